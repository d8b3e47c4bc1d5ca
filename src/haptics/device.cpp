// device.cpp — make_device: the backend a scene's `device.kind` names, with its limits; the
// needle's direction for a device orientation.
#include <palpate/device.h>

namespace palpate {

Vec3 needle_axis(const Vec3& tool_axis, const Quat& orientation) noexcept {
  if (orientation.vec().isZero()) return tool_axis;
  return (orientation * tool_axis).normalized();
}

Result<std::unique_ptr<Device>> make_device(const SceneDef& scene) {
  return make_device(scene.device, scene.tool.axis,
                     scene.file.empty() ? std::string("scene") : scene.file.string());
}

DeviceLimits device_limits(const DeviceDef& d) {
  DeviceLimits limits;
  limits.max_force = d.max_force;
  limits.max_force_rate = d.max_force_rate;
  limits.stiffness = d.stiffness;
  limits.damping = d.damping;
  return limits;
}

Result<std::unique_ptr<Device>> make_device(const DeviceDef& d, const Vec3& tool_axis,
                                            const std::string& where, const std::string& key) {
  const DeviceLimits limits = device_limits(d);
  if (d.kind == "scripted") {
    std::vector<Waypoint> points = d.waypoints;
    if (!d.trajectory.empty()) {
      auto loaded = load_trajectory_csv(d.trajectory);
      if (!loaded) return loaded.error();
      points = std::move(*loaded);
    }
    return std::unique_ptr<Device>(new ScriptedDevice(std::move(points), limits, tool_axis));
  }
  if (d.kind == "replay") {
    if (d.recording.empty())
      return Error{where + ": " + key + " kind 'replay' needs " + key + ".recording (a run's run.csv)"};
    auto samples = load_recording_csv(d.recording);
    if (!samples) return samples.error();
    return std::unique_ptr<Device>(new ReplayDevice(std::move(*samples), limits));
  }
  if (d.kind == "openhaptics") return open_openhaptics(d.hd_library, d.hd_device, limits);
  if (d.kind == "forcedimension") return open_forcedimension(d.dhd_library, d.dhd_index, d.dhd_serial, limits);
  return Error{where + ": " + key + " kind '" + d.kind +
               "' is not one of scripted | replay | openhaptics | forcedimension (use kind: scripted)"};
}

}  // namespace palpate
