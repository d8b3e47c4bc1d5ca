// palpate/device.h — haptic devices: what goes in (pose, velocity, buttons), what comes out
// (force, torque), the device's limits, and the backends (scripted, replay, virtual, openhaptics,
// forcedimension).
#pragma once

#include <palpate/core.h>
#include <palpate/scene_def.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace palpate {

// What a device can take, as data: the safety filter and the virtual coupling read these.
struct DeviceLimits {
  double max_force = 3.3;         // N
  double max_force_rate = 200.0;  // N/s
  double stiffness = 1000.0;      // N/m, nominal maximum stable stiffness
  double damping = 2.0;           // N·s/m
  Vec3 workspace_min = Vec3(-0.08, -0.06, -0.035);  // m (Geomagic Touch: 160 x 120 x 70 mm)
  Vec3 workspace_max = Vec3(0.08, 0.06, 0.035);
  bool has_torque = false;        // whether write()'s torque reaches the hand (a Touch: no)
  double max_torque = 0;          // N·m, largest torque a backend sends (0: none; forcedimension sets it)
  double max_gripper_force = 0;   // N, largest gripper force (0: no active gripper; forcedimension sets it)
};

struct DeviceState {
  double time = 0;                       // s
  Vec3 position = Vec3::Zero();          // m
  Quat orientation = Quat::Identity();
  Vec3 velocity = Vec3::Zero();          // m/s
  std::uint32_t buttons = 0;             // bit i = button i + 1 pressed
  double gripper_angle = 0;              // rad, a gripper's opening (0 for a device without one)
};

// The direction the needle points for a device orientation: `orientation` (unit) applied to
// `tool_axis` (unit: the scene's tool.axis, the needle's direction in the device frame),
// normalised. An orientation without rotation gives `tool_axis` itself, bit for bit.
Vec3 needle_axis(const Vec3& tool_axis, const Quat& orientation) noexcept;

// A device's calibration, as its vendor's library reports it when the device opens (openhaptics:
// hdCheckCalibration). `updated`: it needed an update the library could make by itself
// (hdUpdateCalibration), and made it. A device that needs the user's hand (the stylus into its
// inkwell, the arm into its reset position) does not open: its error says what to do.
enum class Calibration { unknown, ok, updated };

// A haptic device backend. read/write are called from the haptic thread: noexcept, no allocation.
class Device {
 public:
  virtual ~Device() = default;
  virtual const DeviceLimits& limits() const = 0;
  // Read the device's state at time t (s since start); false when the device failed.
  virtual bool read(double t, DeviceState& out) noexcept = 0;
  // Send force (N) and torque (N·m). Callers pass only values that went through safety.
  virtual void write(const Vec3& force, const Vec3& torque) noexcept = 0;
  // Send a gripper force (N, the vendor's sign) to a device with an active gripper
  // (limits().max_gripper_force > 0); the others ignore it. Haptic thread, like write().
  virtual void write_gripper(double /*force*/) noexcept {}
  // Its calibration when it opened; `unknown` for a device without one (scripted, replay, virtual)
  // or a vendor library that cannot tell.
  virtual Calibration calibration() const noexcept { return Calibration::unknown; }
};

// Timed waypoints, linearly interpolated, held at the ends; velocity is the segment's slope.
// Orientation: at a waypoint with a direction, the shortest-arc rotation taking `tool_axis` (the
// needle's direction in the device frame, the scene's tool.axis) to that direction; a waypoint
// without one (or with a zero or non-finite one) keeps the previous waypoint's (identity for the
// first). Between waypoints the orientation is slerped, so the needle turns at a constant rate.
class ScriptedDevice final : public Device {
 public:
  ScriptedDevice(std::vector<Waypoint> waypoints, DeviceLimits limits, const Vec3& tool_axis);
  const DeviceLimits& limits() const override { return limits_; }
  bool read(double t, DeviceState& out) noexcept override;
  void write(const Vec3& force, const Vec3& torque) noexcept override;
  const Vec3& last_force() const { return last_force_; }

 private:
  std::vector<Waypoint> waypoints_;
  std::vector<Quat> orientations_;  // one per waypoint (unit), resolved at construction
  DeviceLimits limits_;
  Vec3 last_force_ = Vec3::Zero();
  size_t segment_ = 0;  // cache of the current segment: ticks walk forward
};

// The rotation a scripted device reports for a needle pointing along `direction` when the device
// frame's needle is `tool_axis` (both non-zero): the shortest arc from one to the other.
Quat orientation_towards(const Vec3& tool_axis, const Vec3& direction);

// Read a CSV trajectory: columns t,x,y,z (s, m) or t,x,y,z,dx,dy,dz (a needle direction, any
// non-zero length, normalised; a row without one keeps the previous row's); '#' comments and one
// header line allowed. Errors name the file and line.
Result<std::vector<Waypoint>> load_trajectory_csv(const std::filesystem::path& file);

// One recorded tick of a session: what a replay plays back.
struct RecordedSample {
  double t = 0;                          // s
  Vec3 position = Vec3::Zero();          // m
  Quat orientation = Quat::Identity();
  std::uint32_t buttons = 0;
};

// Read a run's CSV (`palpate run` writes it): a header naming the columns, then one row per tick.
// Needs t, tool_x, tool_y, tool_z; uses tool_qw..tool_qz and buttons when present.
Result<std::vector<RecordedSample>> load_recording_csv(const std::filesystem::path& file);

