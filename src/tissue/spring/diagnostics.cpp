// diagnostics.cpp — figures of a spring state (energies, momenta, displacement), the anchors' load,
// and the blow-up check the step ends with.
#include <palpate/spring.h>

#include "tissue/spring/forces.h"
#include "tissue/spring/stages.h"

#include <algorithm>
#include <cmath>

namespace palpate {

namespace spring {

// Force of the organ on its anchors: everything acting on the anchored vertices (springs, their
// weight). f_all is the total force (n x 3) at the start of the step.
Vec3 anchor_load(const SpringModel& model, const RowMat3d& f_all) noexcept {
  Vec3 sum = Vec3::Zero();
  for (int a : model.network.anchors) sum += f_all.row(a).transpose();
  return sum;
}

bool finite_and_slow(const SpringModel& model, const SpringState& s) noexcept {
  const double vmax2 = model.options.max_speed * model.options.max_speed;
  const Eigen::Index n = s.x.rows();
  for (Eigen::Index i = 0; i < n; ++i) {
    const double v2 = s.v.row(i).squaredNorm();
    if (!(v2 <= vmax2) || !std::isfinite(s.x(i, 0) + s.x(i, 1) + s.x(i, 2))) return false;
  }
  return true;
}

}  // namespace spring

double kinetic_energy(const SpringModel& model, const SpringState& s) noexcept {
  double e = 0;
  for (Eigen::Index i = 0; i < s.v.rows(); ++i) e += 0.5 * model.network.mass[static_cast<size_t>(i)] * s.v.row(i).squaredNorm();
  return e;
}

double elastic_energy(const SpringModel& model, const SpringState& s) noexcept {
  const SpringNetwork& net = model.network;
  double e = 0;
  for (size_t k = 0; k < net.springs.size(); ++k) {
    const double l = (s.x.row(net.springs[k][0]) - s.x.row(net.springs[k][1])).norm();
    e += 0.5 * net.stiffness[k] * (l - net.rest_length[k]) * (l - net.rest_length[k]);
  }
  if (!net.tets.empty() && net.volume_modulus > 0) {
    RowMat3d scratch = RowMat3d::Zero(s.x.rows(), 3);  // not on the tick
    e += spring::add_volume_forces(net, s.x.data(), 3, scratch.data(), 3);
  }
  return e;
}

Vec3 linear_momentum(const SpringModel& model, const SpringState& s) noexcept {
  Vec3 p = Vec3::Zero();
  for (Eigen::Index i = 0; i < s.v.rows(); ++i) p += model.network.mass[static_cast<size_t>(i)] * s.v.row(i).transpose();
  return p;
}

Vec3 angular_momentum(const SpringModel& model, const SpringState& s) noexcept {
  Vec3 l = Vec3::Zero();
  for (Eigen::Index i = 0; i < s.v.rows(); ++i)
    l += model.network.mass[static_cast<size_t>(i)] * s.x.row(i).transpose().cross(s.v.row(i).transpose());
  return l;
}

double max_displacement(const SpringModel& model, const SpringState& s) noexcept {
  double d2 = 0;
  for (Eigen::Index i = 0; i < s.x.rows(); ++i) d2 = std::max(d2, (s.x.row(i) - model.network.rest.row(i)).squaredNorm());
  return std::sqrt(d2);
}

}  // namespace palpate
