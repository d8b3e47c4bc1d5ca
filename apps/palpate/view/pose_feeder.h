// pose_feeder.h — PoseFeeder: moves the virtual haptic device towards where the mouse puts the
// tool (position and orientation), at 1 kHz and a bounded speed, from its own thread (never the
// haptic thread).
#pragma once

#include <palpate/core.h>
#include <palpate/device.h>

#include <atomic>
#include <mutex>
#include <thread>

namespace palpate::view {

// The display runs at 30–60 Hz (less under software GL) while the haptic loop reads the device at
// 1 kHz: handing it the mouse's position once per frame would make the tool jump millimetres per
// tick (a needle 0.8 mm thick would tunnel through a layer). So the GUI only sets a target; this
// thread walks the device's pose towards it every millisecond at no more than `max_speed`, with a
// matching velocity, through VirtualDevice::set_pose (lock-free on the haptic side). The needle's
// orientation is walked the same way, at no more than `max_turn_rate`: a tilted needle inside the
// tissue turns smoothly instead of jumping by a frame's worth of mouse travel.
class PoseFeeder {
 public:
  // `device` must outlive the feeder. The pose starts (and stays until set_target) at `start`.
  PoseFeeder(VirtualDevice& device, const Vec3& start, double max_speed);
  ~PoseFeeder();
  PoseFeeder(const PoseFeeder&) = delete;
  PoseFeeder& operator=(const PoseFeeder&) = delete;

  void set_target(const Vec3& target);      // m; GUI thread (ends a turn about a pivot)
  // Put the pose at once where a hardware device is (the viewer drawing a tool a haptic device
  // holds, not the mouse): position, target and orientation all at it, nothing left to walk.
  void follow(const Vec3& position, const Quat& orientation);
  // Turn a needle about a point on its shaft (the skin hole it went in through): from now until the
  // next set_target, each millisecond's target is pivot + beyond · the needle's direction at that
  // millisecond's orientation (needle_axis of `tool_axis`), so the shaft passes through the pivot
  // all through the rate-limited turn and the tip swings the other way from the handle.
  void set_pivot(const Vec3& pivot, double beyond, const Vec3& tool_axis);
  bool pivoting() const;
  void set_max_speed(double metres_per_second);
  Vec3 target() const;
  Vec3 position() const;                    // m, the pose last handed to the device
  bool arrived() const;                     // the pose has reached the target
  void set_orientation_target(const Quat& target);  // unit; GUI thread
  Quat orientation_target() const;
  Quat orientation() const;                 // the orientation last handed to the device

  static constexpr double max_turn_rate = 2.0;  // rad/s, fastest the mouse turns the needle

 private:
  void run();

  VirtualDevice& device_;
  mutable std::mutex mutex_;  // between the GUI and this thread only; the haptic thread never waits
  Vec3 target_, position_;
  Quat orientation_target_ = Quat::Identity(), orientation_ = Quat::Identity();
  double max_speed_;
  bool arrived_ = true;
  bool pivoting_ = false;
  Vec3 pivot_ = Vec3::Zero(), pivot_axis_ = Vec3::UnitZ();
  double beyond_ = 0;
  std::atomic<bool> quit_{false};
  std::thread thread_;
};

}  // namespace palpate::view
