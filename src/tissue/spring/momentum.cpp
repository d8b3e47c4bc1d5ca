// momentum.cpp — the predictor's post-step angular-momentum correction (Desbrun, Schröder & Barr
// 1999, §4.3).
#include <palpate/spring.h>

#include "tissue/spring/stages.h"

#include <Eigen/Eigenvalues>

namespace palpate::spring {

// The post-step correction for the dropped non-linear part (DS99 §4.3): spring forces are
// central, so they must not change the angular momentum; the predictor's transverse stiffness
// (K_L ⊗ I3 instead of the true k uuᵀ) does. The spurious change
//   δL = Σ m_i x_i × Δv_i − h (τ_ext + Σ x_i × (−γ v_i⁺))
// (τ_ext = Σ x_i × f_ext,i, about the origin) is removed by a rigid angular velocity ω = I⁺ δL,
// I the inertia tensor about the centre of mass c: Δv_i −= ω × (x_i − c). Linear momentum is
// unchanged since Σ m_i (x_i − c) = 0. Free bodies only: anchors exert torques implicitly.
void correct_angular_momentum(const SpringModel& model, const SpringState& s, const Vec3& ext_torque,
                              RowMat3d& dv) noexcept {
  const double h = model.options.dt;
  const double gamma = model.options.point_damping;
  const Eigen::Index n = s.x.rows();
  Vec3 c = Vec3::Zero();
  for (Eigen::Index i = 0; i < n; ++i) c += model.network.mass[static_cast<size_t>(i)] * s.x.row(i).transpose();
  c /= model.total_mass;
  Vec3 delta = -h * ext_torque;
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();
  for (Eigen::Index i = 0; i < n; ++i) {
    const double m = model.network.mass[static_cast<size_t>(i)];
    const Vec3 xi = s.x.row(i).transpose();
    const Vec3 dvi = dv.row(i).transpose();
    const Vec3 v_new = s.v.row(i).transpose() + dvi;
    delta += xi.cross(m * dvi + h * gamma * v_new);
    const Vec3 r = xi - c;
    inertia += m * (r.squaredNorm() * Eigen::Matrix3d::Identity() - r * r.transpose());
  }
  // Pseudo-inverse: a collinear body has no inertia about its own axis.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(inertia);
  const double top = eig.eigenvalues().maxCoeff();
  if (!(top > 0)) return;
  Vec3 w = eig.eigenvectors().transpose() * delta;
  for (int k = 0; k < 3; ++k) w[k] = eig.eigenvalues()[k] > 1e-12 * top ? w[k] / eig.eigenvalues()[k] : 0.0;
  const Vec3 omega = eig.eigenvectors() * w;
  for (Eigen::Index i = 0; i < n; ++i) dv.row(i) -= omega.cross(s.x.row(i).transpose() - c).transpose();
}

}  // namespace palpate::spring
