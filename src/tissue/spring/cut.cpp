// cut.cpp — cutting a mass-spring organ: removing springs and tetrahedra from a live model, and
// keeping its predictor exact with a Woodbury correction and new factors built off the haptic
// thread (SpringCutter, palpate/spring.h; the algebra in cut.h; docs/models/cutting.md).
#include <palpate/spring.h>

#include "tissue/spring/cut.h"
#include "tissue/spring/forces.h"
#include "tissue/spring/layouts.h"
#include "tissue/spring/solve.h"

#include <Eigen/LU>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <string>
#include <thread>
#include <unordered_map>

namespace palpate {

namespace spring {

void apply_middle(const PredictorCorrection& c, double* z4) noexcept {
  const int r = c.rank;
  double* q = c.q.data();
  double* s = c.s.data();
  // q = Vᵀ t
  for (int e = 0; e < r; ++e) {
    double q0 = 0, q1 = 0, q2 = 0;
    for (int k = c.col_start[static_cast<size_t>(e)]; k < c.col_start[static_cast<size_t>(e) + 1]; ++k) {
      const double* t = z4 + 4 * static_cast<size_t>(c.row[static_cast<size_t>(k)]);
      const double v = c.v[static_cast<size_t>(k)];
      q0 += v * t[0]; q1 += v * t[1]; q2 += v * t[2];
    }
    q[3 * e] = q0; q[3 * e + 1] = q1; q[3 * e + 2] = q2;
  }
  // s = M q
  for (int a = 0; a < r; ++a) {
    double s0 = 0, s1 = 0, s2 = 0;
    const double* m = c.m.data() + static_cast<size_t>(a) * static_cast<size_t>(r);
    for (int b = 0; b < r; ++b) {
      s0 += m[b] * q[3 * b]; s1 += m[b] * q[3 * b + 1]; s2 += m[b] * q[3 * b + 2];
    }
    s[3 * a] = s0; s[3 * a + 1] = s1; s[3 * a + 2] = s2;
  }
  // t += D⁻¹ V s
  for (int e = 0; e < r; ++e) {
    const double s0 = s[3 * e], s1 = s[3 * e + 1], s2 = s[3 * e + 2];
    for (int k = c.col_start[static_cast<size_t>(e)]; k < c.col_start[static_cast<size_t>(e) + 1]; ++k) {
      double* t = z4 + 4 * static_cast<size_t>(c.row[static_cast<size_t>(k)]);
      const double d = c.dv[static_cast<size_t>(k)];
      t[0] += d * s0; t[1] += d * s1; t[2] += d * s2;
    }
  }
}

void apply_dense(const PredictorCorrection& c, int n, double* x) noexcept {
  const int r = c.rank;
  double* q = c.q.data();
  double* s = c.s.data();
  for (int e = 0; e < r; ++e) {  // q = Uᵀ x
    const auto [i, j] = c.edge[static_cast<size_t>(e)];
    for (int k = 0; k < 3; ++k)
      q[3 * e + k] = (i >= 0 ? x[3 * i + k] : 0.0) - (j >= 0 ? x[3 * j + k] : 0.0);
  }
  for (int a = 0; a < r; ++a) {  // s = M q
    double s0 = 0, s1 = 0, s2 = 0;
    const double* m = c.m.data() + static_cast<size_t>(a) * static_cast<size_t>(r);
    for (int b = 0; b < r; ++b) {
      s0 += m[b] * q[3 * b]; s1 += m[b] * q[3 * b + 1]; s2 += m[b] * q[3 * b + 2];
    }
    s[3 * a] = s0; s[3 * a + 1] = s1; s[3 * a + 2] = s2;
  }
  for (int i = 0; i < n; ++i) {  // x += Z s
    const double* z = c.z.data() + static_cast<size_t>(i) * static_cast<size_t>(r);
    double x0 = 0, x1 = 0, x2 = 0;
    for (int e = 0; e < r; ++e) {
      x0 += z[e] * s[3 * e]; x1 += z[e] * s[3 * e + 1]; x2 += z[e] * s[3 * e + 2];
    }
    x[3 * i] += x0; x[3 * i + 1] += x1; x[3 * i + 2] += x2;
  }
}

PredictorCorrection build_correction(const SpringPredictor& p, const std::vector<std::uint8_t>& anchored,
                                     const std::vector<EdgeWeight>& removed) {
  PredictorCorrection c;
  std::vector<double> w;
  for (const EdgeWeight& e : removed) {
    const int i = anchored[static_cast<size_t>(e.i)] ? -1 : e.i, j = anchored[static_cast<size_t>(e.j)] ? -1 : e.j;
    if ((i < 0 && j < 0) || e.w == 0) continue;
    c.edge.push_back({i, j});
    w.push_back(e.w);
  }
  const int r = static_cast<int>(c.edge.size());
  c.rank = r;
  c.q.assign(3 * static_cast<size_t>(r), 0.0);
  c.s.assign(3 * static_cast<size_t>(r), 0.0);
  if (r == 0) return c;
  const int n = p.n;
  Eigen::MatrixXd G(r, r);  // Uᵀ A⁻¹ U
  if (p.kind == SpringSolver::desbrun) {
    c.z.assign(static_cast<size_t>(n) * static_cast<size_t>(r), 0.0);
    const double* W = p.inverse.data();
    for (int e = 0; e < r; ++e) {
      const auto [i, j] = c.edge[static_cast<size_t>(e)];
      for (int k = 0; k < n; ++k) {  // A⁻¹ is symmetric: its rows i, j are its columns
        const double zi = i >= 0 ? W[static_cast<size_t>(i) * static_cast<size_t>(n) + static_cast<size_t>(k)] : 0.0;
        const double zj = j >= 0 ? W[static_cast<size_t>(j) * static_cast<size_t>(n) + static_cast<size_t>(k)] : 0.0;
        c.z[static_cast<size_t>(k) * static_cast<size_t>(r) + static_cast<size_t>(e)] = zi - zj;
      }
    }
    for (int a = 0; a < r; ++a) {
      const auto [i, j] = c.edge[static_cast<size_t>(a)];
      for (int b = 0; b < r; ++b) {
        const double zi = i >= 0 ? c.z[static_cast<size_t>(i) * static_cast<size_t>(r) + static_cast<size_t>(b)] : 0.0;
        const double zj = j >= 0 ? c.z[static_cast<size_t>(j) * static_cast<size_t>(r) + static_cast<size_t>(b)] : 0.0;
        G(a, b) = zi - zj;
      }
    }
  } else {
    // V's columns: forward substitution of e_perm[i] − e_perm[j] along the elimination tree (the
    // first row below a column's diagonal is its parent), touching only the two paths to the root.
    std::vector<int> parent(static_cast<size_t>(n), -1);
    for (int col = 0; col < n; ++col)
      if (p.col_start[static_cast<size_t>(col)] < p.col_start[static_cast<size_t>(col) + 1])
        parent[static_cast<size_t>(col)] = p.row[static_cast<size_t>(p.col_start[static_cast<size_t>(col)])];
    std::vector<double> y(static_cast<size_t>(n), 0.0);
    std::vector<std::uint8_t> mark(static_cast<size_t>(n), 0);
    std::vector<int> path;
    c.col_start.push_back(0);
    for (int e = 0; e < r; ++e) {
      path.clear();
      for (int v : c.edge[static_cast<size_t>(e)]) {
        if (v < 0) continue;
        for (int col = p.perm[static_cast<size_t>(v)]; col >= 0 && !mark[static_cast<size_t>(col)];
             col = parent[static_cast<size_t>(col)]) {
          mark[static_cast<size_t>(col)] = 1;
          path.push_back(col);
        }
      }
      std::sort(path.begin(), path.end());
      const auto [i, j] = c.edge[static_cast<size_t>(e)];
      if (i >= 0) y[static_cast<size_t>(p.perm[static_cast<size_t>(i)])] += 1.0;
      if (j >= 0) y[static_cast<size_t>(p.perm[static_cast<size_t>(j)])] -= 1.0;
      for (int col : path) {
        const double yc = y[static_cast<size_t>(col)];
        if (yc == 0) continue;
        for (int q = p.col_start[static_cast<size_t>(col)]; q < p.col_start[static_cast<size_t>(col) + 1]; ++q)
          y[static_cast<size_t>(p.row[static_cast<size_t>(q)])] -= p.value[static_cast<size_t>(q)] * yc;
      }
      for (int col : path) {
        const double v = y[static_cast<size_t>(col)];
        if (v != 0) {
          c.row.push_back(col);
          c.v.push_back(v);
          c.dv.push_back(v * p.inv_diag[static_cast<size_t>(col)]);
        }
        y[static_cast<size_t>(col)] = 0;
        mark[static_cast<size_t>(col)] = 0;
      }
      c.col_start.push_back(static_cast<int>(c.row.size()));
    }
    // G = Vᵀ D⁻¹ V, column by column through a scattered copy.
    std::vector<double> dense(static_cast<size_t>(n), 0.0);
    for (int b = 0; b < r; ++b) {
      for (int k = c.col_start[static_cast<size_t>(b)]; k < c.col_start[static_cast<size_t>(b) + 1]; ++k)
        dense[static_cast<size_t>(c.row[static_cast<size_t>(k)])] = c.dv[static_cast<size_t>(k)];
      for (int a = 0; a < r; ++a) {
        double sum = 0;
        for (int k = c.col_start[static_cast<size_t>(a)]; k < c.col_start[static_cast<size_t>(a) + 1]; ++k)
          sum += c.v[static_cast<size_t>(k)] * dense[static_cast<size_t>(c.row[static_cast<size_t>(k)])];
        G(a, b) = sum;
      }
      for (int k = c.col_start[static_cast<size_t>(b)]; k < c.col_start[static_cast<size_t>(b) + 1]; ++k)
        dense[static_cast<size_t>(c.row[static_cast<size_t>(k)])] = 0;
    }
  }
  // M = (I − W G)⁻¹ W: no division by a weight, so a tiny removed weight is harmless.
  Eigen::MatrixXd K = Eigen::MatrixXd::Identity(r, r);
  Eigen::MatrixXd Wd = Eigen::MatrixXd::Zero(r, r);
  for (int a = 0; a < r; ++a) {
    Wd(a, a) = w[static_cast<size_t>(a)];
    for (int b = 0; b < r; ++b) K(a, b) -= w[static_cast<size_t>(a)] * G(a, b);
  }
  const Eigen::PartialPivLU<Eigen::MatrixXd> lu(K);
  c.rcond = lu.rcond();
  const Eigen::MatrixXd M = lu.solve(Wd);
  c.m.resize(static_cast<size_t>(r) * static_cast<size_t>(r));
  for (int a = 0; a < r; ++a)
    for (int b = 0; b < r; ++b) c.m[static_cast<size_t>(a) * static_cast<size_t>(r) + static_cast<size_t>(b)] = M(a, b);
  return c;
}

}  // namespace spring

using spring::EdgeWeight;
using spring::PredictorCorrection;

namespace {

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// What the worker hands the stepping thread: a correction for the first `coverage` removals,
// relative to the factor installed with it (a new one when has_factor) or the one already in use.
struct Package {
  int coverage = 0;
  bool has_factor = false;
  SpringPredictor predictor;          // has_factor: the new factor (after the swap: the old one)
  spring::SpringSupernodes supernodes;
  std::vector<float> inverse_single;
  PredictorCorrection correction;
  double correction_ms = 0, factor_ms = 0;
  Package* next = nullptr;            // the retired list
};

// The smallest reciprocal condition of a correction's capacitance matrix kept as a correction.
constexpr double kMinRcond = 1e-4;

struct Removal {
  int kind = 0;   // 0 spring, 1 tetrahedron
  int index = 0;
};

}  // namespace

struct SpringCutter::Impl {
  SpringModel& model;
  SpringCutOptions options;
  int n = 0;
  double h = 0;
  std::vector<std::uint8_t> anchored;
  // Constant: each tetrahedron's six edges (spring indices, −1 when its edge is not a spring) and
  // its share of their predictor weight; the tetrahedra of each spring (CSR).
  std::vector<std::array<int, 6>> tet_edge;
  std::vector<std::array<double, 6>> tet_share;
  std::vector<int> spring_tet_start, spring_tet;
  int max_height = 0;  // the supernodes' (a refactor must keep it)
  // The drawn surface kept closed (model.network.triangles, capacity reserved): every face of a
  // tetrahedron with the tetrahedra on its two sides (−1: none) and its outward corners from each;
  // the boundary faces are those with one live tetrahedron, each at face_slot in the triangles.
  // A network without tetrahedra: its triangles are the faces (no tetrahedron), and a removed
  // spring takes the triangles on it away (spring_face CSR).
  bool surface = false;
  std::vector<std::array<int, 2>> face_tet;
  std::vector<std::array<std::array<int, 3>, 2>> face_tri;
  std::vector<std::array<int, 4>> tet_face;
  std::vector<int> face_slot, slot_face;       // (F), (capacity F)
  std::vector<int> spring_face_start, spring_face;
  std::vector<int> vertex_faces;               // boundary faces on each vertex
  // Edge-manifold repair: the faces on each spring (CSR), and a queue of springs whose boundary
  // faces changed. An edge with more than two boundary faces (two fans of tetrahedra meeting only at
  // it) has all its tetrahedra removed, and the edges that change by it are checked in turn.
  std::vector<int> edge_face_start, edge_face;
  std::vector<int> face_edge;                  // (3F) the springs of each face's edges, −1 when none
  std::vector<int> queue;                      // (capacity S)
  std::vector<std::uint8_t> queued;
  bool repairing = false;

