// pose_feeder.cpp — PoseFeeder: the 1 kHz, speed-limited walk of the virtual device's pose and
// orientation.
#include "pose_feeder.h"

#include "tool_tilt.h"

#include <chrono>
#include <cmath>

namespace palpate::view {

PoseFeeder::PoseFeeder(VirtualDevice& device, const Vec3& start, double max_speed)
    : device_(device), target_(start), position_(start), max_speed_(max_speed) {
  DeviceState s;
  s.position = start;
  device_.set_pose(s);
  thread_ = std::thread([this] { run(); });
}

PoseFeeder::~PoseFeeder() {
  quit_.store(true);
  thread_.join();
}

void PoseFeeder::set_target(const Vec3& target) {
  if (!target.allFinite()) return;
  std::lock_guard lock(mutex_);
  target_ = target;
  pivoting_ = false;
  arrived_ = (target_ - position_).norm() < 1e-9;
}

void PoseFeeder::follow(const Vec3& position, const Quat& orientation) {
  if (!position.allFinite() || !orientation.coeffs().allFinite()) return;
  std::lock_guard<std::mutex> lock(mutex_);
  position_ = target_ = position;
  orientation_ = orientation_target_ = orientation;
  pivoting_ = false;
  arrived_ = true;
}

void PoseFeeder::set_pivot(const Vec3& pivot, double beyond, const Vec3& tool_axis) {
  if (!pivot.allFinite() || !std::isfinite(beyond) || !tool_axis.allFinite() || !(tool_axis.norm() > 0)) return;
  std::lock_guard lock(mutex_);
  pivoting_ = true;
  pivot_ = pivot;
  beyond_ = beyond;
  pivot_axis_ = tool_axis.normalized();
  target_ = pivot_ + beyond_ * needle_axis(pivot_axis_, orientation_);
  arrived_ = false;
}

bool PoseFeeder::pivoting() const {
  std::lock_guard lock(mutex_);
  return pivoting_;
}

void PoseFeeder::set_max_speed(double metres_per_second) {
  std::lock_guard lock(mutex_);
  max_speed_ = metres_per_second > 0 ? metres_per_second : max_speed_;
}

Vec3 PoseFeeder::target() const {
  std::lock_guard lock(mutex_);
  return target_;
}

Vec3 PoseFeeder::position() const {
  std::lock_guard lock(mutex_);
  return position_;
}

bool PoseFeeder::arrived() const {
  std::lock_guard lock(mutex_);
  return arrived_;
}

void PoseFeeder::set_orientation_target(const Quat& target) {
  if (!target.coeffs().allFinite() || !(target.norm() > 0)) return;
  std::lock_guard lock(mutex_);
  orientation_target_ = target.normalized();
}

Quat PoseFeeder::orientation_target() const {
  std::lock_guard lock(mutex_);
  return orientation_target_;
}

Quat PoseFeeder::orientation() const {
  std::lock_guard lock(mutex_);
  return orientation_;
}

void PoseFeeder::run() {
  using clock = std::chrono::steady_clock;
  auto last = clock::now();
  while (!quit_.load(std::memory_order_relaxed)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
    const auto now = clock::now();
    const double dt = std::chrono::duration<double>(now - last).count();
    last = now;
    DeviceState s;
    {
      std::lock_guard lock(mutex_);
      orientation_ = turn_towards(orientation_, orientation_target_, max_turn_rate * dt);
      if (pivoting_) target_ = pivot_ + beyond_ * needle_axis(pivot_axis_, orientation_);
      const Vec3 to_go = target_ - position_;
      const double distance = to_go.norm();
      const double reach = max_speed_ * dt;
      Vec3 step = to_go;
      if (distance > reach) step *= reach / distance;
      position_ += step;
      arrived_ = distance <= reach && (!pivoting_ || orientation_.angularDistance(orientation_target_) < 1e-9);
      s.position = position_;
      s.velocity = dt > 0 ? Vec3(step / dt) : Vec3::Zero();
      s.orientation = orientation_;
    }
    device_.set_pose(s);
  }
}

}  // namespace palpate::view
