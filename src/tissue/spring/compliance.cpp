// compliance.cpp — the exact compliance of a mass-spring organ's vertices, W = h² A⁻¹ restricted
// to them (from the predictor's factor, one forward substitution along an elimination-tree path
// per vertex, cached), and the contact patch a multi-rate loop solves against (issue 24).
#include <palpate/contact.h>
#include <palpate/spring.h>

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <vector>

namespace palpate {

namespace {

// y = L⁻¹ e_perm[v] for up to kBatch vertices at once (column b of the interleaved y, kBatch
// doubles per permuted row), along the union of their elimination-tree paths (sorted into
// `path`, marked in `mark`). after(j) runs once column j is final. The caller clears mark and y
// over `path` when done.
template <int kBatch, class After>
void substitute_batch(const SpringPredictor& p, const std::vector<int>& parent, std::vector<int>& mark,
                      std::vector<int>& path, std::vector<double>& y, const int* vertices, int count,
                      After&& after) {
  path.clear();
  for (int b = 0; b < count; ++b) {
    const int col = p.perm[static_cast<size_t>(vertices[b])];
    y[static_cast<size_t>(col) * kBatch + static_cast<size_t>(b)] = 1.0;
    for (int j = col; j >= 0 && !mark[static_cast<size_t>(j)]; j = parent[static_cast<size_t>(j)]) {
      mark[static_cast<size_t>(j)] = 1;
      path.push_back(j);
    }
  }
  std::sort(path.begin(), path.end());
  for (int j : path) {
    const double* yj = &y[static_cast<size_t>(j) * kBatch];
    for (int k = p.col_start[static_cast<size_t>(j)]; k < p.col_start[static_cast<size_t>(j) + 1]; ++k) {
      double* yr = &y[static_cast<size_t>(p.row[static_cast<size_t>(k)]) * kBatch];
      const double v = p.value[static_cast<size_t>(k)];
      for (int b = 0; b < kBatch; ++b) yr[b] -= v * yj[b];
    }
    after(j);
  }
}
constexpr int kBatch = 8;  // vertices forward-substituted together (the factor's columns read once)
}

SpringCompliance::SpringCompliance(const SpringModel& model, int capacity) : model_(model) {
  const SpringPredictor& p = model.predictor;
  n_ = static_cast<int>(model.network.size());
  const bool sparse = p.kind == SpringSolver::sparse && p.n == n_ && !p.inv_diag.empty() &&
                      p.col_start.size() == static_cast<size_t>(n_) + 1;
  const bool dense = p.kind == SpringSolver::desbrun && p.inverse.size() == static_cast<size_t>(n_) * static_cast<size_t>(n_);
  available_ = (sparse || dense) && !model.network.triangles.empty();
  if (!available_) return;
  if (sparse) {
    parent_.assign(static_cast<size_t>(n_), -1);
    for (int j = 0; j < n_; ++j)
      if (p.col_start[static_cast<size_t>(j)] < p.col_start[static_cast<size_t>(j) + 1])
        parent_[static_cast<size_t>(j)] = p.row[static_cast<size_t>(p.col_start[static_cast<size_t>(j)])];
    slots_.resize(static_cast<size_t>(std::max(capacity, kBatch)));
    slot_of_.assign(static_cast<size_t>(n_), -1);
    y_.assign(static_cast<size_t>(n_) * kBatch, 0.0);
    mark_.assign(static_cast<size_t>(n_), 0);
    union_.reserve(static_cast<size_t>(n_));
  }
  // The surface: its vertices, each vertex's triangles, its longest edge.
  const auto& tris = model.network.triangles;
  tri_start_.assign(static_cast<size_t>(n_) + 1, 0);
  for (const auto& t : tris)
    for (int v : t) ++tri_start_[static_cast<size_t>(v) + 1];
  for (int i = 0; i < n_; ++i) {
    if (tri_start_[static_cast<size_t>(i) + 1] > 0) surface_.push_back(i);
    tri_start_[static_cast<size_t>(i) + 1] += tri_start_[static_cast<size_t>(i)];
  }
  tri_of_.resize(static_cast<size_t>(tri_start_.back()));
  std::vector<int> fill(tri_start_.begin(), tri_start_.end() - 1);
  for (size_t t = 0; t < tris.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const int v = tris[t][static_cast<size_t>(k)];
      tri_of_[static_cast<size_t>(fill[static_cast<size_t>(v)]++)] = static_cast<int>(t);
      const int w = tris[t][static_cast<size_t>((k + 1) % 3)];
      max_edge_ = std::max(max_edge_, (model.network.rest.row(v) - model.network.rest.row(w)).norm());
    }
  near_.reserve(surface_.size());
  local_.assign(static_cast<size_t>(n_), -1);
}

// z_i = D^-½ L⁻¹ P e_i for up to kBatch vertices at once: y = L⁻¹ e_p is nonzero only on the
// elimination-tree path from p = perm[i] to its root (every row below the diagonal of column j of L
// is an ancestor of j), so the substitution visits the union of the paths, in ascending order.
void SpringCompliance::compute(std::span<const int> vertices) {
  const SpringPredictor& p = model_.predictor;
  const int B = static_cast<int>(vertices.size());
  substitute_batch<kBatch>(p, parent_, mark_, union_, y_, vertices.data(), B, [](int) {});
  for (int b = 0; b < B; ++b) {
    const int vertex = vertices[static_cast<size_t>(b)];
    // The least recently used slot.
    size_t best = 0;
    for (size_t s = 1; s < slots_.size(); ++s)
      if (slots_[s].used < slots_[best].used) best = s;
    Slot& slot = slots_[best];
    if (slot.vertex >= 0) slot_of_[static_cast<size_t>(slot.vertex)] = -1;
    else ++cached_;
    slot.vertex = vertex;
    slot.used = ++clock_;
    slot.index.clear();
    slot.z.clear();
    if (!model_.anchored[static_cast<size_t>(vertex)])  // an anchored vertex does not move: W = 0
      for (int j = p.perm[static_cast<size_t>(vertex)]; j >= 0; j = parent_[static_cast<size_t>(j)]) {
        slot.index.push_back(j);
        slot.z.push_back(y_[static_cast<size_t>(j) * kBatch + static_cast<size_t>(b)] *
                         std::sqrt(p.inv_diag[static_cast<size_t>(j)]));
      }
    slot_of_[static_cast<size_t>(vertex)] = static_cast<int>(best);
    ++computed_;
  }
  for (int j : union_) {
    mark_[static_cast<size_t>(j)] = 0;
    std::fill_n(&y_[static_cast<size_t>(j) * kBatch], kBatch, 0.0);
  }
}

void SpringCompliance::diagonal(std::span<const int> vertices, std::span<double> d) {
  const SpringPredictor& p = model_.predictor;
  const size_t count = std::min(vertices.size(), d.size());
  if (!available_) { std::fill_n(d.begin(), count, 0.0); return; }
  if (p.kind == SpringSolver::desbrun) {
    for (size_t a = 0; a < count; ++a) {
      const size_t i = static_cast<size_t>(vertices[a]);
      d[a] = model_.anchored[i] ? 0.0 : p.inverse[i * static_cast<size_t>(n_) + i];
    }
    return;
  }
  // (A⁻¹)_ii = Σ_j y_j² / D_j over the path, y = L⁻¹ e_perm[i]: the batch's substitution as in
  // compute(), its squares summed instead of kept.
  for (size_t start = 0; start < count; start += kBatch) {
    const int B = static_cast<int>(std::min<size_t>(kBatch, count - start));
    double sum[kBatch] = {};
    substitute_batch<kBatch>(p, parent_, mark_, union_, y_, vertices.data() + start, B, [&](int j) {
      const double* yj = &y_[static_cast<size_t>(j) * kBatch];
      const double inv = p.inv_diag[static_cast<size_t>(j)];
      for (int b = 0; b < kBatch; ++b) sum[b] += yj[b] * yj[b] * inv;
    });
    for (int b = 0; b < B; ++b) {
      const size_t i = static_cast<size_t>(vertices[start + static_cast<size_t>(b)]);
      d[start + static_cast<size_t>(b)] = model_.anchored[i] ? 0.0 : sum[b];
    }
    for (int j : union_) {
      mark_[static_cast<size_t>(j)] = 0;
      std::fill_n(&y_[static_cast<size_t>(j) * kBatch], kBatch, 0.0);
    }
  }
}

bool use_exact_contact_compliance(SpringModel& model) {
  if (model.contact_compliance_exact) return true;
  std::vector<double> d;
  {
    SpringCompliance c(model, kBatch);
    if (!c.available() || c.surface().empty()) return false;
    d.resize(c.surface().size());
    c.diagonal(c.surface(), d);
    // Only vertices of the surface touch the tool; the others keep the mass bound (unused).
    for (size_t a = 0; a < d.size(); ++a) {
      const size_t i = static_cast<size_t>(c.surface()[a]);
      // (A⁻¹)_ii ≤ 1/(m_i + hγ) in exact arithmetic; never looser than the bound it replaces.
      if (std::isfinite(d[a]) && d[a] >= 0) model.contact_compliance[i] = std::min(model.contact_compliance[i], d[a]);
    }
  }
  model.contact_compliance_exact = true;
  return true;
}

void SpringCompliance::block(std::span<const int> vertices, std::span<double> w) {
  const size_t m = vertices.size();
  const double h2 = model_.options.dt * model_.options.dt;
  const SpringPredictor& p = model_.predictor;
  if (p.kind == SpringSolver::desbrun) {
    const size_t n = static_cast<size_t>(n_);
    for (size_t a = 0; a < m; ++a)
      for (size_t b = 0; b < m; ++b) {
        const int i = vertices[a], j = vertices[b];
        w[a * m + b] = model_.anchored[static_cast<size_t>(i)] || model_.anchored[static_cast<size_t>(j)]
                           ? 0.0
                           : h2 * p.inverse[static_cast<size_t>(i) * n + static_cast<size_t>(j)];
      }
    return;
  }
  // The missing vertices, kBatch at a time (each marked as used so the batch does not evict them).
  int missing[kBatch];
  int count = 0;
  for (size_t a = 0; a < m; ++a) {
    const int v = vertices[a];
    const int s = slot_of_[static_cast<size_t>(v)];
    if (s >= 0) { slots_[static_cast<size_t>(s)].used = ++clock_; continue; }
    bool queued = false;
    for (int k = 0; k < count; ++k) queued = queued || missing[k] == v;
    if (queued) continue;
    missing[count++] = v;
    if (count == kBatch) { compute({missing, static_cast<size_t>(count)}); count = 0; }
  }
  if (count > 0) compute({missing, static_cast<size_t>(count)});
  // Z (union x m), dense, then W = h² ZᵀZ.
  union_.clear();
  for (size_t a = 0; a < m; ++a)
    for (int j : slots_[static_cast<size_t>(slot_of_[static_cast<size_t>(vertices[a])])].index)
      if (!mark_[static_cast<size_t>(j)]) { mark_[static_cast<size_t>(j)] = 1; union_.push_back(j); }
  std::sort(union_.begin(), union_.end());
  for (size_t r = 0; r < union_.size(); ++r) mark_[static_cast<size_t>(union_[r])] = static_cast<int>(r) + 1;
  const size_t U = union_.size();
  if (dense_.size() < U * m) dense_.resize(U * m);
  std::fill_n(dense_.begin(), U * m, 0.0);
  for (size_t a = 0; a < m; ++a) {
    const Slot& s = slots_[static_cast<size_t>(slot_of_[static_cast<size_t>(vertices[a])])];
    for (size_t k = 0; k < s.index.size(); ++k)
      dense_[a * U + static_cast<size_t>(mark_[static_cast<size_t>(s.index[k])] - 1)] = s.z[k];
  }
  for (int j : union_) mark_[static_cast<size_t>(j)] = 0;
  using Mat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const Eigen::Map<const Mat> Z(dense_.data(), static_cast<Eigen::Index>(m), static_cast<Eigen::Index>(U));
  Eigen::Map<Mat> W(w.data(), static_cast<Eigen::Index>(m), static_cast<Eigen::Index>(m));
  W.noalias() = h2 * (Z * Z.transpose());
}

bool SpringCompliance::contact_patch(const SpringState& state, const ToolState& tool, double margin,
                                     ContactPatch& patch) {
  patch.point_count = patch.triangle_count = 0;
  if (!available_ || !tool.tip.allFinite() || !(tool.radius > 0) || model_.options.contact != SpringContact::surface)
    return false;
  const Vec3 c = tool.tip;
  const double reach = tool.radius + std::max(0.0, margin) + 1.5 * max_edge_;
  near_.clear();
  for (int v : surface_) {
    const double d = (state.x.row(v).transpose() - c).norm();
    if (d <= reach) near_.emplace_back(d, v);
  }
  if (near_.empty()) return false;
  double covered = reach;  // every surface vertex within this distance of c is in the patch
  const size_t cap = ContactPatch::kMaxPoints;
  if (near_.size() > cap) {
    std::nth_element(near_.begin(), near_.begin() + static_cast<std::ptrdiff_t>(cap), near_.end());
    covered = near_[cap].first;
    near_.resize(cap);
  }
  std::sort(near_.begin(), near_.end(), [](const auto& a, const auto& b) { return a.second < b.second; });
  const int m = static_cast<int>(near_.size());
  for (int a = 0; a < m; ++a) local_[static_cast<size_t>(near_[static_cast<size_t>(a)].second)] = a;
  // Triangles with all three corners in the patch, nearest corners first is not needed: at most
  // kMaxTriangles, taken in the order their corners come.
  const auto& tris = model_.network.triangles;
  for (int a = 0; a < m && patch.triangle_count < ContactPatch::kMaxTriangles; ++a) {
    const int v = near_[static_cast<size_t>(a)].second;
    for (int k = tri_start_[static_cast<size_t>(v)]; k < tri_start_[static_cast<size_t>(v) + 1]; ++k) {
      const auto& T = tris[static_cast<size_t>(tri_of_[static_cast<size_t>(k)])];
      const int l0 = local_[static_cast<size_t>(T[0])], l1 = local_[static_cast<size_t>(T[1])],
                l2 = local_[static_cast<size_t>(T[2])];
      if (l0 < 0 || l1 < 0 || l2 < 0) continue;
      if (std::min({l0, l1, l2}) != a) continue;  // each triangle once: from its lowest corner
      if (patch.triangle_count == ContactPatch::kMaxTriangles) { covered = 0; break; }
      patch.triangle[static_cast<size_t>(patch.triangle_count++)] = {l0, l1, l2};
    }
  }
  // W among the patch's vertices: reused while the patch holds the same vertices.
  bool same = static_cast<int>(patch_vertices_.size()) == m;
  for (int a = 0; same && a < m; ++a) same = patch_vertices_[static_cast<size_t>(a)] == near_[static_cast<size_t>(a)].second;
  if (!same) {
    patch_vertices_.resize(static_cast<size_t>(m));
    for (int a = 0; a < m; ++a) patch_vertices_[static_cast<size_t>(a)] = near_[static_cast<size_t>(a)].second;
    patch_w_.resize(static_cast<size_t>(m) * static_cast<size_t>(m));
    block(patch_vertices_, patch_w_);
  }
  const size_t M = static_cast<size_t>(m);
  std::copy_n(patch_w_.begin(), M * M, patch.compliance.begin());
  // Free positions: the step's positions less W times the contact load it ended with.
  for (size_t a = 0; a < M; ++a) {
    patch.free_position[a] = state.x.row(patch_vertices_[a]).transpose();
    patch.free_velocity[a] = state.v.row(patch_vertices_[a]).transpose();
  }
  for (int k = 0; k < state.contact_vertex_count; ++k) {
    const int b = local_[static_cast<size_t>(state.contact_vertex[static_cast<size_t>(k)])];
    if (b < 0) continue;
    const Vec3& load = state.contact_load[static_cast<size_t>(k)];
    for (size_t a = 0; a < M; ++a) patch.free_position[a] -= patch.compliance[a * M + static_cast<size_t>(b)] * load;
  }
  for (int a = 0; a < m; ++a) local_[static_cast<size_t>(patch_vertices_[static_cast<size_t>(a)])] = -1;
  patch.point_count = m;
  patch.stiffness = model_.options.contact_stiffness;
  patch.centre = c;
  patch.reach = std::max(0.0, covered - tool.radius - 1.5 * max_edge_);
  return true;
}

}  // namespace palpate
