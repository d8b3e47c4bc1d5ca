// palpate/mesh_load.h — surface and tetrahedral mesh files (the io layer).
#pragma once

#include <palpate/core.h>
#include <palpate/mesh.h>

#include <filesystem>

namespace palpate {

// Load a surface: OBJ, STL (ASCII and binary), PLY, OFF (through assimp; any other extension is
// refused, even one assimp reads: only these four are tested and fuzzed). Triangulated, all meshes of the file concatenated, vertices
// merged by exact position (corners that differ only in normal or UV become one vertex), normals
// computed, validated against `need`; `scale` (> 0) multiplies every coordinate. A closed,
// consistently oriented surface whose triangles face inward is turned outward. Errors start with
// the file's path, e.g. "liver.obj: triangle 17 has vertex index 999 out of range [0, 181)".
Result<SurfaceMesh> load_surface(const std::filesystem::path& file, double scale = 1.0,
                                 const SurfaceRequirements& need = {});

// Load a tetrahedral mesh: Gmsh .msh (v1, v2, v4 ASCII or binary, through Gmsh; vertices in node
// tag order, only 4-node tetrahedra kept), TetGen .node/.ele (either file's path; 0- or 1-based;
// quadratic elements keep their corners), legacy ASCII VTK unstructured grid (.vtk, file versions
// up to 5.1; cells of type 10 kept). Validated: no empty mesh, no NaN/Inf, indices in range, no
// degenerate or inverted tetrahedra. Errors name the file, and the line where the reader knows it.
// Built without Gmsh (PALPATE_WITH_GMSH=OFF), a .msh file that passes palpate's own checks is
// refused with an error naming the option.
Result<TetMesh> load_tet(const std::filesystem::path& file, double scale = 1.0);

}  // namespace palpate
