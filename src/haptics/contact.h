// contact.h — a local contact model linearised at the last physics step, F(x) ≈ F0 + J·(x − x0),
// its secant (Broyden) estimate of J, and the virtual coupling between a device and a tool proxy.
#pragma once

#include <palpate/core.h>
#include <palpate/device.h>

#include <Eigen/Core>

namespace palpate {

using Mat3 = Eigen::Matrix3d;

// The force of a tissue on the tool near the pose of its last step: F(x) ≈ f0 + jacobian·(x − x0).
// jacobian = ∂F/∂x (N/m). A passive contact pushes back, so it is symmetric negative semi-definite.
struct ContactLinearisation {
  Vec3 x0 = Vec3::Zero();         // m, tool position at the last physics step
  Vec3 f0 = Vec3::Zero();         // N, force at that step
  Mat3 jacobian = Mat3::Zero();   // N/m, ∂F/∂x
  // F0 + J·(x − x0), as a contact: it only pushes. Nothing where the step had no contact (f0 = 0:
  // the tool was free, and a J learnt earlier must not render a force in free space — a 54k organ
  // stepping late rendered 2.8 N on a probe 5 mm above it moving sideways; a contact that begins
  // between steps is felt from the next step, at most a period late), and nothing once the linear
  // force turns against f0's direction (the tool leaving).
  Vec3 force_at(const Vec3& x) const noexcept {
    if (!(f0.squaredNorm() > 0)) return Vec3::Zero();
    const Vec3 f = f0 + jacobian * (x - x0);
    return f.dot(f0) > 0 ? f : Vec3::Zero();
  }
};

// Broyden's rank-one secant update (Broyden 1965, "A class of methods for solving nonlinear
// simultaneous equations"): the smallest change to J that makes J·dx = df hold,
//   J ← J + (df − J·dx) dxᵀ / (dxᵀ dx).
// Skipped when |dx| < min_step (m): a still tool carries no information about the stiffness.
void broyden_update(Mat3& jacobian, const Vec3& dx, const Vec3& df, double min_step = 1e-7) noexcept;

// The nearest passive stiffness: symmetric part, eigenvalues clamped to [−max_stiffness, 0] (N/m),
// so the rendered contact never injects energy and never exceeds what the device can render.
Mat3 make_passive(const Mat3& jacobian, double max_stiffness) noexcept;

// Tracks (x, F) pairs of successive physics steps and keeps a passive secant estimate of ∂F/∂x.
class ContactEstimator {
 public:
  explicit ContactEstimator(double max_stiffness) : max_stiffness_(max_stiffness) {}
  void update(const Vec3& x, const Vec3& f) noexcept;
  void set_jacobian(const Mat3& j) noexcept { jacobian_ = make_passive(j, max_stiffness_); }
  const Mat3& jacobian() const noexcept { return jacobian_; }
  void reset() noexcept;

 private:
  double max_stiffness_;
  Mat3 jacobian_ = Mat3::Zero();
  Vec3 last_x_ = Vec3::Zero(), last_f_ = Vec3::Zero();
  bool have_last_ = false;
};

// Virtual coupling (Colgate, Stanley & Brown 1995, "Issues in the haptic display of tool use";
// Adams & Hannaford 1999): a spring-damper between the device at x and a tool proxy of mass m at
// p that the tissue pushes. Stiffness k ≤ DeviceLimits::stiffness; damping b = 2·sqrt(k·m)
// (critical damping of the proxy), clamped to DeviceLimits::damping.
struct CouplingModel {
  double stiffness = 0;   // N/m
  double damping = 0;     // N·s/m
  double proxy_mass = 0;  // kg
};
CouplingModel make_coupling(const DeviceLimits& limits, double proxy_mass, double stiffness = 0);

struct ProxyState {
  Vec3 position = Vec3::Zero();  // m
  Vec3 velocity = Vec3::Zero();  // m/s
};

// One step of the proxy, implicit (backward Euler) in the coupling and in the tissue's linearised
// stiffness J = ∂F/∂x, so a stiff tissue stays stable at 1 kHz:
//   m (v1 − v0) = dt [F_t + J dt v1 + k (x − p0 − dt v1) + b (v_x − v1)],   p1 = p0 + dt v1
//   ⇒ (m + dt b + dt² k − dt² J) v1 = m v0 + dt [F_t + k (x − p0) + b v_x].
// Returns the force on the device, −(k (x − p1) + b (v_x − v1)) (N): in static contact it equals
// the tissue's force on the proxy, felt through the coupling spring in series.
Vec3 step_proxy(const CouplingModel& c, ProxyState& proxy, const Vec3& device_position,
                const Vec3& device_velocity, const Vec3& tissue_force, const Mat3& tissue_jacobian,
                double dt) noexcept;

}  // namespace palpate