  // Stepping thread.
  std::vector<std::uint8_t> spring_removed, tet_removed;
  std::vector<Removal> log;               // capacity max_removals, written before `logged` moves
  std::atomic<int> logged{0};
  Package* installed = nullptr;
  int installed_coverage = 0;
  std::uint64_t calls = 0;
  std::vector<int> counts;                // fixed_latency: `logged` at the last fixed_latency calls (ring)
  std::vector<std::int32_t> schedule;     // a replay's coverage per install() call (set_install_schedule)
  size_t scheduled = 0;                   // the schedule's next entry
  SpringCutStatus stat;

  // Between the threads.
  std::atomic<Package*> ready{nullptr};
  std::atomic<Package*> retired{nullptr};
  std::atomic<int> requested{0};          // fixed_latency: the coverage wanted now
  std::atomic<bool> stop{false};
  std::atomic<int> worker_error{0};
  std::thread worker;

  // The worker's own copy of the weights.
  SpringNetwork base;                     // the network for assembling A: tets none, stiffness = predictor weight
  std::vector<double> kp, damp;           // the weights after the removals applied so far
  std::vector<double> kp_factor, damp_factor;  // those of the factor in use (or on its way)
  std::vector<std::uint8_t> w_spring, w_tet;   // removals applied so far (the worker's)
  std::vector<int> dirty;                 // edges changed since the factor
  std::vector<std::uint8_t> is_dirty;
  int applied = 0;                        // log records applied to kp, damp
  int built = 0;                          // coverage of the last package published
  SpringPredictor factor;                 // the worker's copy of the factor in use (pattern and values)

