// step.cpp — the spring step as a pipeline (Desbrun, Schröder & Barr 1999): forces → right-hand
// side → solve → correction → advance, then the surface contact, each a named stage; the work of
// each stage lives in the file of its job (stages.h).
#include <palpate/spring.h>

#include "tissue/spring/forces.h"
#include "tissue/spring/solve.h"
#include "tissue/spring/stages.h"

#include <cmath>
#include <cstdint>
#include <limits>

namespace palpate::spring {

void all_forces(const SpringModel& model, SpringState& s, const ToolState* tool, bool stiffness_term) noexcept {
  s.tool_force = external_forces(model, s, tool, s.work);
  s.force = s.work;
  if (stiffness_term && !model.all_pairs) {
    s.rhs.setZero();
    add_spring_forces_and_stiffness_term(model, s.x, s.v, s.force, s.rhs, s.soa.data(), true);
    s.anchor_force = anchor_load(model, s.force);
    return;
  }
  if (model.all_pairs) add_all_pair_forces(model, s.x, s.v, s.force, s);
  else add_spring_forces(model.network, s.x, s.v, s.force);
  s.anchor_force = anchor_load(model, s.force);
}

void advance(const SpringModel& model, SpringState& s, const RowMat3d& dv) noexcept {
  s.v += dv;
  for (int a : model.network.anchors) s.v.row(a).setZero();
  s.x += model.options.dt * s.v;
}

}  // namespace palpate::spring

