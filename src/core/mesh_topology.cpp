// mesh_topology.cpp — edge incidence and volumes of triangle and tetrahedral meshes.
#include "core/mesh_topology.h"

#include <algorithm>
#include <tuple>

namespace palpate::topology {

std::vector<HalfEdge> sorted_half_edges(const RowMat3i& F) {
  std::vector<HalfEdge> h;
  h.reserve(static_cast<size_t>(F.rows()) * 3);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = F(f, k), b = F(f, (k + 1) % 3);
      h.push_back({std::min(a, b), std::max(a, b), static_cast<int>(f), a < b});
    }
  std::sort(h.begin(), h.end(), [](const HalfEdge& x, const HalfEdge& y) {
    return std::tie(x.lo, x.hi, x.triangle) < std::tie(y.lo, y.hi, y.triangle);
  });
  return h;
}

EdgeCounts count_edges(const std::vector<HalfEdge>& h) {
  EdgeCounts c;
  for (size_t i = 0; i < h.size();) {
    size_t j = i + 1;
    while (j < h.size() && h[j].lo == h[i].lo && h[j].hi == h[i].hi) ++j;
    ++c.edges;
    const size_t uses = j - i;
    if (uses == 1) ++c.boundary;
    else if (uses > 2 || h[i].forward == h[i + 1].forward) ++c.non_manifold;
    if (uses > 2) ++c.over_two;
    i = j;
  }
  return c;
}

double tet_volume(const TetMesh& m, Eigen::Index t) {
  const auto p = [&](int k) -> Vec3 { return m.V.row(m.T(t, k)).transpose(); };
  return tet_volume(p(0), p(1), p(2), p(3));
}

double enclosed_volume(const SurfaceMesh& m) {
  double six_v = 0;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    const Vec3 a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
    six_v += a.dot(b.cross(c));
  }
  return six_v / 6.0;
}

namespace {

template <class Elements>
double mean_element_edge(const RowMat3d& V, const Elements& E) {
  // Every element edge once per element: shared edges count several times, which is fine for
  // the size scale a relative tolerance needs.
  const int n = static_cast<int>(E.cols());
  double sum = 0;
  size_t count = 0;
  for (Eigen::Index e = 0; e < E.rows(); ++e)
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j) {
        sum += (V.row(E(e, i)) - V.row(E(e, j))).norm();
        ++count;
      }
  return count ? sum / static_cast<double>(count) : 0.0;
}

}  // namespace

double mean_edge_length(const RowMat3d& V, const RowMat3i& F) { return mean_element_edge(V, F); }
double mean_edge_length(const RowMat3d& V, const RowMat4i& T) { return mean_element_edge(V, T); }

}  // namespace palpate::topology