  Impl(SpringModel& m, const SpringCutOptions& o) : model(m), options(o) {}

  // ---- stepping thread ----
  void log_removal(int kind, int index) noexcept {
    const int k = logged.load(std::memory_order_relaxed);
    log[static_cast<size_t>(k)] = {kind, index};
    logged.store(k + 1, std::memory_order_release);
  }
  bool room() const noexcept { return logged.load(std::memory_order_relaxed) < static_cast<int>(log.size()); }

  void check_edges_of(int f) noexcept {
    if (face_edge.empty()) return;
    for (int k = 0; k < 3; ++k) {
      const int e = face_edge[3 * static_cast<size_t>(f) + static_cast<size_t>(k)];
      if (e >= 0 && !queued[static_cast<size_t>(e)] && queue.size() < queue.capacity()) {
        queued[static_cast<size_t>(e)] = 1;
        queue.push_back(e);
      }
    }
  }
  int boundary_faces_on(int e) const noexcept {
    int count = 0;
    for (int q = edge_face_start[static_cast<size_t>(e)]; q < edge_face_start[static_cast<size_t>(e) + 1]; ++q)
      count += face_slot[static_cast<size_t>(edge_face[static_cast<size_t>(q)])] >= 0 ? 1 : 0;
    return count;
  }
  // Remove the tetrahedra on every edge the last removals left with more than two boundary faces.
  void repair() noexcept {
    if (repairing || face_edge.empty()) return;
    repairing = true;
    for (size_t i = 0; i < queue.size(); ++i) {
      const int e = queue[i];
      queued[static_cast<size_t>(e)] = 0;
      if (boundary_faces_on(e) <= 2) continue;
      for (int q = spring_tet_start[static_cast<size_t>(e)]; q < spring_tet_start[static_cast<size_t>(e) + 1]; ++q)
        remove_tet(spring_tet[static_cast<size_t>(q)]);
    }
    queue.clear();
    repairing = false;
  }

