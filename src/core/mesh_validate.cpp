// mesh_validate.cpp — validation of surface and tetrahedral meshes, with errors that name the source and element.
#include <palpate/mesh.h>

#include "core/mesh_topology.h"

#include <fmt/format.h>

#include <cmath>

namespace palpate {

namespace {

// Below this fraction of the mesh's size scale (mean edge², mean edge³) an element has no area
// or volume: 1e-12 leaves room for millimetre elements in a metre-sized scene at double precision.
constexpr double kRelativeTolerance = 1e-12;

Status check_vertices(const RowMat3d& V, const std::string& where) {
  if (V.rows() == 0) return Error{fmt::format("{}: empty mesh: no vertices", where)};
  for (Eigen::Index v = 0; v < V.rows(); ++v)
    if (!V.row(v).allFinite())
      return Error{fmt::format("{}: vertex {} has a non-finite coordinate ({}, {}, {})", where, v, V(v, 0), V(v, 1),
                               V(v, 2))};
  return {};
}

template <class Elements>
Status check_indices(const Elements& E, Eigen::Index num_vertices, const char* kind, const std::string& where) {
  for (Eigen::Index e = 0; e < E.rows(); ++e)
    for (Eigen::Index k = 0; k < E.cols(); ++k)
      if (E(e, k) < 0 || E(e, k) >= num_vertices)
        return Error{fmt::format("{}: {} {} has vertex index {} out of range [0, {})", where, kind, e, E(e, k),
                                 num_vertices)};
  return {};
}

}  // namespace

Status validate(const SurfaceMesh& m, const std::string& where, const SurfaceRequirements& need) {
  if (Status s = check_vertices(m.V, where); !s) return s;
  if (m.F.rows() == 0) return Error{fmt::format("{}: empty mesh: no triangles", where)};
  if (Status s = check_indices(m.F, m.V.rows(), "triangle", where); !s) return s;

  const double edge = topology::mean_edge_length(m.V, m.F);
  const double min_double_area = 2.0 * kRelativeTolerance * edge * edge;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    const Vec3 a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
    const double double_area = (b - a).cross(c - a).norm();
    if (!(double_area > min_double_area))
      return Error{fmt::format("{}: triangle {} (vertices {}, {}, {}) is degenerate: area {:.3g}, expected more than "
                               "{:.3g} (1e-12 x mean edge²)",
                               where, f, m.F(f, 0), m.F(f, 1), m.F(f, 2), 0.5 * double_area, 0.5 * min_double_area)};
  }

  if (!need.manifold && !need.closed) return {};
  const std::vector<topology::HalfEdge> h = topology::sorted_half_edges(m.F);
  size_t boundary = 0;
  const topology::HalfEdge* first_boundary = nullptr;
  for (size_t i = 0; i < h.size();) {
    size_t j = i + 1;
    while (j < h.size() && h[j].lo == h[i].lo && h[j].hi == h[i].hi) ++j;
    const size_t uses = j - i;
    if (uses == 1) {
      if (!first_boundary) first_boundary = &h[i];
      ++boundary;
    }
    if (uses > 2 && (need.manifold || need.closed)) {
      std::string tris;
      for (size_t k = i; k < j; ++k) tris += fmt::format("{}{}", k == i ? "" : ", ", h[k].triangle);
      return Error{fmt::format("{}: non-manifold edge ({}, {}): shared by {} triangles ({}), expected at most 2",
                               where, h[i].lo, h[i].hi, uses, tris)};
    }
    if (uses == 2 && need.manifold && h[i].forward == h[i + 1].forward)
      return Error{fmt::format("{}: non-manifold edge ({}, {}): triangles {} and {} traverse it in the same direction "
                               "(inconsistent orientation)",
                               where, h[i].lo, h[i].hi, h[i].triangle, h[i + 1].triangle)};
    i = j;
  }
  if (need.closed && boundary > 0)
    return Error{fmt::format("{}: open surface: {} boundary edge{}, e.g. edge ({}, {}) of triangle {} has no "
                             "neighbour; expected a closed surface",
                             where, boundary, boundary == 1 ? "" : "s", first_boundary->lo, first_boundary->hi,
                             first_boundary->triangle)};
  return {};
}

Status validate(const TetMesh& m, const std::string& where) {
  if (Status s = check_vertices(m.V, where); !s) return s;
  if (m.T.rows() == 0) return Error{fmt::format("{}: empty mesh: no tetrahedra", where)};
  if (Status s = check_indices(m.T, m.V.rows(), "tetrahedron", where); !s) return s;
  const double edge = topology::mean_edge_length(m.V, m.T);
  const double min_volume = kRelativeTolerance * edge * edge * edge;
  for (Eigen::Index t = 0; t < m.T.rows(); ++t) {
    const double v = topology::tet_volume(m, t);
    if (!(std::abs(v) > min_volume))
      return Error{fmt::format("{}: tetrahedron {} (vertices {}, {}, {}, {}) is degenerate: volume {:.3g}, expected "
                               "more than {:.3g} (1e-12 x mean edge³)",
                               where, t, m.T(t, 0), m.T(t, 1), m.T(t, 2), m.T(t, 3), v, min_volume)};
    if (v < 0)
      return Error{fmt::format("{}: tetrahedron {} (vertices {}, {}, {}, {}) is inverted: volume {:.6g} < 0, expected "
                               "(v1-v0)·((v2-v0)×(v3-v0)) > 0",
                               where, t, m.T(t, 0), m.T(t, 1), m.T(t, 2), m.T(t, 3), v)};
  }
  return {};
}

}  // namespace palpate
