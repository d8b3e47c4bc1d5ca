// contact.cpp — secant stiffness estimate, passive projection, and the virtual coupling step.
#include "haptics/contact.h"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>

namespace palpate {

void broyden_update(Mat3& jacobian, const Vec3& dx, const Vec3& df, double min_step) noexcept {
  const double dx2 = dx.squaredNorm();
  if (!(dx2 >= min_step * min_step) || !df.allFinite()) return;
  jacobian += (df - jacobian * dx) * dx.transpose() / dx2;
}

Mat3 make_passive(const Mat3& jacobian, double max_stiffness) noexcept {
  if (!jacobian.allFinite()) return Mat3::Zero();
  const Mat3 sym = 0.5 * (jacobian + jacobian.transpose());
  Eigen::SelfAdjointEigenSolver<Mat3> es;
  es.computeDirect(sym);
  Vec3 ev = es.eigenvalues();
  for (int i = 0; i < 3; ++i) ev[i] = std::clamp(ev[i], -std::max(0.0, max_stiffness), 0.0);
  Mat3 out = es.eigenvectors() * ev.asDiagonal() * es.eigenvectors().transpose();
  return out.allFinite() ? out : Mat3::Zero();
}

void ContactEstimator::update(const Vec3& x, const Vec3& f) noexcept {
  if (!x.allFinite() || !f.allFinite()) return;
  if (have_last_) {
    Mat3 j = jacobian_;
    broyden_update(j, x - last_x_, f - last_f_);
    jacobian_ = make_passive(j, max_stiffness_);
  }
  last_x_ = x, last_f_ = f, have_last_ = true;
}

void ContactEstimator::reset() noexcept {
  jacobian_.setZero();
  have_last_ = false;
}

CouplingModel make_coupling(const DeviceLimits& limits, double proxy_mass, double stiffness) {
  CouplingModel c;
  c.proxy_mass = std::max(proxy_mass, 1e-6);
  const double k_max = std::max(0.0, limits.stiffness);
  c.stiffness = stiffness > 0 ? std::min(stiffness, k_max) : k_max;
  c.damping = std::min(2.0 * std::sqrt(c.stiffness * c.proxy_mass), std::max(0.0, limits.damping));
  return c;
}

Vec3 step_proxy(const CouplingModel& c, ProxyState& proxy, const Vec3& device_position,
                const Vec3& device_velocity, const Vec3& tissue_force, const Mat3& tissue_jacobian,
                double dt) noexcept {
  const double m = c.proxy_mass, k = c.stiffness, b = c.damping;
  const Mat3 a = (m + dt * b + dt * dt * k) * Mat3::Identity() - dt * dt * tissue_jacobian;
  const Vec3 rhs = m * proxy.velocity +
                   dt * (tissue_force + k * (device_position - proxy.position) + b * device_velocity);
  // `a` is symmetric positive definite when J is passive; partial-pivot LU is cheap and safe.
  Vec3 v1 = a.partialPivLu().solve(rhs);
  if (!v1.allFinite()) v1.setZero();
  proxy.velocity = v1;
  proxy.position += dt * v1;
  return -(k * (device_position - proxy.position) + b * (device_velocity - proxy.velocity));
}

}  // namespace palpate