  // The drawn surface: a face leaves or joins the triangles (no allocation: capacity reserved).
  void drop_face(int f) noexcept {
    const int slot = face_slot[static_cast<size_t>(f)];
    if (slot < 0) return;
    check_edges_of(f);
    auto& tris = model.network.triangles;
    for (int v : tris[static_cast<size_t>(slot)]) --vertex_faces[static_cast<size_t>(v)];
    const int last = static_cast<int>(tris.size()) - 1;
    tris[static_cast<size_t>(slot)] = tris.back();
    slot_face[static_cast<size_t>(slot)] = slot_face[static_cast<size_t>(last)];
    face_slot[static_cast<size_t>(slot_face[static_cast<size_t>(slot)])] = slot;
    tris.pop_back();
    face_slot[static_cast<size_t>(f)] = -1;
  }
  void add_face(int f, const std::array<int, 3>& tri) noexcept {
    auto& tris = model.network.triangles;
    if (face_slot[static_cast<size_t>(f)] >= 0 || tris.size() == tris.capacity()) return;
    face_slot[static_cast<size_t>(f)] = static_cast<int>(tris.size());
    slot_face[tris.size()] = f;
    check_edges_of(f);
    tris.push_back(tri);
    for (int v : tri)
      if (vertex_faces[static_cast<size_t>(v)]++ == 0 && model.surface_vertices.size() < model.surface_vertices.capacity())
        model.surface_vertices.push_back(v);  // (a vertex the cut laid open; order is not used)
  }
  void open_faces_of(int t) noexcept {
    if (!surface || tet_face.empty()) return;
    for (int f : tet_face[static_cast<size_t>(t)]) {
      const auto& sides = face_tet[static_cast<size_t>(f)];
      const int k = sides[0] == t ? 1 : 0;  // the other side
      const int other = sides[static_cast<size_t>(k)];
      if (other < 0 || tet_removed[static_cast<size_t>(other)]) drop_face(f);
      else add_face(f, face_tri[static_cast<size_t>(f)][static_cast<size_t>(k)]);
    }
  }

  bool remove_tet(int t) noexcept {
    if (t < 0 || static_cast<size_t>(t) >= tet_removed.size() || tet_removed[static_cast<size_t>(t)] || !room())
      return false;
    tet_removed[static_cast<size_t>(t)] = 1;
    open_faces_of(t);
    auto& T = model.network.tets[static_cast<size_t>(t)];
    T = {T[0], T[0], T[0], T[0]};  // no volume, no gradient: no force in the scalar forms either
    // Its lane of the vectorised pass collapsed onto one corner too: zero edges, zero gradients
    // (the pass's factor κ/6 − scale·6V is not zero at V = 0; the gradients are).
    auto& lanes = model.solver->volume_lane;
    auto& corners = model.solver->volume_corners;
    if (static_cast<size_t>(t) < lanes.size() && lanes[static_cast<size_t>(t)] >= 0) {
      const size_t j = static_cast<size_t>(lanes[static_cast<size_t>(t)]), G = lanes.size() / 4;
      auto at = [&](size_t c) { return j < 4 * G ? 16 * (j / 4) + 4 * c + j % 4 : 4 * j + c; };
      for (size_t c = 1; c < 4; ++c) corners[at(c)] = corners[at(0)];
    }
    for (int k = 0; k < 6; ++k) {
      const int e = tet_edge[static_cast<size_t>(t)][static_cast<size_t>(k)];
      if (e >= 0 && !spring_removed[static_cast<size_t>(e)])
        model.predictor_stiffness[static_cast<size_t>(e)] -= tet_share[static_cast<size_t>(t)][static_cast<size_t>(k)];
    }
    log_removal(1, t);
    ++stat.removed_tets;
    return true;
  }

  bool remove_spring(int e) noexcept {
    if (e < 0 || static_cast<size_t>(e) >= spring_removed.size() || spring_removed[static_cast<size_t>(e)]) return false;
    // Its tetrahedra first (each a record), then the spring: room for all of them or none.
    const int tets = spring_tet_start[static_cast<size_t>(e) + 1] - spring_tet_start[static_cast<size_t>(e)];
    if (logged.load(std::memory_order_relaxed) + tets + 1 > static_cast<int>(log.size())) return false;
    for (int q = spring_tet_start[static_cast<size_t>(e)]; q < spring_tet_start[static_cast<size_t>(e) + 1]; ++q)
      remove_tet(spring_tet[static_cast<size_t>(q)]);
    spring_removed[static_cast<size_t>(e)] = 1;
    if (surface && tet_face.empty())
      for (int q = spring_face_start[static_cast<size_t>(e)]; q < spring_face_start[static_cast<size_t>(e) + 1]; ++q)
        drop_face(spring_face[static_cast<size_t>(q)]);
    model.network.stiffness[static_cast<size_t>(e)] = 0;
    model.network.damping[static_cast<size_t>(e)] = 0;
    model.predictor_stiffness[static_cast<size_t>(e)] = 0;
    model.uniform_stiffness = 0;  // the passes read each spring's stiffness and damping from now on
    model.uniform_damping = false;
    log_removal(0, e);
    ++stat.removed_springs;
    repair();
    return true;
  }