namespace palpate {

namespace {

using namespace spring;

// τ_ext = Σ x_i × f_ext,i about the origin, N·m (the external forces in s.work): the torque the
// angular-momentum correction leaves to the body.
Vec3 external_torque(const SpringState& s) noexcept {
  Vec3 torque = Vec3::Zero();
  for (Eigen::Index i = 0; i < s.x.rows(); ++i) torque += s.x.row(i).transpose().cross(s.work.row(i).transpose());
  return torque;
}

// Right-hand side stage: s.rhs = h (f − γ v − h K_L v), anchored rows zero. Generic springs: s.rhs
// already holds −h K_L v from the spring pass; all pairs: K_L v from the springs (in O(n) when they
// share one stiffness).
void right_hand_side(const SpringModel& model, SpringState& s) noexcept {
  const SpringNetwork& net = model.network;
  const double h = model.options.dt;
  const double gamma = model.options.point_damping;
  const Eigen::Index n = s.x.rows();
  if (!model.all_pairs) {
    s.rhs += s.force - gamma * s.v;  // s.rhs holds −h K_L v from the spring pass
  } else if (model.uniform_stiffness > 0) {
    // K_L v with one stiffness over every pair: (K_L v)_i = k (n v_i − Σ_j v_j).
    s.rhs = s.force - gamma * s.v;
    const Eigen::RowVector3d sum = s.v.colwise().sum();
    const double kh = h * model.uniform_stiffness;
    for (Eigen::Index i = 0; i < n; ++i) s.rhs.row(i) -= kh * (static_cast<double>(n) * s.v.row(i) - sum);
  } else {
    s.rhs = s.force - gamma * s.v;
    for (size_t e = 0; e < net.springs.size(); ++e) {
      const int i = net.springs[e][0], j = net.springs[e][1];
      const double kh = h * net.stiffness[e];
      for (int c = 0; c < 3; ++c) {
        const double d = kh * (s.v(i, c) - s.v(j, c));
        s.rhs(i, c) -= d;
        s.rhs(j, c) += d;
      }
    }
  }
  s.rhs *= h;
  for (int a : net.anchors) s.rhs.row(a).setZero();
}

// Correction stage: backward Euler's own damping on request (refine_toward_exact), then the
// angular-momentum correction of free bodies (DS99 §4.3), both on s.dv.
void correct(const SpringModel& model, SpringState& s, const Vec3& ext_torque, bool momentum) noexcept {
  refine_toward_exact(model, s);
  if (momentum) correct_angular_momentum(model, s, ext_torque, s.dv);
}

// The doubles of SpringState::soa the fused sparse step takes: the padded spring pass, then the
// permuted right-hand side and the block being solved.
size_t fused_scratch(const SpringModel& model) {
  return spring_pass_scratch(model) + supernodal_scratch(model.predictor, model.solver->supernodes);
}

// step_predictor's sparse step for generic springs with the supernodal factor, fused: the spring
// pass leaves its sums in the padded layout, one pass over the vertices builds the permuted
// right-hand side h (f − γ v − h K_L v) straight into the solve's z4 (anchored rows zero), the
// solve works there in place, and Δv is gathered from it for the general path's last stages. No
// (n x 3) copies of the forces or the right-hand side; the arithmetic is the general path's,
// operation for operation.
void step_sparse_fused(const SpringModel& model, SpringState& s, const ToolState* tool, bool momentum) noexcept {
  const SpringNetwork& net = model.network;
  const size_t n = net.size();
  // Forces: the external ones into s.work, the springs' (and −h K_L v) into the padded layout.
  s.tool_force = external_forces(model, s, tool, s.work);
  const Vec3 ext_torque = momentum ? external_torque(s) : Vec3::Zero();
  double* p = spring_pass_padded(model, s.x, s.v, s.soa.data(), SpringKernel::best);
  const double* fr = p + 8 * n;  // per vertex: the springs' force, 0, their −h K_L v, 0
  double* z4 = p + 16 * n;
  const double* work = s.work.data();
  Vec3 anchor = Vec3::Zero();
  for (int a : net.anchors) {
    const size_t i = static_cast<size_t>(a);
    anchor += Vec3(work[3 * i] + fr[8 * i], work[3 * i + 1] + fr[8 * i + 1], work[3 * i + 2] + fr[8 * i + 2]);
  }
  s.anchor_force = anchor;
  // Right-hand side, permuted into the solve's layout.
  fused_rhs(n, model.options.dt, model.options.point_damping, model.predictor.perm.data(), model.anchored.data(), fr,
            work, s.v.data(), z4);
  // Solve, in place, and Δv gathered back.
  solve_supernodal_permuted(model.predictor, model.solver->supernodes, z4, z4 + 4 * n, SolveIsa::best,
                            model.solver->correction);
  unpermute_rows(model.predictor, z4, s.dv.data());
  correct(model, s, ext_torque, momentum);
  advance(model, s, s.dv);
}

// One step with the precomputed predictor (DS99): the implicit system with the constant matrix,
//   (M + h(γI + C_L) + h²K_L) Δv = h (f(x, v) − γ v − h K_L v),
// solved with the stored inverse or factor, then corrected, then x⁺ = x + h v⁺.
void step_predictor(const SpringModel& model, SpringState& s, const ToolState* tool) noexcept {
  const bool momentum = model.options.angular_momentum_correction && model.network.anchors.empty();
  if (!model.all_pairs && model.predictor.kind == SpringSolver::sparse && !model.solver->supernodes.empty() &&
      spring_pass_padded_available(model) && s.soa.size() >= fused_scratch(model)) {
    step_sparse_fused(model, s, tool, momentum);
    return;
  }
  all_forces(model, s, tool, true);  // s.work holds the external forces afterwards; s.rhs −h K_L v
  const Vec3 ext_torque = momentum ? external_torque(s) : Vec3::Zero();
  right_hand_side(model, s);
  solve_predictor(model, s, s.rhs, s.dv);
  correct(model, s, ext_torque, momentum);
  advance(model, s, s.dv);
}

}  // namespace

bool step(const SpringModel& model, SpringState& s, const ToolState* tool) noexcept {
  // A device glitch (non-finite pose) must not reach the tissue: the tool is ignored this step.
  if (tool && !(tool->tip.allFinite() && tool->velocity.allFinite() && tool->axis.allFinite() &&
                std::isfinite(tool->radius)))
    tool = nullptr;
  if (model.options.integrator == SpringIntegrator::bdf2) bdf2_start(s);
  if (model.options.solver == SpringSolver::exact) {
    try {
      step_exact(model, s, tool);
    } catch (...) {  // out of memory in the reference solver: treated as a blow-up
      s.v.setConstant(std::numeric_limits<double>::quiet_NaN());
    }
  } else {
    step_predictor(model, s, tool);
  }
  if (model.options.contact == SpringContact::surface) {
    if (tool) {
      surface_contact(model, s, *tool);
    } else {
      s.contact_vertex_count = 0;
      s.contact_force = 0;
      s.carried_on_tool.setZero();
    }
  }
  s.time += step_length(model.options);
  if (finite_and_slow(model, s)) return true;
  const std::uint64_t resets = s.resets + 1;
  reset(model, s);
  s.resets = resets;
  return false;
}

}  // namespace palpate
