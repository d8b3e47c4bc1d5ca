// palpate/mesh.h — surface and tetrahedral meshes (core): their types, validation and statistics.
// Loading them is palpate/mesh_load.h (io), filling a surface with tetrahedra palpate/meshing.h.
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

// Validation on meshes built in memory; `where` names the source at the head of the message.
// Checks, in order: vertices exist and are finite; elements exist; indices in range; no element
// with area (volume) below 1e-12 x mean edge² (edge³); tetrahedra positively oriented; for a
// surface, `need.manifold`: no edge with more than two triangles or traversed twice the same way;
// `need.closed`: no edge with more than two triangles and none with only one.
Status validate(const SurfaceMesh& m, const std::string& where, const SurfaceRequirements& need = {});
Status validate(const TetMesh& m, const std::string& where);

// Recompute area-weighted unit vertex normals of a surface (a vertex no triangle uses gets 0).
void compute_normals(SurfaceMesh& m);

// A region of a tetrahedral fill meshed finer (a graded mesh, e.g. under an indenter): within
// `radius` (m) of `center` the tetrahedra's edges are about `size` (m); beyond it the size grows
// linearly by `growth` (m per m of distance) until it meets `FillOptions::max_edge` or the
// surface's own edges. The surface's triangles are kept as they are (a fine region at the boundary
// needs a fine surface there).
struct FillRefinement {
  Vec3 center = Vec3::Zero();
  double radius = 0.0;  // m, ≥ 0
  double size = 0.0;    // m, > 0 (and ≤ max_edge when max_edge > 0)
  double growth = 0.3;  // size gained per metre of distance beyond radius, > 0 and ≤ 10
};
struct FillOptions {
  double max_edge = 0.0;                // m, 0 = as the surface's edges
  std::vector<FillRefinement> refine;   // each region's size applies where it is the smallest
};

// The boundary triangles of a tetrahedral mesh (faces used by one tetrahedron), outward oriented
// (also for inverted tetrahedra), over the same vertices, in tetrahedron order; normals computed.
SurfaceMesh boundary_surface(const TetMesh& m);

// Lengths of a mesh's unique edges (the median of an even count is the mean of the middle two).
struct EdgeStats {
  size_t count = 0;
  double min = 0, max = 0, mean = 0, median = 0;  // m
};

// Facts about a mesh, what `palpate info` prints. For a tetrahedral mesh, `triangles`, `closed`,
// `manifold` and the edge counts describe its boundary surface; `edges` its own unique edges.
struct MeshInfo {
  std::string kind;  // "surface" or "tetrahedral"
  size_t vertices = 0, triangles = 0, tetrahedra = 0;
  Vec3 bbox_min = Vec3::Zero(), bbox_max = Vec3::Zero();  // m, over all vertices
  bool closed = false, manifold = false;
  size_t boundary_edges = 0;      // edges of one triangle
  size_t non_manifold_edges = 0;  // edges of more than two triangles, or two in the same direction
  double volume = 0;  // m³, signed: enclosed by a closed surface (divergence theorem; negative when
                      // its triangles face inward), 0 for an open one; sum over tetrahedra
  EdgeStats edges;
};

// A mesh whose indices are out of range gets counts and bounding box only (validate() says why).

MeshInfo describe(const SurfaceMesh& m);
MeshInfo describe(const TetMesh& m);

// True when `file`'s extension names a tetrahedral format palpate reads.
bool is_tet_file(const std::filesystem::path& file);

}  // namespace palpate
