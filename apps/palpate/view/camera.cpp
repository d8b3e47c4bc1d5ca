// camera.cpp — OrbitCamera's matrices, mouse controls and pixel rays; ray–triangle picking.
#include "camera.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace palpate::view {

namespace {

constexpr double kMaxPitch = 1.55;  // rad, just short of straight up/down (the up vector degenerates)

}  // namespace

OrbitCamera OrbitCamera::from(const CameraDef& def) {
  OrbitCamera c;
  c.target = def.target;
  c.fov = def.fov;
  const Vec3 offset = def.position - def.target;  // target to eye
  c.distance = offset.norm();
  if (!(c.distance > 0) || !std::isfinite(c.distance)) {
    c.distance = 0.1;
    return c;
  }
  c.pitch = std::clamp(std::asin(std::clamp(offset.y() / c.distance, -1.0, 1.0)), -kMaxPitch, kMaxPitch);
  c.yaw = std::atan2(offset.x(), offset.z());
  return c;
}

Vec3 OrbitCamera::eye() const {
  const Vec3 offset(std::cos(pitch) * std::sin(yaw), std::sin(pitch), std::cos(pitch) * std::cos(yaw));
  return target + distance * offset;
}

Vec3 OrbitCamera::forward() const { return (target - eye()).normalized(); }

Vec3 OrbitCamera::right() const { return forward().cross(Vec3::UnitY()).normalized(); }

Vec3 OrbitCamera::up() const { return right().cross(forward()); }

Eigen::Matrix4f OrbitCamera::view_matrix() const {
  const Vec3 f = forward(), r = right(), u = up(), e = eye();
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.block<1, 3>(0, 0) = r.transpose();
  m.block<1, 3>(1, 0) = u.transpose();
  m.block<1, 3>(2, 0) = -f.transpose();
  m(0, 3) = -r.dot(e);
  m(1, 3) = -u.dot(e);
  m(2, 3) = f.dot(e);
  return m.cast<float>();
}

Eigen::Matrix4f OrbitCamera::projection_matrix(double aspect) const {
  const double n = near_plane(), f = far_plane();
  const double t = 1.0 / std::tan(fov * std::numbers::pi / 360.0);
  Eigen::Matrix4d p = Eigen::Matrix4d::Zero();
  p(0, 0) = t / aspect;
  p(1, 1) = t;
  p(2, 2) = (f + n) / (n - f);
  p(2, 3) = 2 * f * n / (n - f);
  p(3, 2) = -1;
  return p.cast<float>();
}

void OrbitCamera::orbit(double dx, double dy) {
  yaw -= dx * 0.01;
  pitch = std::clamp(pitch + dy * 0.01, -kMaxPitch, kMaxPitch);
}

void OrbitCamera::pan(double dx, double dy, int height) {
  // One pixel moves the target by the size of a pixel at the target's depth.
  const double metres_per_pixel =
      2.0 * distance * std::tan(fov * std::numbers::pi / 360.0) / std::max(1, height);
  target += (-dx * right() + dy * up()) * metres_per_pixel;
}

void OrbitCamera::zoom(double notches) { distance = std::clamp(distance * std::pow(0.9, notches), 1e-4, 1e3); }

Vec3 OrbitCamera::ray_direction(double x, double y, int width, int height) const {
  const double w = std::max(1, width), h = std::max(1, height);
  const double ndc_x = 2.0 * x / w - 1.0, ndc_y = 1.0 - 2.0 * y / h;
  const double t = std::tan(fov * std::numbers::pi / 360.0);
  return (forward() + ndc_x * t * (w / h) * right() + ndc_y * t * up()).normalized();
}

std::optional<Eigen::Vector2d> OrbitCamera::project(const Vec3& point, int width, int height) const {
  const Vec3 d = point - eye();
  const double z = d.dot(forward());
  if (!(z > 0)) return std::nullopt;
  const double t = std::tan(fov * std::numbers::pi / 360.0);
  const double w = std::max(1, width), h = std::max(1, height);
  const double ndc_x = d.dot(right()) / (z * t * (w / h)), ndc_y = d.dot(up()) / (z * t);
  return Eigen::Vector2d((ndc_x + 1.0) * 0.5 * w, (1.0 - ndc_y) * 0.5 * h);
}

std::optional<double> pick(const Vec3& origin, const Vec3& dir, std::span<const float> positions,
                           std::span<const std::uint32_t> triangles) {
  std::optional<double> best;
  const size_t points = positions.size() / 3;
  auto at = [&](std::uint32_t i) {
    return Vec3(positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]);
  };
  for (size_t k = 0; k + 2 < triangles.size(); k += 3) {
    if (triangles[k] >= points || triangles[k + 1] >= points || triangles[k + 2] >= points) continue;
    const Vec3 a = at(triangles[k]), e1 = at(triangles[k + 1]) - a, e2 = at(triangles[k + 2]) - a;
    const Vec3 p = dir.cross(e2);
    const double det = e1.dot(p);
    if (std::abs(det) < 1e-18) continue;  // parallel to the triangle (or a degenerate one)
    const double inv = 1.0 / det;
    const Vec3 s = origin - a;
    const double u = s.dot(p) * inv;
    if (u < 0 || u > 1) continue;
    const Vec3 q = s.cross(e1);
    const double v = dir.dot(q) * inv;
    if (v < 0 || u + v > 1) continue;
    const double t = e2.dot(q) * inv;
    if (t > 0 && (!best || t < *best)) best = t;
  }
  return best;
}

}  // namespace palpate::view