  void install(Package* p) noexcept {
    if (p->has_factor) {
      std::swap(model.predictor, p->predictor);
      std::swap(model.solver->supernodes, p->supernodes);
      std::swap(model.solver->inverse_single, p->inverse_single);
      ++stat.factors;
      stat.last_factor_ms = p->factor_ms;
    }
    model.solver->correction = p->correction.empty() ? nullptr : &p->correction;
    stat.correction_rank = p->correction.rank;
    stat.last_correction_ms = p->correction_ms;
    ++stat.installs;
    installed_coverage = p->coverage;
    stat.installed = installed_coverage;
    if (installed) retire(installed);
    installed = p;
  }

  void retire(Package* p) noexcept {  // lock-free push; the worker frees
    Package* head = retired.load(std::memory_order_relaxed);
    do p->next = head;
    while (!retired.compare_exchange_weak(head, p, std::memory_order_release, std::memory_order_relaxed));
  }

  void setup_surface() {
    const SpringNetwork& net = model.network;
    auto& tris = model.network.triangles;
    if (tris.empty()) return;
    auto key3 = [](std::array<int, 3> a) {
      std::sort(a.begin(), a.end());
      return (static_cast<std::uint64_t>(a[0]) << 42) | (static_cast<std::uint64_t>(a[1]) << 21) |
             static_cast<std::uint64_t>(a[2]);
    };
    std::unordered_map<std::uint64_t, int> face_of;
    if (!net.tets.empty()) {
      // A positively oriented tetrahedron (a, b, c, d)'s outward faces.
      tet_face.resize(net.tets.size());
      for (size_t t = 0; t < net.tets.size(); ++t) {
        const auto [a, b, c, d] = net.tets[t];
        const std::array<std::array<int, 3>, 4> out = {{{a, c, b}, {a, b, d}, {a, d, c}, {b, c, d}}};
        for (int k = 0; k < 4; ++k) {
          const auto [it, fresh] = face_of.try_emplace(key3(out[static_cast<size_t>(k)]), static_cast<int>(face_tet.size()));
          if (fresh) {
            face_tet.push_back({static_cast<int>(t), -1});
            face_tri.push_back({out[static_cast<size_t>(k)], out[static_cast<size_t>(k)]});
          } else {
            face_tet[static_cast<size_t>(it->second)][1] = static_cast<int>(t);
            face_tri[static_cast<size_t>(it->second)][1] = out[static_cast<size_t>(k)];
          }
          tet_face[t][static_cast<size_t>(k)] = it->second;
        }
      }
    } else {
      for (const auto& tri : tris) {
        const auto [it, fresh] = face_of.try_emplace(key3(tri), static_cast<int>(face_tet.size()));
        if (fresh) {
          face_tet.push_back({-1, -1});
          face_tri.push_back({tri, tri});
        }
      }
    }
    const size_t F = face_tet.size();
    face_slot.assign(F, -1);
    slot_face.assign(F, -1);
    vertex_faces.assign(net.size(), 0);
    for (size_t i = 0; i < tris.size(); ++i) {
      const auto it = face_of.find(key3(tris[i]));
      if (it == face_of.end() || face_slot[static_cast<size_t>(it->second)] >= 0) {
        tet_face.clear();  // drawn triangles that are not the tetrahedra's faces: left as they are
        return;
      }
      face_slot[static_cast<size_t>(it->second)] = static_cast<int>(i);
      slot_face[i] = it->second;
      for (int v : tris[i]) ++vertex_faces[static_cast<size_t>(v)];
    }
    if (net.tets.empty()) {
      // Each spring's triangles (a triangle's edge that is not a spring is never cut).
      std::unordered_map<std::uint64_t, int> spring_of;
      for (size_t e = 0; e < net.springs.size(); ++e)
        spring_of.emplace((static_cast<std::uint64_t>(net.springs[e][0]) << 32) | static_cast<std::uint32_t>(net.springs[e][1]),
                          static_cast<int>(e));
      std::vector<std::vector<int>> faces_of(net.springs.size());
      for (size_t f = 0; f < F; ++f)
        for (int k = 0; k < 3; ++k) {
          const int a = face_tri[f][0][static_cast<size_t>(k)], b = face_tri[f][0][static_cast<size_t>((k + 1) % 3)];
          const auto it = spring_of.find((static_cast<std::uint64_t>(std::min(a, b)) << 32) |
                                         static_cast<std::uint32_t>(std::max(a, b)));
          if (it != spring_of.end()) faces_of[static_cast<size_t>(it->second)].push_back(static_cast<int>(f));
        }
      spring_face_start.assign(net.springs.size() + 1, 0);
      for (size_t e = 0; e < net.springs.size(); ++e) {
        spring_face_start[e + 1] = spring_face_start[e] + static_cast<int>(faces_of[e].size());
        spring_face.insert(spring_face.end(), faces_of[e].begin(), faces_of[e].end());
      }
    }
    if (!net.tets.empty()) {
      std::unordered_map<std::uint64_t, int> spring_of;
      for (size_t e = 0; e < net.springs.size(); ++e)
        spring_of.emplace((static_cast<std::uint64_t>(net.springs[e][0]) << 32) | static_cast<std::uint32_t>(net.springs[e][1]),
                          static_cast<int>(e));
      face_edge.assign(3 * F, -1);
      edge_face_start.assign(net.springs.size() + 1, 0);
      for (size_t f = 0; f < F; ++f)
        for (int k = 0; k < 3; ++k) {
          const int a = face_tri[f][0][static_cast<size_t>(k)], b = face_tri[f][0][static_cast<size_t>((k + 1) % 3)];
          const auto it = spring_of.find((static_cast<std::uint64_t>(std::min(a, b)) << 32) |
                                         static_cast<std::uint32_t>(std::max(a, b)));
          if (it == spring_of.end()) continue;
          face_edge[3 * f + static_cast<size_t>(k)] = it->second;
          ++edge_face_start[static_cast<size_t>(it->second) + 1];
        }
      for (size_t e = 0; e < net.springs.size(); ++e) edge_face_start[e + 1] += edge_face_start[e];
      edge_face.resize(static_cast<size_t>(edge_face_start.back()));
      std::vector<int> fill(edge_face_start.begin(), edge_face_start.end() - 1);
      for (size_t f = 0; f < F; ++f)
        for (int k = 0; k < 3; ++k) {
          const int e = face_edge[3 * f + static_cast<size_t>(k)];
          if (e >= 0) edge_face[static_cast<size_t>(fill[static_cast<size_t>(e)]++)] = static_cast<int>(f);
        }
      queue.reserve(net.springs.size());
      queued.assign(net.springs.size(), 0);
    }
    tris.reserve(F);
    model.surface_vertices.reserve(net.size());
    surface = true;
  }

