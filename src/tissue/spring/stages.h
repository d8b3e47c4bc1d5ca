// stages.h — the stages of the spring step (internal): what step.cpp wires into its pipeline, each
// in the file of its job (external.cpp, all_pairs.cpp, spring_pass.cpp, momentum.cpp, contact.cpp,
// integrators.cpp, diagnostics.cpp, step.cpp). Arrays are (n x 3) unless said; SI units.
#pragma once

#include <palpate/spring.h>

#include <cstddef>
#include <cstdint>

namespace palpate::spring {

// step.cpp — forces: all forces at the start of the step into s.force (the external ones also left
// in s.work), and the anchors' load. With stiffness_term (the predictor's path, generic springs)
// s.rhs also receives −h K_L v.
void all_forces(const SpringModel& model, SpringState& s, const ToolState* tool, bool stiffness_term = false) noexcept;

// step.cpp — the last stage: v⁺ = v + Δv (anchored vertices held at zero velocity), x⁺ = x + h v⁺.
void advance(const SpringModel& model, SpringState& s, const RowMat3d& dv) noexcept;

// external.cpp — gravity into f (overwritten), then the tool's probe and grasp forces added
// (tool may be nullptr). Returns the force on the tool, N.
Vec3 external_forces(const SpringModel& model, SpringState& s, const ToolState* tool, RowMat3d& f) noexcept;

// all_pairs.cpp — the all-pairs spring forces (model.all_pairs) added to f, through s.soa (or
// s.soa_single in single precision).
void add_all_pair_forces(const SpringModel& model, const RowMat3d& x, const RowMat3d& v, RowMat3d& f,
                         SpringState& s) noexcept;

// spring_pass.cpp — Hooke-plus-damper forces of every spring, and the volume term's, added to f
// (the scalar reference, without the predictor's −h K_L v term).
void add_spring_forces(const SpringNetwork& net, const RowMat3d& x, const RowMat3d& v, RowMat3d& f) noexcept;

// spring_pass.cpp — the fused step's right-hand side: row perm[i] of z4 (4n, x, y, z, 0 per vertex)
// = h (r + ((f_ext + f) − γ v)), zero when vertex i is anchored; fr the padded pass's sums (8n),
// work the external forces and v the velocities (3n each).
void fused_rhs(size_t n, double h, double gamma, const int* perm, const std::uint8_t* anchored, const double* fr,
               const double* work, const double* v, double* z4) noexcept;

// momentum.cpp — the predictor's angular-momentum correction of dv (DS99 §4.3); ext_torque is
// Σ x_i × f_ext,i about the origin, N·m.
void correct_angular_momentum(const SpringModel& model, const SpringState& s, const Vec3& ext_torque,
                              RowMat3d& dv) noexcept;

// contact.cpp — the surface contact after the solve: corrects the carried contact force and moves
// the contact vertices (SpringContact::surface).
void surface_contact(const SpringModel& model, SpringState& s, const ToolState& tool) noexcept;

// integrators.cpp — x = A⁻¹ b with the model's predictor (dense, supernodal or column by column).
void solve_predictor(const SpringModel& model, SpringState& s, const RowMat3d& b, RowMat3d& x) noexcept;
// integrators.cpp — SpringModelOptions::exact_iterations of preconditioned conjugate gradients
// toward the exact linearised backward Euler, added to s.dv.
void refine_toward_exact(const SpringModel& model, SpringState& s) noexcept;
// integrators.cpp — Newton on the full non-linear backward Euler (SpringSolver::exact; allocates).
void step_exact(const SpringModel& model, SpringState& s, const ToolState* tool);
// integrators.cpp — BDF2's start: the state extrapolated from this step's and the last one's.
void bdf2_start(SpringState& s) noexcept;

// diagnostics.cpp — the force of the organ on its anchors (f_all the total force at the start of
// the step), N; and whether the state is finite and slower than max_speed.
Vec3 anchor_load(const SpringModel& model, const RowMat3d& f_all) noexcept;
bool finite_and_slow(const SpringModel& model, const SpringState& s) noexcept;

}  // namespace palpate::spring
