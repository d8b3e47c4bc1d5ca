// forcedimension_device.cpp — the forcedimension backend: omega.x, sigma.7, delta.x and the Novint
// Falcon through Force Dimension's DHD library (and DRD for calibration), loaded at run time with
// dlopen; a servo thread of its own exchanges pose and force with the SDK at 1 kHz.
#include <palpate/device.h>

#include "haptics/pacing.h"
#include "haptics/triple_buffer.h"

#include <dlfcn.h>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <thread>
#include <vector>

namespace palpate {

namespace {

// The few DHD/DRD functions and constants palpate needs, declared from the public Force Dimension
// SDK reference (dhdc.h, drdc.h as documented), so that no SDK is needed to build. DHD works in SI
// units (m, m/s, N, N·m, rad). Every call takes the device ID as a `char` last argument; most
// return 0 on success, -1 on error (then dhdErrorGetLast/Str say which), and a few positive
// non-errors: DHD_TIMEGUARD (the call came sooner than the SDK's time guard: the value is the last
// one read) and DHD_MOTOR_SATURATED (the force asked for was more than a motor gives: it was scaled
// down).
constexpr int DHD_ON = 1;
constexpr int DHD_OFF = 0;
constexpr int DHD_TIMEGUARD = 1;
constexpr int DHD_MOTOR_SATURATED = 2;
constexpr int DHD_ERROR_TIMEOUT =
    7;  // also the velocity estimator's "fewer than 2 positions in its window"
// Device types (dhdGetSystemType).
constexpr int DHD_DEVICE_OMEGA3 = 33, DHD_DEVICE_OMEGA33 = 34, DHD_DEVICE_OMEGA331 = 35;
constexpr int DHD_DEVICE_OMEGA33_LEFT = 36, DHD_DEVICE_OMEGA331_LEFT = 37;
constexpr int DHD_DEVICE_FALCON = 60, DHD_DEVICE_DELTA3 = 63, DHD_DEVICE_DELTA6 = 64;
constexpr int DHD_DEVICE_SIGMA331 = 104, DHD_DEVICE_SIGMA331_LEFT = 105;
constexpr int DHD_DEVICE_SIGMA33P = 106, DHD_DEVICE_SIGMA33P_LEFT = 107;

struct DhdApi {
  void* lib = nullptr;      // the DHD library
  void* drd_lib = nullptr;  // a separate DRD library, when DRD is not in `lib`
  std::string path;         // what `lib` was loaded as
  // Required.
  int (*dhdGetDeviceCount)() = nullptr;
  int (*dhdOpenID)(char) = nullptr;
  int (*dhdOpenSerial)(int) = nullptr;
  int (*dhdClose)(char) = nullptr;
  int (*dhdStop)(char) = nullptr;
  int (*dhdEnableForce)(unsigned char, char) = nullptr;
  int (*dhdGetSystemType)(char) = nullptr;
  int (*dhdGetPosition)(double*, double*, double*, char) = nullptr;
  int (*dhdGetLinearVelocity)(double*, double*, double*, char) = nullptr;
  int (*dhdSetForce)(double, double, double, char) = nullptr;
  int (*dhdErrorGetLast)() = nullptr;
  const char* (*dhdErrorGetLastStr)() = nullptr;
  // Optional: older SDKs or devices without them.
  const char* (*dhdGetSystemName)(char) = nullptr;
  int (*dhdGetSerialNumber)(unsigned short*, char) = nullptr;
  int (*dhdGetOrientationFrame)(double[3][3], char) = nullptr;
  int (*dhdGetGripperAngleRad)(double*, char) = nullptr;
  unsigned int (*dhdGetButtonMask)(char) = nullptr;
  bool (*dhdHasWrist)(char) = nullptr;
  bool (*dhdHasActiveWrist)(char) = nullptr;
  bool (*dhdHasGripper)(char) = nullptr;
  bool (*dhdHasActiveGripper)(char) = nullptr;
  int (*dhdEmulateButton)(unsigned char, char) = nullptr;
  int (*dhdSetGravityCompensation)(int, char) = nullptr;
  int (*dhdSetForceAndTorque)(double, double, double, double, double, double, char) = nullptr;
  int (*dhdSetForceAndTorqueAndGripperForce)(double, double, double, double, double, double, double,
                                             char) = nullptr;
  double (*dhdGetMaxForce)(char) = nullptr;  // the software limit set; negative = none
  double (*dhdGetMaxTorque)(char) = nullptr;
  double (*dhdGetMaxGripperForce)(char) = nullptr;
  int (*dhdSetMaxForce)(double, char) = nullptr;
  int (*dhdSetMaxTorque)(double, char) = nullptr;
  int (*dhdSetMaxGripperForce)(double, char) = nullptr;
  // The watchdog: in units of 125 us (SDK 3.3.2 on); a device not fed a force for that long turns
  // its forces off in firmware. Devices without one return an error, which is ignored.
  int (*dhdSetWatchdog)(unsigned char, char) = nullptr;
  // Expert API: only read, never set (palpate never enables expert mode). The argument is `uint` in
  // SDK 3.7's header and `unsigned char` in older ones; both pass in one integer register.
  int (*dhdGetVelocityThreshold)(unsigned int*, char) = nullptr;
  void (*dhdGetSDKVersion)(int*, int*, int*, int*) = nullptr;
  // DRD (the robotic SDK: calibration). drdStop's first argument leaves forces on when true. The
  // order drdOpenID(id) on the ID dhdOpen* returned is CHAI3D's Linux backend's; the SDK's manual
  // documents drdOpenID's argument as the device's index: the same for a single device.
  int (*drdOpenID)(char) = nullptr;
  bool (*drdIsInitialized)(char) = nullptr;
  int (*drdAutoInit)(char) = nullptr;
  int (*drdStop)(bool, char) = nullptr;
  int (*drdClose)(char) = nullptr;

