// palpate/contact.h — what a tissue model offers a haptic loop about its contact, and a tool's own
// force law: plain interfaces of the tissue layer, so tissue models implement them without
// knowing the loop (the haptics layer uses them; DESIGN.md §3).
#pragma once

#include <palpate/core.h>
#include <palpate/tissue.h>

#include <Eigen/Core>

#include <array>

namespace palpate {

// Optional for a Tissue model: the contact stiffness at its last step, ∂F/∂x (N/m), where F is the
// force on the tool and x the tool's position. A multi-rate loop renders F0 + J·(x − x0) between
// the model's steps; a model that does not offer it gets a secant (Broyden) estimate instead.
class ContactJacobianSource {
 public:
  virtual ~ContactJacobianSource() = default;
  // False when the model has no estimate this step (the secant estimate is used then).
  virtual bool contact_jacobian(Eigen::Matrix3d& dforce_dposition) const noexcept = 0;
};

// Optional for a Tissue model (issue 24): the compliance of the organ's surface near the tool, so a
// multi-rate loop can solve the contact itself every tick between the model's steps instead of
// extrapolating a force. After each step the model describes the surface points within reach of
// the tool as they would be at the end of its next step without any contact force (free_position),
// the triangles over them, and their compliance W: a load L_j (N) on point j moves point i by
// W_ij L_j (m), the same for each coordinate. The haptic thread then solves, every tick, the
// penalty contact of the tool's sphere with these points (src/haptics/contact.h, solve_patch).
struct ContactPatch {
  static constexpr int kMaxPoints = 128;
  static constexpr int kMaxTriangles = 256;
  int point_count = 0;
  int triangle_count = 0;
  std::array<Vec3, kMaxPoints> free_position{};                  // m
  std::array<Vec3, kMaxPoints> free_velocity{};                  // m/s: the points' velocity at the step;
                                                                   // the haptic solve moves the free
                                                                   // positions on with it between steps
  std::array<std::array<int, 3>, kMaxTriangles> triangle{};        // indices into the points, outward (CCW)
  std::array<double, static_cast<size_t>(kMaxPoints) * kMaxPoints> compliance{};  // m/N, W row-major
                                                                                   // (point_count x point_count)
  double stiffness = 0;       // N/m, the model's contact penalty k_c (force per metre of depth)
  Vec3 centre = Vec3::Zero(); // m, the tool's centre the patch was gathered around
  double reach = 0;           // m, the patch holds every surface triangle the tool's sphere can touch
                              // while its centre stays within reach of `centre`
};

class ContactComplianceSource {
 public:
  virtual ~ContactComplianceSource() = default;
  // Physics thread, right after step(tool, dt): fill `out` around the tool. False when the model
  // has none this step (then the loop renders the linearised contact, ContactJacobianSource or the
  // secant). May compute and cache (allocation-free once warm), never called on the haptic thread.
  // `horizon` (s, ≥ dt): how long the patch will be rendered before the next one — dt when the
  // physics keeps its rate, the time its steps actually take when they run late; the patch reaches
  // as far as the tool can go in that time.
  virtual bool contact_patch(const ToolState& tool, double dt, double horizon, ContactPatch& out) noexcept = 0;
};

// A tool's force law other than the tissues' contact: evaluated on the haptic thread every tick
// (noexcept, no allocation, no locks), the force on the tool (N) at its pose and the run's time (s).
// The ultrasound probe's is NeckCompression (palpate/ultrasound.h).
class ToolForceModel {
 public:
  virtual ~ToolForceModel() = default;
  virtual Vec3 force(const Vec3& position, const Quat& orientation, double t) noexcept = 0;
  // A model that deforms the tissues the other tools meet (the probe pressing the neck the needle
  // goes into): where the tissue now at `x` lay at rest, under the pose of the last force() call.
  // The tissues are built at rest, so the loop steps them with the other tools mapped through this:
  // one tissue under both tools. Haptic thread: noexcept, no allocation. False (X untouched) when
  // the model deforms nothing (the default) or has not been posed yet.
  virtual bool to_rest(const Vec3& x, Vec3& X) const noexcept {
    (void)x, (void)X;
    return false;
  }
};

}  // namespace palpate
