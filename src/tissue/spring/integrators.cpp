// integrators.cpp — the solves of a step besides the predictor pipeline (step.cpp): the predictor's
// solve of one right-hand side, the conjugate-gradient refinement toward the exact linearised
// backward Euler, Newton's exact backward Euler (the reference), and BDF2's extrapolated start.
#include <palpate/spring.h>

#include "tissue/spring/forces.h"
#include "tissue/spring/solve.h"
#include "tissue/spring/cut.h"
#include "tissue/spring/stages.h"

#include <Eigen/SparseCholesky>

#include <algorithm>
#include <cmath>
#include <vector>

namespace palpate::spring {

namespace {

// out += sign · (h² K y + h C w) with the exact Jacobian at x: per spring K_e = k [uuᵀ + max(0, 1 − L/l)
// (I − uuᵀ)] (the exact solver's, positive semi-definite) and C_e = c uuᵀ, and per tetrahedron the
// volume term's (κ/V0) ∇V ∇Vᵀ. Anchored vertices' rows are left for the caller to zero.
void add_exact_jacobian(const SpringModel& model, const RowMat3d& x, const RowMat3d& y, const RowMat3d& w,
                        RowMat3d& out, double sign) noexcept {
  const SpringNetwork& net = model.network;
  const double h = model.options.dt;
  for (size_t e = 0; e < net.springs.size(); ++e) {
    const int a = net.springs[e][0], b = net.springs[e][1];
    const Vec3 d = (x.row(b) - x.row(a)).transpose();
    const double l = d.norm();
    if (!(l > 0)) continue;
    const Vec3 u = d / l;
    const Vec3 dy = (y.row(a) - y.row(b)).transpose(), dw = (w.row(a) - w.row(b)).transpose();
    const double lateral = std::max(0.0, 1.0 - net.rest_length[e] / l);
    const double uy = u.dot(dy);
    const Vec3 t = sign * (h * h * net.stiffness[e] * (uy * u + lateral * (dy - uy * u)) + h * net.damping[e] * u.dot(dw) * u);
    out.row(a) += t.transpose();
    out.row(b) -= t.transpose();
  }
  if (!model.volume_term) return;
  for (size_t k = 0; k < net.tets.size(); ++k) {
    const auto& q = net.tets[k];
    const auto g = spring::tet_volume_gradients(x.row(q[0]).transpose(), x.row(q[1]).transpose(),
                                                x.row(q[2]).transpose(), x.row(q[3]).transpose());
    double gy = 0;
    for (int c = 0; c < 4; ++c) gy += g[static_cast<size_t>(c)].dot(y.row(q[static_cast<size_t>(c)]).transpose());
    const double wgt = sign * h * h * net.volume_modulus / net.rest_volume[k] * gy;
    for (int c = 0; c < 4; ++c) out.row(q[static_cast<size_t>(c)]) += wgt * g[static_cast<size_t>(c)].transpose();
  }
}

// out += sign · (h² K_p y + h C_L w): the predictor's Laplacians (weights predictor_stiffness, damping).
void add_predictor_jacobian(const SpringModel& model, const RowMat3d& y, const RowMat3d& w, RowMat3d& out,
                            double sign) noexcept {
  const SpringNetwork& net = model.network;
  const double h = model.options.dt;
  for (size_t e = 0; e < net.springs.size(); ++e) {
    const int a = net.springs[e][0], b = net.springs[e][1];
    const Eigen::RowVector3d t = sign * (h * h * model.predictor_stiffness[e] * (y.row(a) - y.row(b)) +
                                         h * net.damping[e] * (w.row(a) - w.row(b)));
    out.row(a) += t;
    out.row(b) -= t;
  }
}

}  // namespace

void solve_predictor(const SpringModel& model, SpringState& s, const RowMat3d& b, RowMat3d& x) noexcept {
  const PredictorCorrection* cut = model.solver->correction;  // a cut's low-rank correction (cut.h)
  if (model.predictor.kind == SpringSolver::desbrun) {
    spring::solve_dense(model.predictor, model.solver->inverse_single, b, x, s.soa.data());
    if (cut && !cut->empty()) apply_dense(*cut, model.predictor.n, x.data());
  } else if (model.solver->supernodes.empty()) {
    spring::solve_columns(model.predictor, b, x, s.work);  // (a model built by hand: never cut)
  } else {
    spring::solve_supernodal(model.predictor, model.solver->supernodes, b, x, s.soa.data(), SolveIsa::best, cut);
  }
}

// Backward Euler's damping on request (SpringModelOptions::exact_iterations): the predictor's Δv
// solves (M + hγ + hC_L + h²K_p) Δv = h (f − h K_p v); the exact linearised backward Euler (one
// Newton step of the exact solver) has the true C and K instead. Its residual at the predictor's
// Δv is r = h² (K_p − K)(v + Δv) + h (C_L − C) Δv; preconditioned conjugate gradients (the
// predictor's matrix as the preconditioner; both symmetric positive definite) solve for the
// correction δ, A δ = r, a few iterations. Free vertices only (anchored rows zero).
void refine_toward_exact(const SpringModel& model, SpringState& s) noexcept {
  const int iterations = model.options.exact_iterations;
  if (iterations <= 0 || s.cg_r.rows() != s.x.rows() || model.all_pairs) return;
  const double h = model.options.dt, gamma = model.options.point_damping;
  const Eigen::Index n = s.x.rows();
  auto zero_anchors = [&](RowMat3d& m) {
    for (int a : model.network.anchors) m.row(a).setZero();
  };
  auto dot = [](const RowMat3d& a, const RowMat3d& b) { return (a.array() * b.array()).sum(); };
  s.cg_q = s.v + s.dv;
  s.cg_r.setZero();
  add_predictor_jacobian(model, s.cg_q, s.dv, s.cg_r, 1.0);
  add_exact_jacobian(model, s.x, s.cg_q, s.dv, s.cg_r, -1.0);
  zero_anchors(s.cg_r);
  s.cg_d.setZero();
  solve_predictor(model, s, s.cg_r, s.cg_z);
  zero_anchors(s.cg_z);
  s.cg_p = s.cg_z;
  double rz = dot(s.cg_r, s.cg_z);
  for (int it = 0; it < iterations && rz > 0; ++it) {
    // q = A p: masses and point damping, then the exact Jacobian's parts.
    for (Eigen::Index i = 0; i < n; ++i)
      s.cg_q.row(i) = (model.network.mass[static_cast<size_t>(i)] + h * gamma) * s.cg_p.row(i);
    add_exact_jacobian(model, s.x, s.cg_p, s.cg_p, s.cg_q, 1.0);
    zero_anchors(s.cg_q);
    const double pq = dot(s.cg_p, s.cg_q);
    if (!(pq > 0)) break;
    const double alpha = rz / pq;
    s.cg_d += alpha * s.cg_p;
    if (it + 1 == iterations) break;
    s.cg_r -= alpha * s.cg_q;
    solve_predictor(model, s, s.cg_r, s.cg_z);
    zero_anchors(s.cg_z);
    const double rz_next = dot(s.cg_r, s.cg_z);
    s.cg_p = s.cg_z + (rz_next / rz) * s.cg_p;
    rz = rz_next;
  }
  s.dv += s.cg_d;
}

// The exact backward Euler: solve G(Δv) = M Δv − h f(x + h(v + Δv), v + Δv) = 0 by Newton with the
// full spring Jacobian, K_e = k [uuᵀ + max(0, 1 − L/l)(I − uuᵀ)] (the transverse term clamped at
// zero in compression keeps the matrix definite; the residual stays exact), re-assembled and
// factorised (SimplicialLDLT) every iteration. External and tool forces are taken at the start.
void step_exact(const SpringModel& model, SpringState& s, const ToolState* tool) {
  const SpringNetwork& net = model.network;
  const SpringModelOptions& o = model.options;
  const double h = o.dt, gamma = o.point_damping;
  const Eigen::Index n = s.x.rows();
  all_forces(model, s, tool);
  const RowMat3d f_ext = s.work;
  RowMat3d dv = RowMat3d::Zero(n, 3);
  RowMat3d xn(n, 3), vn(n, 3), f(n, 3);
  Eigen::VectorXd residual(3 * n);
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(static_cast<size_t>(3 * n + 36 * static_cast<Eigen::Index>(net.springs.size())));
  Eigen::SparseMatrix<double> J(3 * n, 3 * n);
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver;
  s.newton_iterations = 0;
  const double vscale = 1.0 + s.v.cwiseAbs().maxCoeff();
  for (int it = 0; it < o.newton_iterations; ++it) {
    vn = s.v + dv;
    xn = s.x + h * vn;
    f = f_ext - gamma * vn;
    add_spring_forces(net, xn, vn, f);
    for (Eigen::Index i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c)
        residual[3 * i + c] = model.anchored[static_cast<size_t>(i)]
                                  ? dv(i, c)
                                  : net.mass[static_cast<size_t>(i)] * dv(i, c) - h * f(i, c);
    trip.clear();
    for (Eigen::Index i = 0; i < n; ++i) {
      const double d = model.anchored[static_cast<size_t>(i)] ? 1.0 : net.mass[static_cast<size_t>(i)] + h * gamma;
      for (int c = 0; c < 3; ++c) trip.emplace_back(3 * i + c, 3 * i + c, d);
    }
    for (size_t e = 0; e < net.springs.size(); ++e) {
      const int a = net.springs[e][0], b = net.springs[e][1];
      Vec3 d = (xn.row(b) - xn.row(a)).transpose();
      const double l = d.norm();
      if (!(l > 0)) continue;
      const Vec3 u = d / l;
      const Eigen::Matrix3d uu = u * u.transpose();
      const double lateral = std::max(0.0, 1.0 - net.rest_length[e] / l);
      const Eigen::Matrix3d B = h * h * net.stiffness[e] * (uu + lateral * (Eigen::Matrix3d::Identity() - uu)) +
                                h * net.damping[e] * uu;
      const bool fa = !model.anchored[static_cast<size_t>(a)], fb = !model.anchored[static_cast<size_t>(b)];
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
          if (fa) trip.emplace_back(3 * a + r, 3 * a + c, B(r, c));
          if (fb) trip.emplace_back(3 * b + r, 3 * b + c, B(r, c));
          if (fa && fb) {
            trip.emplace_back(3 * a + r, 3 * b + c, -B(r, c));
            trip.emplace_back(3 * b + r, 3 * a + c, -B(r, c));
          }
        }
    }
    // The volume term: its Gauss-Newton Jacobian (κ / V0) ∇V ∇Vᵀ (positive semi-definite; the
    // residual is exact, so Newton still converges to the backward-Euler step).
    for (size_t t = 0; t < net.tets.size() && net.volume_modulus > 0; ++t) {
      const auto& q = net.tets[t];
      const auto g = spring::tet_volume_gradients(xn.row(q[0]).transpose(), xn.row(q[1]).transpose(),
                                                  xn.row(q[2]).transpose(), xn.row(q[3]).transpose());
      const double w = h * h * net.volume_modulus / net.rest_volume[t];
      for (int a = 0; a < 4; ++a) {
        if (model.anchored[static_cast<size_t>(q[static_cast<size_t>(a)])]) continue;
        for (int b = 0; b < 4; ++b) {
          if (model.anchored[static_cast<size_t>(q[static_cast<size_t>(b)])]) continue;
          const Eigen::Matrix3d B = w * g[static_cast<size_t>(a)] * g[static_cast<size_t>(b)].transpose();
          for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c)
              trip.emplace_back(3 * q[static_cast<size_t>(a)] + r, 3 * q[static_cast<size_t>(b)] + c, B(r, c));
        }
      }
    }
    J.setFromTriplets(trip.begin(), trip.end());
    if (it == 0) solver.analyzePattern(J);
    solver.factorize(J);
    if (solver.info() != Eigen::Success) break;
    const Eigen::VectorXd delta = solver.solve(residual);
    for (Eigen::Index i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) dv(i, c) -= delta[3 * i + c];
    ++s.newton_iterations;
    if (delta.cwiseAbs().maxCoeff() <= o.newton_tolerance * vscale) break;
  }
  advance(model, s, dv);
}

// BDF2 as a backward-Euler step from an extrapolated state: x_{n+1} = x̃ + h v_{n+1} and
// v_{n+1} = ṽ + h a(x_{n+1}, v_{n+1}) with h = 2H/3, x̃ = (4 x_n − x_{n−1})/3, ṽ = (4 v_n − v_{n−1})/3,
// which is the backward-Euler step the predictor already takes, started from (x̃, ṽ). Keeps (x_n, v_n)
// as the next step's previous state. The first step after make_state or reset takes x_{n−1} = x_n.
void bdf2_start(SpringState& s) noexcept {
  if (!s.has_prev) {
    s.x_prev = s.x;
    s.v_prev = s.v;
    s.has_prev = true;
  }
  const Eigen::Index n = s.x.rows();
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index c = 0; c < 3; ++c) {
      const double x = s.x(i, c), v = s.v(i, c);
      s.x(i, c) = (4.0 * x - s.x_prev(i, c)) / 3.0;
      s.v(i, c) = (4.0 * v - s.v_prev(i, c)) / 3.0;
      s.x_prev(i, c) = x;
      s.v_prev(i, c) = v;
    }
}

}  // namespace palpate::spring