  void close() {
    if (drd_lib) ::dlclose(drd_lib);
    if (lib) ::dlclose(lib);
    lib = drd_lib = nullptr;
  }
  std::string last_error() const {
    const char* s = dhdErrorGetLastStr ? dhdErrorGetLastStr() : nullptr;
    return s && *s ? s : "no error text";
  }
};

template <class F>
bool bind(void* lib, F& fn, const char* name) {
  if (!lib) return false;
  fn = reinterpret_cast<F>(::dlsym(lib, name));
  return fn != nullptr;
}

constexpr const char* kScriptedHint =
    "; to run without a device, use the scripted device (scene: `device: {kind: scripted}`)";
// What to do when the SDK sees no device or cannot open it: USB access on Linux.
constexpr const char* kUsbHint =
    "check that the device is powered and its USB cable plugged in; on Linux your user needs "
    "access "
    "to its USB device: install the udev rule in docs/haptics.md (\"Force Dimension devices\") and "
    "plug "
    "it in again, or run as root";

// A device family's nominal figures (N, N·m, N, N/m, N·s/m, m), from Force Dimension's and Novint's
// specification sheets where they give them (continuous force; the workspace's diameter x height),
// and the nominal stiffness and damping CHAI3D's device table gives for each (the vendor does not
// publish them). The scene's limits may only lower them.
struct Family {
  const char* model;
  double force, torque, gripper_force, stiffness, damping;
  double workspace_diameter, workspace_height;
};
Family family_of(int type) {
  switch (type) {
    case DHD_DEVICE_OMEGA3:
      return {"omega.3", 12.0, 0.0, 0.0, 5000.0, 30.0, 0.160, 0.110};
    case DHD_DEVICE_OMEGA33:
    case DHD_DEVICE_OMEGA33_LEFT:
      return {"omega.6", 12.0, 0.0, 0.0, 5000.0, 30.0, 0.160, 0.110};
    case DHD_DEVICE_OMEGA331:
    case DHD_DEVICE_OMEGA331_LEFT:
      return {"omega.7", 12.0, 0.0, 8.0, 5000.0, 30.0, 0.160, 0.110};
    case DHD_DEVICE_SIGMA331:
    case DHD_DEVICE_SIGMA331_LEFT:
      return {"sigma.7", 12.0, 0.2, 8.0, 4000.0, 30.0, 0.190, 0.130};
    case DHD_DEVICE_SIGMA33P:
    case DHD_DEVICE_SIGMA33P_LEFT:
      return {"sigma.6+", 12.0, 0.2, 0.0, 4000.0, 30.0, 0.190, 0.130};
    case DHD_DEVICE_DELTA3:
      return {"delta.3", 20.0, 0.0, 0.0, 5000.0, 30.0, 0.400, 0.260};
    case DHD_DEVICE_DELTA6:
      return {"delta.6", 20.0, 0.15, 0.0, 5000.0, 30.0, 0.400, 0.260};
    case DHD_DEVICE_FALCON:
      return {"Novint Falcon", 8.0, 0.0, 0.0, 3000.0, 20.0, 0.1016, 0.1016};
    // A type palpate does not know (a custom device, a newer model): the smallest family's.
    default:
      return {nullptr, 8.0, 0.0, 0.0, 3000.0, 20.0, 0.1016, 0.1016};
  }
}

// What the haptic thread asks the servo to send, with when: the servo zeroes a stale command.
struct Command {
  Vec3 force = Vec3::Zero();   // N
  Vec3 torque = Vec3::Zero();  // N·m
  double gripper = 0;          // N
  std::int64_t written_ns = 0;
};

constexpr double kServoFrame = 1e-3;                // s: the servo's period (1 kHz)
constexpr std::int64_t kStalePose = 20'000'000;     // ns: a pose older is not the device's
constexpr std::int64_t kStaleCommand = 50'000'000;  // ns: a command older means our loop died
// The watchdog's period: the longest the SDK takes (255 x 125 us = 31.9 ms). A servo that did not
// send for longer (it was blocked in the SDK, descheduled) finds the device's forces turned off by
// its firmware: the device has failed for the rest of the run, since turning forces back on is the
// user's to do (the force button), not a backend's.
constexpr unsigned char kWatchdogUnits = 255;
constexpr std::int64_t kWatchdogNs = std::int64_t(kWatchdogUnits) * 125'000;

// A limit from the SDK's software limit (negative or 0 = none set): the lower of it and `nominal`.
double lower_by_sdk(double nominal, double sdk) {
  return sdk > 0 && std::isfinite(sdk) ? std::min(nominal, sdk) : nominal;
}

class ForceDimensionDevice final : public Device {
 public:
  ForceDimensionDevice(DhdApi api, char id, DeviceLimits limits)
      : api_(std::move(api)), id_(id), limits_(limits) {
    pose_.fill(DeviceState{});
    cmd_.fill(Command{});
  }
  ~ForceDimensionDevice() override {
    if (thread_.joinable()) {
      // Ramp what the hand feels down to zero within the rate limit before the servo stops.
      zeroing_.store(true);
      const double ramp =
          std::min(1.0, servo_max_force_ / std::max(1e-9, servo_max_step_) * kServoFrame);
      const std::int64_t until = monotonic_ns() + static_cast<std::int64_t>((ramp + 0.05) * 1e9);
      while (!zeroed_.load() && monotonic_ns() < until) sleep_until_ns(monotonic_ns() + 500'000, 0);
      stopping_.store(true);
      thread_.join();
    }
    if (forces_enabled_) api_.dhdEnableForce(DHD_OFF, id_);
    api_.dhdStop(id_);
    if (drd_opened_ && api_.drdClose) api_.drdClose(id_);
    api_.dhdClose(id_);
    api_.close();
  }
  ForceDimensionDevice(const ForceDimensionDevice&) = delete;
  ForceDimensionDevice& operator=(const ForceDimensionDevice&) = delete;

  // Reads the device's type and limits, checks its calibration (initialising it where DRD can),
  // keeps the SDK's safety features on, enables forces, and starts the servo.
  Status start(const std::string& which) {
    type_ = api_.dhdGetSystemType(id_);
    const Family fam = family_of(type_);
    const char* sdk_name = api_.dhdGetSystemName ? api_.dhdGetSystemName(id_) : nullptr;
    name_ = sdk_name && *sdk_name ? sdk_name
            : fam.model           ? fam.model
                                  : "device of type " + std::to_string(type_);
    unsigned short serial = 0;
    if (api_.dhdGetSerialNumber && api_.dhdGetSerialNumber(&serial, id_) >= 0) serial_ = serial;
    has_wrist_ = api_.dhdHasWrist && api_.dhdHasWrist(id_);
    has_gripper_ = api_.dhdHasGripper && api_.dhdHasGripper(id_);
    const bool active_wrist = api_.dhdHasActiveWrist && api_.dhdHasActiveWrist(id_);
    const bool active_gripper = api_.dhdHasActiveGripper && api_.dhdHasActiveGripper(id_);

    // Limits: the family's nominal ones, lowered by a software limit the SDK already holds, lowered
    // by the scene's; then handed to the SDK too (dhdSetMax*), which scales down anything above.
    limits_.max_force =
        std::min(limits_.max_force,
                 lower_by_sdk(fam.force, api_.dhdGetMaxForce ? api_.dhdGetMaxForce(id_) : -1));
    limits_.stiffness = std::min(limits_.stiffness, fam.stiffness);
    limits_.damping = std::min(limits_.damping, fam.damping);
    const double r = 0.5 * fam.workspace_diameter, h = 0.5 * fam.workspace_height;
    limits_.workspace_min = Vec3(-r, -r, -h);  // the SDK's frame: x towards the user, z up
    limits_.workspace_max = Vec3(r, r, h);
    limits_.has_torque = active_wrist && fam.torque > 0 &&
                         (api_.dhdSetForceAndTorque || api_.dhdSetForceAndTorqueAndGripperForce);
    limits_.max_torque =
        limits_.has_torque
            ? lower_by_sdk(fam.torque, api_.dhdGetMaxTorque ? api_.dhdGetMaxTorque(id_) : -1)
            : 0.0;
    limits_.max_gripper_force =
        active_gripper && fam.gripper_force > 0 && api_.dhdSetForceAndTorqueAndGripperForce
            ? lower_by_sdk(fam.gripper_force,
                           api_.dhdGetMaxGripperForce ? api_.dhdGetMaxGripperForce(id_) : -1)
            : 0.0;
    if (!std::isfinite(limits_.max_force) || limits_.max_force < 0) limits_.max_force = 0;
    if (api_.dhdSetMaxForce) api_.dhdSetMaxForce(limits_.max_force, id_);
    if (api_.dhdSetMaxTorque && limits_.has_torque) api_.dhdSetMaxTorque(limits_.max_torque, id_);
    if (api_.dhdSetMaxGripperForce && limits_.max_gripper_force > 0)
      api_.dhdSetMaxGripperForce(limits_.max_gripper_force, id_);
    const double rate =
        std::isfinite(limits_.max_force_rate) ? std::max(0.0, limits_.max_force_rate) : 0.0;
    servo_max_force_ = limits_.max_force;
    servo_max_step_ = rate * kServoFrame;
    // Torque and gripper force change as fast, relative to their maxima, as the force may.
    const double fraction = limits_.max_force > 0 ? servo_max_step_ / limits_.max_force : 0.0;
    servo_max_torque_step_ = limits_.max_torque * fraction;
    servo_max_gripper_step_ = limits_.max_gripper_force * fraction;

    // The SDK's safety cut-offs stay on. The velocity threshold (forces off when the arm moves
    // faster than it) is never set: CHAI3D's Linux backend sets it to 0, off; a device found with
    // it off is refused rather than run. The watchdog (forces off in firmware when no force
    // arrives) is set to 31.9 ms where the device has one: it is what cuts the force if this
    // process dies.
    if (api_.dhdGetVelocityThreshold) {
      unsigned int thr = 1;
      if (api_.dhdGetVelocityThreshold(&thr, id_) >= 0 && thr == 0)
        return Error{
            "forcedimension: the " + name_ + " (" + which +
            ") has its velocity threshold off (0): another program turned the SDK's safety cut-off "
            "off; power the device off and on again (palpate keeps it on)"};
    }
    if (api_.dhdSetWatchdog)
      api_.dhdSetWatchdog(kWatchdogUnits, id_);  // an error: a device without one
    if (api_.dhdSetGravityCompensation) api_.dhdSetGravityCompensation(DHD_ON, id_);
    if (has_gripper_ && api_.dhdEmulateButton)
      api_.dhdEmulateButton(DHD_ON, id_);  // a closed gripper = button 1

    // Calibration, before any force: DRD says whether the device is initialised, and initialises
    // (calibrates) it where it is not — the arm moves by itself to its calibration position.
    if (!api_.drdIsInitialized || !api_.drdAutoInit || !api_.drdOpenID)
      return Error{
          "forcedimension: the DRD functions (drdIsInitialized, drdAutoInit) are in neither '" +
          api_.path + "' nor libdrd.so: palpate needs them to check that the " + name_ +
          " is calibrated before it enables forces; install the whole Force Dimension SDK (its "
          "lib/ "
          "holds libdrd.so), or set device.dhd_library to libdrd.so, which holds the DHD functions "
          "too" +
          kScriptedHint};
    if (api_.drdOpenID(id_) < 0)
      return Error{"forcedimension: DRD cannot open the " + name_ + " (" + api_.last_error() + ")" +
                   kScriptedHint};
    drd_opened_ = true;
    if (api_.drdIsInitialized(id_)) {
      calibration_ = Calibration::ok;
    } else {
      if (api_.drdAutoInit(id_) < 0 || !api_.drdIsInitialized(id_))
        return Error{
            "forcedimension: the " + name_ + " (" + which +
            ") is not calibrated and drdAutoInit could not "
            "calibrate it (" +
            api_.last_error() +
            "): clear the space around its arm so that it can move "
            "to its calibration position, and start again; forces stay off on a device that is not "
            "calibrated"};
      calibration_ = Calibration::updated;
    }
    if (api_.drdStop)
      api_.drdStop(true, id_);  // DRD's regulation thread off, the device left to us

    // A first pose before forces: the device answers.
    double x = 0, y = 0, z = 0;
    if (api_.dhdGetPosition(&x, &y, &z, id_) < 0)
      return Error{"forcedimension: the " + name_ + " (" + which + ") gives no position (" +
                   api_.last_error() + "); " + kUsbHint};
    if (api_.dhdEnableForce(DHD_ON, id_) < 0)
      return Error{"forcedimension: the " + name_ + " (" + which + ") refuses to enable forces (" +
                   api_.last_error() + "); check its force button or switch, then start again"};
    forces_enabled_ = true;
    thread_ = std::thread([this] { servo_main(); });
    // The servo's first frame, so that the first read() is the device's pose (at most 1 s).
    for (const std::int64_t until = monotonic_ns() + 1'000'000'000;
         frame_ns_.load() == 0 && !failed_.load() && monotonic_ns() < until;)
      sleep_until_ns(monotonic_ns() + 200'000, 0);
    if (frame_ns_.load() == 0)
      return Error{"forcedimension: the " + name_ + " (" + which +
                   ") gave no pose in its first second (" + api_.last_error() + "); " + kUsbHint};
    return {};
  }

  const DeviceLimits& limits() const override { return limits_; }
  Calibration calibration() const noexcept override { return calibration_; }

  bool read(double t, DeviceState& out) noexcept override {
    pose_.update();
    out = pose_.read();
    out.time = t;
    // A pose the servo has not refreshed for kStalePose (the SDK blocked, the device stopped
    // answering): not a pose. An error from the SDK (unplugged, a USB fault) fails as well.
    const std::int64_t frame = frame_ns_.load(std::memory_order_relaxed);
    if (frame == 0 || monotonic_ns() - frame > kStalePose) return false;
    return !failed_.load(std::memory_order_relaxed);
  }

  void write(const Vec3& force, const Vec3& torque) noexcept override {
    mine_.force = force;
    mine_.torque = torque;
    publish();
  }
  void write_gripper(double force) noexcept override {
    mine_.gripper = force;
    publish();
  }

 private:
  void publish() noexcept {
    Command& c = cmd_.write_slot();
    c = mine_;
    c.written_ns = monotonic_ns();
    cmd_.publish();
  }

  void servo_main() noexcept {
    try_realtime_priority(80);  // best effort: refused without the permission, as the haptic loop's
    std::int64_t next = monotonic_ns();
    while (!stopping_.load(std::memory_order_relaxed)) {
      frame();
      next += static_cast<std::int64_t>(kServoFrame * 1e9);
      const std::int64_t now = monotonic_ns();
      if (next < now - 5'000'000) next = now;  // a long stall: no burst of frames to catch up
      sleep_until_ns(next, 0);
    }
    // The last word is zero (ramped by the destructor; this only confirms it).
    send(Vec3::Zero(), Vec3::Zero(), 0.0);
  }

  // One servo frame: read the pose, guard the command, send it.
  void frame() noexcept {
    const DhdApi& d = api_;
    double p[3] = {0, 0, 0};
    // DHD_TIMEGUARD (1) is a non-error: the SDK gave the last value it read.
    if (d.dhdGetPosition(&p[0], &p[1], &p[2], id_) < 0) {
      failed_.store(true, std::memory_order_relaxed);
      return;
    }
    double v[3] = {0, 0, 0};
    // The velocity estimate is the SDK's (a window of positions, 20 ms by default); an error there
    // (fewer than two positions in the window, at the start) keeps the last one, and is no fault.
    const bool have_velocity = d.dhdGetLinearVelocity(&v[0], &v[1], &v[2], id_) >= 0;
    double m[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    if (has_wrist_ && d.dhdGetOrientationFrame && d.dhdGetOrientationFrame(m, id_) < 0) {
      failed_.store(true, std::memory_order_relaxed);
      return;
    }
    const unsigned int buttons = d.dhdGetButtonMask ? d.dhdGetButtonMask(id_) : 0u;
    double grip = 0;
    if (has_gripper_ && d.dhdGetGripperAngleRad) d.dhdGetGripperAngleRad(&grip, id_);

    cmd_.update();
    const Command& c = cmd_.read();
    const bool stop =
        zeroing_.load(std::memory_order_relaxed) ||
        monotonic_ns() - c.written_ns > kStaleCommand;  // our loop died: to zero, ramped
    const Vec3 f =
        guard(stop ? Vec3::Zero() : c.force, sent_force_, servo_max_force_, servo_max_step_);
    const Vec3 tq = guard(stop ? Vec3::Zero() : c.torque, sent_torque_, limits_.max_torque,
                          servo_max_torque_step_);
    const double g = guard(Vec3(stop ? 0.0 : c.gripper, 0, 0), Vec3(sent_gripper_, 0, 0),
                           limits_.max_gripper_force, servo_max_gripper_step_)
                         .x();
    const std::int64_t now = monotonic_ns();
    if (last_send_ns_ > 0 && now - last_send_ns_ > kWatchdogNs)
      failed_.store(true, std::memory_order_relaxed);
    last_send_ns_ = now;
    const int rc = send(f, tq, g);
    if (rc < 0) {
      failed_.store(true, std::memory_order_relaxed);
      return;
    }
    if (rc == DHD_MOTOR_SATURATED)
      saturated_.fetch_add(1, std::memory_order_relaxed);  // scaled down: no fault
    sent_force_ = f, sent_torque_ = tq, sent_gripper_ = g;
    if (zeroing_.load(std::memory_order_relaxed) && f.isZero() && tq.isZero() && g == 0)
      zeroed_.store(true);

    DeviceState& s = pose_.write_slot();
    s.position = Vec3(p[0], p[1], p[2]);
    if (have_velocity) velocity_ = Vec3(v[0], v[1], v[2]);
    s.velocity = velocity_;
    Eigen::Matrix3d r;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) r(i, j) = m[i][j];  // row i, column j, as C stores it
    s.orientation = Quat(r).normalized();
    s.buttons = buttons;
    s.gripper_angle = grip;
    pose_.publish();
    frame_ns_.store(monotonic_ns(), std::memory_order_relaxed);
  }

  // The backend's own guard, whatever the caller wrote: zero when not finite, clamped to `max`,
  // changed from `last` by at most `step` per frame; never above `max` nor non-finite.
  static Vec3 guard(Vec3 want, const Vec3& last, double max, double step) noexcept {
    if (!want.allFinite()) want.setZero();
    if (const double n = want.norm(); n > max) want *= max / n;
    const Vec3 change = want - last;
    if (const double c = change.norm(); c > step) want = last + change * (step / c);
    if (!want.allFinite()) want.setZero();
    if (const double n = want.norm(); n > max) want *= max / n;
    return want;
  }

  int send(const Vec3& f, const Vec3& t, double g) noexcept {
    const DhdApi& d = api_;
    if (d.dhdSetForceAndTorqueAndGripperForce)
      return d.dhdSetForceAndTorqueAndGripperForce(f.x(), f.y(), f.z(), t.x(), t.y(), t.z(), g,
                                                   id_);
    if (d.dhdSetForceAndTorque)
      return d.dhdSetForceAndTorque(f.x(), f.y(), f.z(), t.x(), t.y(), t.z(), id_);
    return d.dhdSetForce(f.x(), f.y(), f.z(), id_);
  }

  DhdApi api_;
  char id_;
  DeviceLimits limits_;
  int type_ = 0;
  int serial_ = 0;
  std::string name_;
  bool has_wrist_ = false, has_gripper_ = false;
  bool drd_opened_ = false, forces_enabled_ = false;
  Calibration calibration_ = Calibration::unknown;
  // Set in start() before the servo thread exists; read-only after.
  double servo_max_force_ = 0, servo_max_step_ = 0, servo_max_torque_step_ = 0,
         servo_max_gripper_step_ = 0;
  // Servo thread only.
  Vec3 sent_force_ = Vec3::Zero(), sent_torque_ = Vec3::Zero();
  double sent_gripper_ = 0;
  std::int64_t last_send_ns_ = 0;
  Vec3 velocity_ = Vec3::Zero();  // the SDK's last estimate
  // Haptic thread only: the command being built (write and write_gripper each set their part).
  Command mine_;
  TripleBuffer<DeviceState> pose_;  // servo → haptic thread
  TripleBuffer<Command> cmd_;       // haptic thread → servo
  std::atomic<bool> failed_{false}, stopping_{false}, zeroing_{false}, zeroed_{false};
  std::atomic<std::int64_t> frame_ns_{
      0};  // monotonic ns of the servo's last complete frame (0: none yet)
  std::atomic<std::uint64_t> saturated_{0};
  std::thread thread_;
};

// Load the DHD library: `library`, or libdhd.so.3 then libdhd.so. On failure, `why` says what each
// name gave.
bool load(const std::string& library, DhdApi& api, std::string& why) {
  const std::vector<std::string> names = library.empty()
                                             ? std::vector<std::string>{"libdhd.so.3", "libdhd.so"}
                                             : std::vector<std::string>{library};
  for (const std::string& n : names) {
    api.lib = ::dlopen(n.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (api.lib) {
      api.path = n;
      return true;
    }
    const char* e = ::dlerror();
    why += (why.empty() ? "" : "; ") + n + ": " + (e ? e : "?");
  }
  return false;
}

std::string cannot_load(const std::string& library, const std::string& why) {
  return "forcedimension: cannot load the DHD library " +
         (library.empty() ? std::string("(libdhd.so.3, libdhd.so)") : "'" + library + "'") + " (" +
         why +
         "): install the Force Dimension SDK (its lib/ folder on LD_LIBRARY_PATH, or copied to "
         "/usr/local/lib "
         "followed by `sudo ldconfig`), or set device.dhd_library to the path of libdhd.so";
}

}  // namespace

Result<std::unique_ptr<Device>> open_forcedimension(const std::string& library, int index,
                                                    int serial, const DeviceLimits& limits) {
  DhdApi api;
  std::string why;
  if (!load(library, api, why)) return Error{cannot_load(library, why) + kScriptedHint};
  const char* missing = nullptr;
#define PALPATE_BIND(name) \
  if (!missing && !bind(api.lib, api.name, #name)) missing = #name
  PALPATE_BIND(dhdGetDeviceCount);
  PALPATE_BIND(dhdOpenID);
  PALPATE_BIND(dhdOpenSerial);
  PALPATE_BIND(dhdClose);
  PALPATE_BIND(dhdStop);
  PALPATE_BIND(dhdEnableForce);
  PALPATE_BIND(dhdGetSystemType);
  PALPATE_BIND(dhdGetPosition);
  PALPATE_BIND(dhdGetLinearVelocity);
  PALPATE_BIND(dhdSetForce);
  PALPATE_BIND(dhdErrorGetLast);
  PALPATE_BIND(dhdErrorGetLastStr);
#undef PALPATE_BIND
  if (missing) {
    api.close();
    return Error{"forcedimension: '" + api.path + "' has no function " + missing +
                 ": it is not Force Dimension's DHD library" + kScriptedHint};
  }
  bind(api.lib, api.dhdGetSystemName, "dhdGetSystemName");
  bind(api.lib, api.dhdGetSerialNumber, "dhdGetSerialNumber");
  bind(api.lib, api.dhdGetOrientationFrame, "dhdGetOrientationFrame");
  bind(api.lib, api.dhdGetGripperAngleRad, "dhdGetGripperAngleRad");
  bind(api.lib, api.dhdGetButtonMask, "dhdGetButtonMask");
  bind(api.lib, api.dhdHasWrist, "dhdHasWrist");
  bind(api.lib, api.dhdHasActiveWrist, "dhdHasActiveWrist");
  bind(api.lib, api.dhdHasGripper, "dhdHasGripper");
  bind(api.lib, api.dhdHasActiveGripper, "dhdHasActiveGripper");
  bind(api.lib, api.dhdEmulateButton, "dhdEmulateButton");
  bind(api.lib, api.dhdSetGravityCompensation, "dhdSetGravityCompensation");
  bind(api.lib, api.dhdSetForceAndTorque, "dhdSetForceAndTorque");
  bind(api.lib, api.dhdSetForceAndTorqueAndGripperForce, "dhdSetForceAndTorqueAndGripperForce");
  bind(api.lib, api.dhdGetMaxForce, "dhdGetMaxForce");
  bind(api.lib, api.dhdGetMaxTorque, "dhdGetMaxTorque");
  bind(api.lib, api.dhdGetMaxGripperForce, "dhdGetMaxGripperForce");
  bind(api.lib, api.dhdSetMaxForce, "dhdSetMaxForce");
  bind(api.lib, api.dhdSetMaxTorque, "dhdSetMaxTorque");
  bind(api.lib, api.dhdSetMaxGripperForce, "dhdSetMaxGripperForce");
  bind(api.lib, api.dhdSetWatchdog, "dhdSetWatchdog");
  bind(api.lib, api.dhdGetVelocityThreshold, "dhdGetVelocityThreshold");
  // DRD: in the same library (libdrd.so holds DHD's functions too), else libdrd.so beside it.
  void* drd = api.lib;
  if (!::dlsym(drd, "drdAutoInit")) {
    drd = nullptr;
    for (const char* n : {"libdrd.so.3", "libdrd.so"})
      if ((drd = ::dlopen(n, RTLD_NOW | RTLD_LOCAL))) break;
    api.drd_lib = drd;
  }
  bind(drd, api.drdOpenID, "drdOpenID");
  bind(drd, api.drdIsInitialized, "drdIsInitialized");
  bind(drd, api.drdAutoInit, "drdAutoInit");
  bind(drd, api.drdStop, "drdStop");
  bind(drd, api.drdClose, "drdClose");

  const int count = api.dhdGetDeviceCount();
  if (count <= 0) {
    const std::string e = api.last_error();
    api.close();
    return Error{"forcedimension: no Force Dimension device found (DHD: " + e + "): " + kUsbHint +
                 kScriptedHint};
  }
  std::string which;
  int id = -1;
  if (serial > 0) {
    which = "serial " + std::to_string(serial);
    id = api.dhdOpenSerial(serial);
  } else {
    which = "index " + std::to_string(index);
    if (index < 0 || index >= count) {
      api.close();
      return Error{"forcedimension: device.dhd_index " + std::to_string(index) +
                   " asked for, but " + std::to_string(count) +
                   (count == 1 ? " device is" : " devices are") + " connected (index 0" +
                   (count > 1 ? " to " + std::to_string(count - 1) : std::string()) + ")" +
                   kScriptedHint};
    }
    id = api.dhdOpenID(static_cast<char>(index));
  }
  if (id < 0) {
    const std::string e = api.last_error();
    api.close();
    return Error{
        "forcedimension: cannot open the device with " + which + " (DHD: " + e + "; " +
        std::to_string(count) + (count == 1 ? " device" : " devices") + " connected): " +
        (serial > 0 ? "check the serial number on the device's label, and " : std::string()) +
        kUsbHint + kScriptedHint};
  }
  auto dev = std::make_unique<ForceDimensionDevice>(std::move(api), static_cast<char>(id), limits);
  if (Status s = dev->start(which); !s) return s.error();
  return std::unique_ptr<Device>(std::move(dev));
}

ForceDimensionProbe probe_forcedimension(const std::string& library) {
  ForceDimensionProbe p;
  DhdApi api;
  std::string why;
  if (!load(library, api, why)) {
    p.library = library.empty() ? "libdhd.so.3, libdhd.so" : library;
    p.error = cannot_load(library, why);
    return p;
  }
  p.loaded = true;
  p.library = api.path;
  if (bind(api.lib, api.dhdGetSDKVersion, "dhdGetSDKVersion")) {
    int a = 0, b = 0, c = 0, d = 0;
    api.dhdGetSDKVersion(&a, &b, &c, &d);
    p.version = std::to_string(a) + "." + std::to_string(b) + "." + std::to_string(c) + "-" +
                std::to_string(d);
  }
  bind(api.lib, api.dhdErrorGetLastStr, "dhdErrorGetLastStr");
  if (bind(api.lib, api.dhdGetDeviceCount, "dhdGetDeviceCount")) {
    p.devices = api.dhdGetDeviceCount();
    if (p.devices < 0) p.error = "dhdGetDeviceCount failed (DHD: " + api.last_error() + ")";
  } else {
    p.error = "'" + api.path +
              "' has no function dhdGetDeviceCount: it is not Force Dimension's DHD library";
  }
  api.close();
  return p;
}

}  // namespace palpate