  // ---- worker ----
  void apply_log(int upto) {
    for (; applied < upto; ++applied) {
      const Removal r = log[static_cast<size_t>(applied)];
      if (r.kind == 1) {
        if (w_tet[static_cast<size_t>(r.index)]) continue;
        w_tet[static_cast<size_t>(r.index)] = 1;
        for (int k = 0; k < 6; ++k) {
          const int e = tet_edge[static_cast<size_t>(r.index)][static_cast<size_t>(k)];
          if (e < 0 || w_spring[static_cast<size_t>(e)]) continue;
          kp[static_cast<size_t>(e)] -= tet_share[static_cast<size_t>(r.index)][static_cast<size_t>(k)];
          touch(e);
        }
      } else {
        if (w_spring[static_cast<size_t>(r.index)]) continue;
        w_spring[static_cast<size_t>(r.index)] = 1;
        kp[static_cast<size_t>(r.index)] = 0;
        damp[static_cast<size_t>(r.index)] = 0;
        touch(r.index);
      }
    }
  }
  void touch(int e) {
    if (!is_dirty[static_cast<size_t>(e)]) {
      is_dirty[static_cast<size_t>(e)] = 1;
      dirty.push_back(e);
    }
  }
  double weight(double c, double k) const { return h * c + h * h * k; }

  std::vector<EdgeWeight> changed() const {
    std::vector<EdgeWeight> out;
    for (int e : dirty) {
      const size_t u = static_cast<size_t>(e);
      const double dw = weight(damp_factor[u], kp_factor[u]) - weight(damp[u], kp[u]);
      if (dw != 0) out.push_back({model.network.springs[u][0], model.network.springs[u][1], dw});
    }
    return out;
  }

  Package* build(int target) {
    auto* p = new Package;
    p->coverage = target;
    apply_log(target);
    std::vector<EdgeWeight> removed = changed();
    // Woodbury loses the digits the capacitance matrix's conditioning costs: a cut that nearly
    // detaches a piece makes I − W Uᵀ A⁻¹ U ill-conditioned. Past kMinRcond the step would no longer
    // be exact to 1e-10, so a new factor is built instead (measured: a random path's correction
    // reached 1.9e-10 relative before this guard).
    bool refactor = static_cast<int>(removed.size()) > options.refactor_rank;
    if (!refactor && !removed.empty() && static_cast<int>(removed.size()) <= options.max_rank) {
      const auto t0 = std::chrono::steady_clock::now();
      p->correction = spring::build_correction(factor, anchored, removed);
      p->correction_ms = ms_since(t0);
      if (p->correction.rcond < kMinRcond) refactor = true;
      else return p;
    }
    if (refactor) {
      const auto t0 = std::chrono::steady_clock::now();
      SpringNetwork net = base;
      net.stiffness = kp;
      net.damping = damp;
      p->correction = {};
      auto f = spring::refactor_predictor(net, model.options, factor);
      if (f) {
        p->has_factor = true;
        p->predictor = std::move(*f);
        p->supernodes = spring::make_supernodes(p->predictor, model.options.single_precision);
        if (p->predictor.kind == SpringSolver::sparse && p->supernodes.max_height != max_height) {
          p->has_factor = false;  // (cannot happen on the same pattern; kept as a guard)
        } else {
          if (model.options.single_precision && p->predictor.kind == SpringSolver::desbrun)
            p->inverse_single.assign(p->predictor.inverse.begin(), p->predictor.inverse.end());
          factor = p->predictor;  // the worker's copy (the package's is swapped with the model's)
          kp_factor = kp;
          damp_factor = damp;
          for (int e : dirty) is_dirty[static_cast<size_t>(e)] = 0;
          dirty.clear();
          removed.clear();
          p->factor_ms = ms_since(t0);
        }
      } else {
        worker_error.store(1, std::memory_order_relaxed);
      }
    }
    if (static_cast<int>(removed.size()) <= options.max_rank) {
      const auto t0 = std::chrono::steady_clock::now();
      p->correction = spring::build_correction(factor, anchored, removed);
      p->correction_ms = ms_since(t0);
    } else {
      p->coverage = built;  // too many edges for one correction: the step waits for the factor
      p->correction = {};
    }
    return p;
  }

