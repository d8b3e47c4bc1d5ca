// mesh_topology.h — internal: edge incidence and volumes of triangle and tetrahedral meshes,
// shared by validation, describe() and boundary extraction.
#pragma once

#include <palpate/mesh.h>

#include <vector>

namespace palpate::topology {

// One triangle's use of an edge: the edge is (lo, hi) with lo < hi; `forward` when the triangle
// traverses it from lo to hi.
struct HalfEdge {
  int lo = 0, hi = 0;
  int triangle = 0;
  bool forward = false;
};

// The 3·#F half-edges of `F`, sorted by (lo, hi, triangle): the uses of one edge are adjacent.
std::vector<HalfEdge> sorted_half_edges(const RowMat3i& F);

// Edge-use summary of a triangle surface.
struct EdgeCounts {
  size_t edges = 0;         // unique edges
  size_t boundary = 0;      // used by one triangle
  size_t non_manifold = 0;  // used by more than two triangles, or twice in the same direction
  size_t over_two = 0;      // used by more than two triangles (a subset of non_manifold)
};
EdgeCounts count_edges(const std::vector<HalfEdge>& half_edges);

// Signed volume of tetrahedron (a, b, c, d): (b−a)·((c−a)×(d−a)) / 6, m³.
inline double tet_volume(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  return (b - a).dot((c - a).cross(d - a)) / 6.0;
}
double tet_volume(const TetMesh& m, Eigen::Index t);

// Volume enclosed by a closed surface by the divergence theorem, Σ a·(b×c)/6 over triangles, m³;
// positive when the triangles are counter-clockwise seen from outside.
double enclosed_volume(const SurfaceMesh& m);

// Mean length of the element edges of `F` (triangles) or `T` (tetrahedra), each counted once per
// element that has it (a size scale for tolerances, not a statistic), m; 0 when none.
double mean_edge_length(const RowMat3d& V, const RowMat3i& F);
double mean_edge_length(const RowMat3d& V, const RowMat4i& T);

}  // namespace palpate::topology
