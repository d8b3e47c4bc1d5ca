// palpate/device.h — haptic devices: what goes in (pose, velocity, buttons), what comes out
// (force, torque), the device's limits, and the scripted backend.
#pragma once

#include <palpate/core.h>
#include <palpate/scene.h>

#include <cstdint>
#include <memory>
#include <vector>

namespace palpate {

struct DeviceLimits {
  double max_force = 3.3;         // N
  double max_force_rate = 200.0;  // N/s
  double stiffness = 1000.0;      // N/m, nominal maximum stable stiffness
  double damping = 2.0;           // N·s/m
  Vec3 workspace_min = Vec3(-0.08, -0.06, -0.035);  // m (Geomagic Touch: 160 x 120 x 70 mm)
  Vec3 workspace_max = Vec3(0.08, 0.06, 0.035);
};

struct DeviceState {
  double time = 0;                       // s
  Vec3 position = Vec3::Zero();          // m
  Quat orientation = Quat::Identity();
  Vec3 velocity = Vec3::Zero();          // m/s
  std::uint32_t buttons = 0;
};

// A haptic device backend. read/write are called from the haptic thread: noexcept, no allocation.
class Device {
 public:
  virtual ~Device() = default;
  virtual const DeviceLimits& limits() const = 0;
  // Read the device's state at time t (s since start); false when the device failed.
  virtual bool read(double t, DeviceState& out) noexcept = 0;
  // Send force (N) and torque (N·m). Callers pass only values that went through safety.
  virtual void write(const Vec3& force, const Vec3& torque) noexcept = 0;
};

// Timed waypoints, linearly interpolated, held at the ends; velocity is the segment's slope.
class ScriptedDevice final : public Device {
 public:
  ScriptedDevice(std::vector<Waypoint> waypoints, DeviceLimits limits);
  const DeviceLimits& limits() const override { return limits_; }
  bool read(double t, DeviceState& out) noexcept override;
  void write(const Vec3& force, const Vec3& torque) noexcept override;
  const Vec3& last_force() const { return last_force_; }

 private:
  std::vector<Waypoint> waypoints_;
  DeviceLimits limits_;
  Vec3 last_force_ = Vec3::Zero();
  size_t segment_ = 0;  // cache of the current segment: ticks walk forward
};

// Read a CSV trajectory (columns t,x,y,z; '#' comments and one header line allowed).
Result<std::vector<Waypoint>> load_trajectory_csv(const std::filesystem::path& file);

// The device a scene asks for.
Result<std::unique_ptr<Device>> make_device(const SceneDef& scene);

}  // namespace palpate