  void free_retired() {
    Package* p = retired.exchange(nullptr, std::memory_order_acquire);
    while (p) {
      Package* next = p->next;
      delete p;
      p = next;
    }
  }

  void run() {
    int idle = 1000;
    while (!stop.load(std::memory_order_acquire)) {
      free_retired();
      const int target = options.fixed_latency >= 1 ? requested.load(std::memory_order_acquire)
                                                    : logged.load(std::memory_order_acquire);
      if (target == built || ready.load(std::memory_order_acquire) != nullptr) {
        // Idle: a short nap while removals are coming (a cut in progress), a longer one otherwise, so
        // an uncut organ's worker costs the stepping thread nothing measurable on a small machine.
        idle = std::min(idle + 1, 1000);
        std::this_thread::sleep_for(std::chrono::microseconds(idle < 50 ? 200 : 2000));
        continue;
      }
      idle = 0;
      Package* p = nullptr;
      try {
        p = build(target);
      } catch (...) {  // out of memory: the step goes on with the matrix it has (its forces are exact)
        worker_error.store(1, std::memory_order_relaxed);
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
        continue;
      }
      built = target;
      ready.store(p, std::memory_order_release);
    }
    free_retired();
  }
};

SpringCutter::SpringCutter(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

SpringCutter::~SpringCutter() {
  if (!impl_) return;
  impl_->stop.store(true, std::memory_order_release);
  if (impl_->worker.joinable()) impl_->worker.join();
  impl_->model.solver->correction = nullptr;
  delete impl_->ready.exchange(nullptr);
  delete impl_->installed;
  impl_->free_retired();
}

Result<std::unique_ptr<SpringCutter>> SpringCutter::create(SpringModel& model, const SpringCutOptions& options) {
  const SpringPredictor& p = model.predictor;
  if (p.kind != SpringSolver::desbrun && p.kind != SpringSolver::sparse)
    return Error{"cutting needs a predictor (solver desbrun or sparse), not the exact solver"};
  if (p.kind == SpringSolver::sparse && model.solver->supernodes.empty())
    return Error{"cutting needs the sparse predictor's supernodes (a model from build_spring_model)"};
  if (model.solver->correction) return Error{"this model is already being cut"};
  if (options.refactor_rank < 0 || options.max_rank < 1 || options.refactor_rank > options.max_rank ||
      options.max_removals < 1)
    return Error{"cut options: 0 <= refactor_rank <= max_rank, max_rank >= 1 and max_removals >= 1 expected"};
  auto impl = std::make_unique<Impl>(model, options);
  Impl& m = *impl;
  const SpringNetwork& net = model.network;
  m.n = static_cast<int>(net.size());
  m.h = model.options.dt;
  m.anchored = model.anchored;
  m.max_height = model.solver->supernodes.max_height;
  const size_t S = net.springs.size(), T = net.tets.size();
  // Each tetrahedron's edges as springs, and its share of their predictor weight (predictor_stiffness).
  std::unordered_map<std::uint64_t, int> index;
  index.reserve(S);
  auto key = [](int a, int b) {
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(std::min(a, b))) << 32) |
           static_cast<std::uint32_t>(std::max(a, b));
  };
  for (size_t e = 0; e < S; ++e) index.emplace(key(net.springs[e][0], net.springs[e][1]), static_cast<int>(e));
  m.tet_edge.assign(T, {-1, -1, -1, -1, -1, -1});
  m.tet_share.assign(T, {0, 0, 0, 0, 0, 0});
  m.spring_tet_start.assign(S + 1, 0);
  const bool volume = model.volume_term;
  for (size_t t = 0; t < T; ++t) {
    const auto& Tt = net.tets[t];
    const auto g = spring::tet_volume_gradients(net.rest.row(Tt[0]).transpose(), net.rest.row(Tt[1]).transpose(),
                                                net.rest.row(Tt[2]).transpose(), net.rest.row(Tt[3]).transpose());
    const double w = volume ? kVolumePredictorScale * net.volume_modulus / net.rest_volume[t] : 0.0;
    int k = 0;
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b, ++k) {
        const auto it = index.find(key(Tt[static_cast<size_t>(a)], Tt[static_cast<size_t>(b)]));
        if (it == index.end()) continue;
        m.tet_edge[t][static_cast<size_t>(k)] = it->second;
        m.tet_share[t][static_cast<size_t>(k)] = -w * g[static_cast<size_t>(a)].dot(g[static_cast<size_t>(b)]);
        ++m.spring_tet_start[static_cast<size_t>(it->second) + 1];
      }
  }
  for (size_t e = 0; e < S; ++e) m.spring_tet_start[e + 1] += m.spring_tet_start[e];
  m.spring_tet.resize(static_cast<size_t>(m.spring_tet_start[S]));
  {
    std::vector<int> fill(m.spring_tet_start.begin(), m.spring_tet_start.end() - 1);
    for (size_t t = 0; t < T; ++t)
      for (int e : m.tet_edge[t])
        if (e >= 0) m.spring_tet[static_cast<size_t>(fill[static_cast<size_t>(e)]++)] = static_cast<int>(t);
  }
  m.spring_removed.assign(S, 0);
  m.tet_removed.assign(T, 0);
  m.setup_surface();
  m.log.resize(static_cast<size_t>(options.max_removals));
  m.counts.assign(static_cast<size_t>(std::max(options.fixed_latency, 8)), 0);
  // The worker's copy: weights as the predictor was built with.
  m.base.rest = net.rest;
  m.base.mass = net.mass;
  m.base.springs = net.springs;
  m.base.rest_length = net.rest_length;
  m.base.anchors = net.anchors;
  m.kp = model.predictor_stiffness;
  m.damp = net.damping;
  m.kp_factor = m.kp;
  m.damp_factor = m.damp;
  m.w_spring.assign(S, 0);
  m.w_tet.assign(T, 0);
  m.is_dirty.assign(S, 0);
  m.factor = model.predictor;
  m.worker = std::thread([&m] { m.run(); });
  return std::unique_ptr<SpringCutter>(new SpringCutter(std::move(impl)));
}

