// palpate/mesh.h — surface and tetrahedral meshes, their loaders, validation and statistics.
#pragma once

#include <palpate/core.h>

#include <Eigen/Core>

#include <filesystem>
#include <string>
#include <vector>

namespace palpate {

using RowMat3d = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
using RowMat3i = Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>;
using RowMat4i = Eigen::Matrix<int, Eigen::Dynamic, 4, Eigen::RowMajor>;

// A triangulated surface, libigl style: plain matrices.
struct SurfaceMesh {
  RowMat3d V;  // (#V x 3) vertex positions, m
  RowMat3i F;  // (#F x 3) triangles, counter-clockwise seen from outside, 0-based
  RowMat3d N;  // (#V x 3) unit vertex normals (area-weighted face normals)
};

// A tetrahedral volume mesh.
struct TetMesh {
  RowMat3d V;  // (#V x 3) vertex positions, m
  RowMat4i T;  // (#T x 4) tetrahedra, positively oriented: (v1-v0)·((v2-v0)×(v3-v0)) > 0
};

// What a model needs of a surface beyond being readable.
struct SurfaceRequirements {
  bool manifold = false;  // every edge shared by at most two triangles, consistently oriented
  bool closed = false;    // every edge shared by exactly two triangles
};

// Load a surface: OBJ, STL (ASCII and binary), PLY, OFF (through assimp). Triangulated,
// duplicate vertices merged, normals computed, validated; `scale` multiplies every coordinate.
Result<SurfaceMesh> load_surface(const std::filesystem::path& file, double scale = 1.0,
                                 const SurfaceRequirements& need = {});

// Load a tetrahedral mesh: Gmsh .msh (v1, v2, v4), TetGen .node/.ele (either file's path),
// legacy VTK unstructured grid (.vtk). Validated: no empty mesh, no NaN/Inf, indices in range,
// no degenerate or inverted tetrahedra.
Result<TetMesh> load_tet(const std::filesystem::path& file, double scale = 1.0);

// Validation on meshes built in memory; `where` names the source in the message.
Status validate(const SurfaceMesh& m, const std::string& where, const SurfaceRequirements& need = {});
Status validate(const TetMesh& m, const std::string& where);

// Recompute area-weighted unit vertex normals of a surface.
void compute_normals(SurfaceMesh& m);

// Fill a closed, manifold surface with tetrahedra (Gmsh's mesher). `max_edge` (m) bounds the
// tetrahedra's size, 0 = as the surface's edges; the result meets Gmsh's default quality bound.
Result<TetMesh> tetrahedralize(const SurfaceMesh& surface, double max_edge = 0.0);

// The boundary triangles of a tetrahedral mesh, outward oriented, over the same vertices.
SurfaceMesh boundary_surface(const TetMesh& m);

struct EdgeStats {
  size_t count = 0;
  double min = 0, max = 0, mean = 0, median = 0;  // m
};

// Facts about a mesh, what `palpate info` prints.
struct MeshInfo {
  std::string kind;  // "surface" or "tetrahedral"
  size_t vertices = 0, triangles = 0, tetrahedra = 0;
  Vec3 bbox_min = Vec3::Zero(), bbox_max = Vec3::Zero();
  bool closed = false, manifold = false;
  size_t boundary_edges = 0, non_manifold_edges = 0;
  double volume = 0;  // m³: enclosed volume of a closed surface, or sum of tetrahedra
  EdgeStats edges;
};

MeshInfo describe(const SurfaceMesh& m);
MeshInfo describe(const TetMesh& m);

// True when `file`'s extension names a tetrahedral format palpate reads.
bool is_tet_file(const std::filesystem::path& file);

}  // namespace palpate
