// fill.h — internal: the tetrahedral fill's mesher side, behind tetrahedralize (fill.cpp), which
// checks the options and the surface before and orients and validates the tetrahedra after.
#pragma once

#include <palpate/mesh.h>

#include <string>

namespace palpate::meshing {

// Gmsh's Delaunay fill of a checked closed, manifold surface (fill_gmsh.cpp); built without Gmsh
// (PALPATE_WITH_GMSH=OFF), fill_none.cpp fails naming the option. Errors name `where`.
Result<TetMesh> gmsh_fill(const SurfaceMesh& surface, const FillOptions& options, const std::string& where);

}  // namespace palpate::meshing