int SpringCutter::remove_springs(std::span<const int> springs) noexcept {
  int count = 0;
  for (int e : springs) count += impl_->remove_spring(e) ? 1 : 0;
  return count;
}

int SpringCutter::remove_tets(std::span<const int> tets) noexcept {
  int count = 0;
  for (int t : tets) count += impl_->remove_tet(t) ? 1 : 0;
  impl_->repair();
  return count;
}

bool SpringCutter::install() noexcept {
  Impl& m = *impl_;
  bool changed = false;
  const int L = m.options.fixed_latency;
  if (L >= 1) {
    // Deterministic: at call c the removals logged before call c − L + 1 take effect (L = 1: those
    // of the tick before, from this tick on), waiting for the worker if it is late (headless runs and
    // replays; never a real-time loop). The ring holds the counts sampled at the last L calls.
    const int logged = m.logged.load(std::memory_order_relaxed);
    m.counts[static_cast<size_t>(m.calls % static_cast<std::uint64_t>(L))] = logged;
    int want = m.calls + 1 >= static_cast<std::uint64_t>(L)
                   ? m.counts[static_cast<size_t>((m.calls + 1) % static_cast<std::uint64_t>(L))]
                   : 0;
    ++m.calls;
    if (m.scheduled < m.schedule.size()) {
      // A replay: the recorded run's coverage at this call instead. The worker builds exactly the
      // coverages asked for, one at a time, as the recorded run's worker did, so each package (its
      // correction, whether it brings a new factor) is the one the run installed. A run that has
      // diverged (asked for removals this one never logged, or for less than it has installed) is
      // counted and goes on with what it has: a wait for removals that will not come would hang.
      want = m.schedule[m.scheduled++];
      if (want > logged || want < m.installed_coverage) {
        ++m.stat.replay_mismatches;
        want = std::min(want, logged);
      }
    }
    if (want > m.installed_coverage) {
      m.requested.store(want, std::memory_order_release);
      while (m.installed_coverage < want && !m.worker_error.load(std::memory_order_relaxed)) {
        if (Package* p = m.ready.exchange(nullptr, std::memory_order_acq_rel)) {
          m.install(p);
          changed = true;
        } else {
          std::this_thread::yield();
        }
      }
    }
  } else if (Package* p = m.ready.exchange(nullptr, std::memory_order_acq_rel)) {
    m.install(p);
    changed = true;
  }
  m.stat.pending = m.logged.load(std::memory_order_relaxed) - m.installed_coverage;
  return changed;
}

void SpringCutter::settle() {
  Impl& m = *impl_;
  const int want = m.logged.load(std::memory_order_relaxed);
  m.requested.store(want, std::memory_order_release);
  while (m.installed_coverage < want && !m.worker_error.load(std::memory_order_relaxed)) {
    if (Package* p = m.ready.exchange(nullptr, std::memory_order_acq_rel)) m.install(p);
    else std::this_thread::sleep_for(std::chrono::microseconds(100));
  }
  m.stat.pending = m.logged.load(std::memory_order_relaxed) - m.installed_coverage;
}

SpringCutStatus SpringCutter::status() const noexcept { return impl_->stat; }

void SpringCutter::set_fixed_latency(int latency) noexcept {
  Impl& m = *impl_;
  // (The ring has room for the latency it was made with; a longer one is clamped to it.)
  m.options.fixed_latency = latency < 1 ? -1 : std::min(latency, static_cast<int>(m.counts.size()));
  std::fill(m.counts.begin(), m.counts.end(), m.installed_coverage);
  m.calls = 0;
}
Status SpringCutter::set_install_schedule(std::span<const std::int32_t> installed) {
  for (size_t i = 0; i < installed.size(); ++i) {
    if (installed[i] < 0)
      return Error{"install schedule: value " + std::to_string(i) + " is " + std::to_string(installed[i]) +
                   ", expected a count of removals >= 0"};
    if (i > 0 && installed[i] < installed[i - 1])
      return Error{"install schedule: value " + std::to_string(i) + " (" + std::to_string(installed[i]) +
                   ") is below the one before (" + std::to_string(installed[i - 1]) + "): installs only add"};
  }
  impl_->schedule.assign(installed.begin(), installed.end());
  impl_->scheduled = 0;
  return {};
}
const std::vector<std::uint8_t>& SpringCutter::removed_springs() const noexcept { return impl_->spring_removed; }
const std::vector<std::uint8_t>& SpringCutter::removed_tets() const noexcept { return impl_->tet_removed; }

}  // namespace palpate