// A run's CSV column of whole counts, one per tick, for a replay to repeat when work done off the
// stepping thread took effect (a cut's `<tissue>.cut_installed`, docs/models/cutting.md): value i
// is the row whose `tick` is i (the row's order without a tick column); a tick with no row (a
// real-time recorder's dropped row) holds the value before it. Empty when the file has no such
// column. Refused, naming the file and line: a value that is not a whole number >= 0, one below the
// value before it, a tick that does not rise.
Result<std::vector<std::int32_t>> load_recording_counts(const std::filesystem::path& file, std::string_view column);

// A recorded session played back tick for tick: read(t) gives the last row at or before t (rows
// are ticks, so a replay at the recording's tick reproduces it exactly); velocity is the
// difference to the previous row over its time step. Held at the last row.
class ReplayDevice final : public Device {
 public:
  ReplayDevice(std::vector<RecordedSample> samples, DeviceLimits limits);
  const DeviceLimits& limits() const override { return limits_; }
  bool read(double t, DeviceState& out) noexcept override;
  void write(const Vec3& force, const Vec3& torque) noexcept override;
  const Vec3& last_force() const { return last_force_; }
  size_t size() const { return samples_.size(); }

 private:
  std::vector<RecordedSample> samples_;
  DeviceLimits limits_;
  Vec3 last_force_ = Vec3::Zero();
  size_t row_ = 0;  // cursor: ticks walk forward
};

// A device moved by another thread (the viewer's mouse, a test, a network peer): `set_pose` from
// any one thread, `read` from the haptic thread; neither ever blocks (a lock-free triple buffer).
// The last force written is readable back by the other side through `force`.
class VirtualDevice final : public Device {
 public:
  explicit VirtualDevice(DeviceLimits limits = {});
  ~VirtualDevice() override;
  VirtualDevice(const VirtualDevice&) = delete;
  VirtualDevice& operator=(const VirtualDevice&) = delete;
  const DeviceLimits& limits() const override { return limits_; }
  bool read(double t, DeviceState& out) noexcept override;
  void write(const Vec3& force, const Vec3& torque) noexcept override;
  // Producer side (one thread): the pose the haptic thread sees from its next read on.
  void set_pose(const DeviceState& state) noexcept;
  // The last force the haptic thread sent (N), from any thread.
  Vec3 force() const noexcept;

 private:
  struct Exchange;
  DeviceLimits limits_;
  std::unique_ptr<Exchange> x_;
};

// Phantom Omni / Geomagic Touch through the vendor's HD library, loaded at run time with dlopen
// (no SDK needed to build). The vendor's scheduler runs a servo callback at its own 1 kHz that
// exchanges pose and force with this object through lock-free triple buffers; read/write never
// block. HD works in millimetres: positions and velocities are converted to metres here.
// `library`: file name or path of libHD.so; `config`: HD device configuration name, "" = default.
// Errors say what is missing and how to run with the scripted device instead. The calibration is
// checked as the device opens: an update the library can make alone is made; one that needs the
// user's hand is an error saying which (stylus into the inkwell, arm to its reset position).
Result<std::unique_ptr<Device>> open_openhaptics(const std::string& library, const std::string& config,
                                                 const DeviceLimits& limits);

// Force Dimension devices (omega.3/6/7, sigma.7, delta.3/6, and the Novint Falcon, which the SDK
// drives) through the vendor's DHD library, loaded at run time with dlopen (no SDK needed to
// build). `library`: file name or path; "" = libdhd.so.3, then libdhd.so. `serial` > 0 opens the
// device with that serial number, else the `index`-th one (0 = the first). Its type, name and
// nominal limits are read as it opens; the scene's `limits` may only lower them. Forces are enabled
// only once the device is calibrated (DRD's drdAutoInit where it is not); the SDK's watchdog and
// velocity threshold stay on. A servo thread of the backend's own exchanges pose and force with the
// SDK at 1 kHz through lock-free triple buffers, so read/write never block on USB, and guards what
// it sends (finite, clamped, rate-limited, zero when stale), torque and gripper force included.
// Errors say what is missing and what to do (install the SDK, the udev rule for USB access).
Result<std::unique_ptr<Device>> open_forcedimension(const std::string& library, int index, int serial,
                                                    const DeviceLimits& limits);

// What `palpate doctor` reports about the DHD library: whether it loads (and from where), its
// version, and how many Force Dimension devices it sees (-1: could not ask). Opens no device.
struct ForceDimensionProbe {
  bool loaded = false;
  std::string library;   // the file it was loaded from, or the names tried
  std::string error;     // why it did not load, or why the count failed
  std::string version;   // the SDK's major.minor.release-revision, "" when unknown
  int devices = -1;
};
ForceDimensionProbe probe_forcedimension(const std::string& library);

// The device a scene asks for (scripted, replay, openhaptics or forcedimension).
Result<std::unique_ptr<Device>> make_device(const SceneDef& scene);
// The limits a DeviceDef sets (max force and rate, nominal stiffness and damping).
DeviceLimits device_limits(const DeviceDef& def);
// The device a DeviceDef asks for: `tool_axis` (unit) is the tool's direction at identity, which a
// scripted waypoint's `direction` turns (the needle's tool.axis, the probe's probe.axis); `where`
// (the scene file) and `key` ("device", "probe.device") name it in messages.
Result<std::unique_ptr<Device>> make_device(const DeviceDef& def, const Vec3& tool_axis,
                                            const std::string& where, const std::string& key = "device");

}  // namespace palpate
