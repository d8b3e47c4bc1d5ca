// openhaptics_device.cpp — the openhaptics backend: Phantom Omni / Geomagic Touch through the
// vendor's HD API, loaded at run time with dlopen; its servo callback runs in the HD scheduler.
#include <palpate/device.h>

#include "haptics/pacing.h"
#include "haptics/triple_buffer.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <dlfcn.h>

namespace palpate {

namespace {

// The few HD API types and constants palpate needs, declared from the public OpenHaptics HD API
// reference (hdDefines.h), so that no SDK is needed to build. HD works in millimetres.
using HHD = unsigned int;
using HDenum = unsigned int;
using HDint = int;
using HDdouble = double;
using HDushort = unsigned short;
using HDerror = unsigned int;
using HDCallbackCode = unsigned int;
using HDSchedulerHandle = unsigned long;
using HDSchedulerCallback = HDCallbackCode (*)(void*);
struct HDErrorInfo {
  HDerror errorCode;
  int internalErrorCode;
  HHD hHD;
};
constexpr HHD HD_INVALID_HANDLE = 0xFFFFFFFF;
constexpr HDerror HD_SUCCESS = 0x0000;
constexpr HDCallbackCode HD_CALLBACK_DONE = 0;
constexpr HDCallbackCode HD_CALLBACK_CONTINUE = 1;
constexpr HDushort HD_DEFAULT_SCHEDULER_PRIORITY = 0x7fff;  // (HD_MAX 0xffff + HD_MIN 0) / 2
constexpr HDenum HD_CURRENT_BUTTONS = 0x2000;
constexpr HDenum HD_CURRENT_POSITION = 0x2050;   // mm
constexpr HDenum HD_CURRENT_VELOCITY = 0x2051;   // mm/s
constexpr HDenum HD_CURRENT_TRANSFORM = 0x2052;  // 4x4 column-major, translation in mm
constexpr HDenum HD_NOMINAL_MAX_STIFFNESS = 0x2602;  // N/mm
constexpr HDenum HD_NOMINAL_MAX_FORCE = 0x2603;      // N
constexpr HDenum HD_NOMINAL_MAX_DAMPING = 0x2609;    // N·s/mm
constexpr HDenum HD_CURRENT_FORCE = 0x2700;          // N
constexpr HDenum HD_FORCE_OUTPUT = 0x4000;
constexpr HDenum HD_CALIBRATION_STYLE = 0x2650;      // the styles a device supports (bit mask)
constexpr HDenum HD_CALIBRATION_OK = 0x5000;
constexpr HDenum HD_CALIBRATION_NEEDS_UPDATE = 0x5001;
constexpr HDenum HD_CALIBRATION_NEEDS_MANUAL_INPUT = 0x5002;
constexpr HDint HD_CALIBRATION_ENCODER_RESET = 1 << 0;  // the arm held in its reset position
constexpr HDint HD_CALIBRATION_AUTO = 1 << 1;           // by moving the arm about (Phantom Premium)
constexpr HDint HD_CALIBRATION_INKWELL = 1 << 2;        // the stylus in its inkwell (Omni, Touch)

struct HdApi {
  void* lib = nullptr;
  HHD (*hdInitDevice)(const char*) = nullptr;
  void (*hdDisableDevice)(HHD) = nullptr;
  void (*hdEnable)(HDenum) = nullptr;
  void (*hdStartScheduler)() = nullptr;
  void (*hdStopScheduler)() = nullptr;
  HDSchedulerHandle (*hdScheduleAsynchronous)(HDSchedulerCallback, void*, HDushort) = nullptr;
  void (*hdScheduleSynchronous)(HDSchedulerCallback, void*, HDushort) = nullptr;
  void (*hdUnschedule)(HDSchedulerHandle) = nullptr;
  void (*hdBeginFrame)(HHD) = nullptr;
  void (*hdEndFrame)(HHD) = nullptr;
  void (*hdGetDoublev)(HDenum, HDdouble*) = nullptr;
  void (*hdGetIntegerv)(HDenum, HDint*) = nullptr;
  void (*hdSetDoublev)(HDenum, const HDdouble*) = nullptr;
  HDErrorInfo (*hdGetError)() = nullptr;
  // Optional: a library without them gives Calibration::unknown.
  HDenum (*hdCheckCalibration)() = nullptr;
  void (*hdUpdateCalibration)(HDenum) = nullptr;
};

template <class F>
bool bind(void* lib, F& fn, const char* name) {
  fn = reinterpret_cast<F>(::dlsym(lib, name));
  return fn != nullptr;
}

std::string hex(unsigned v) {
  char b[16];
  std::snprintf(b, sizeof b, "0x%04x", v);
  return b;
}

constexpr const char* kScriptedHint =
    "; to run without a device, use the scripted device (scene: `device: {kind: scripted}`)";

// The force the haptic thread last wrote, with when: the servo callback zeroes a stale force.
struct TimedForce {
  Vec3 force = Vec3::Zero();
  std::int64_t written_ns = 0;
};

// The nominal maximum force of the smallest device of the family the HD API drives, used when a
// device reports none (0): the Phantom Omni / Geomagic Touch, "maximum exertable force at nominal
// (orthogonal arms) position 3.3 N" (3D Systems, Touch haptic device specifications; the Touch X
// and Phantom Premium models take more, so 3.3 N is within every one of them).
constexpr double kFamilyMaxForce = 3.3;  // N
// The HD scheduler's servo rate when the application does not set one (hdSetSchedulerRate; palpate
// never does): 1000 Hz, so one servo frame is 1 ms.
constexpr double kServoFrame = 1e-3;  // s
// A pose older than this is not the device's: its servo has stopped (the library blocked inside a
// call, the device stopped answering). read() fails then, a `device_failed` fault: the loop's force
// heads to zero on that tick. 20 servo frames: far above a loaded machine's scheduling jitter.
constexpr std::int64_t kStalePose = 20'000'000;  // ns

class OpenHapticsDevice final : public Device {
 public:
  OpenHapticsDevice(HdApi api, HHD hhd, DeviceLimits limits) : api_(api), hhd_(hhd), limits_(limits) {
    pose_.fill(DeviceState{});
    force_.fill(TimedForce{});
    publish_servo_limits();
  }
  ~OpenHapticsDevice() override {
    // Ramp the force the hand feels down to zero within the rate limit before the servo stops:
    // the servo heads for zero from now on; wait (bounded) until it has sent zero.
    zeroing_.store(true);
    const double ramp = std::min(1.0, servo_max_force_.load() / std::max(1e-9, servo_max_step_.load()) * kServoFrame);
    const std::int64_t until = monotonic_ns() + static_cast<std::int64_t>((ramp + 0.05) * 1e9);
    while (running_.load() && !zeroed_.load() && monotonic_ns() < until) sleep_until_ns(monotonic_ns() + 500'000, 0);
    stopping_.store(true);
    api_.hdStopScheduler();
    if (handle_) api_.hdUnschedule(handle_);
    api_.hdDisableDevice(hhd_);
    ::dlclose(api_.lib);
  }
  OpenHapticsDevice(const OpenHapticsDevice&) = delete;
  OpenHapticsDevice& operator=(const OpenHapticsDevice&) = delete;

  Status start() {
    frame_ns_.store(monotonic_ns(), std::memory_order_relaxed);  // the first frame's grace
    api_.hdEnable(HD_FORCE_OUTPUT);
    handle_ = api_.hdScheduleAsynchronous(&OpenHapticsDevice::servo, this, HD_DEFAULT_SCHEDULER_PRIORITY);
    api_.hdStartScheduler();
    HDErrorInfo e = api_.hdGetError();
    if (e.errorCode != HD_SUCCESS)
      return Error{"openhaptics: the HD scheduler did not start (HD error " + hex(e.errorCode) + ")" +
                   kScriptedHint};
    // The device's own nominal limits, read once in the scheduler; the scene may only lower them.
    api_.hdScheduleSynchronous(&OpenHapticsDevice::query_limits, this, HD_DEFAULT_SCHEDULER_PRIORITY);
    publish_servo_limits();
    // Its calibration, in the scheduler as the vendor's examples do: an update it can make alone
    // (hdUpdateCalibration) is made; one that needs the user's hand stops the open, saying which.
    if (api_.hdCheckCalibration) {
      api_.hdScheduleSynchronous(&OpenHapticsDevice::check_calibration, this, HD_DEFAULT_SCHEDULER_PRIORITY);
      if (calibration_status_ != HD_CALIBRATION_OK) {
        const bool inkwell = (calibration_styles_ & HD_CALIBRATION_INKWELL) != 0;
        const bool reset = (calibration_styles_ & HD_CALIBRATION_ENCODER_RESET) != 0;
        const std::string how =
            inkwell ? "put the stylus in its inkwell"
            : reset ? "hold the arm in its reset position (see the device's manual)"
                    : "calibrate it with the vendor's Touch Setup or Touch Diagnostic";
        return Error{"openhaptics: the device is not calibrated (" +
                     std::string(calibration_status_ == HD_CALIBRATION_NEEDS_MANUAL_INPUT
                                     ? "it needs your hand"
                                     : "HD status " + hex(calibration_status_)) +
                     "): " + how + ", then start again; a device out of calibration puts the tool off "
                     "where the hand is"};
      }
    }
    return {};
  }

  const DeviceLimits& limits() const override { return limits_; }
  Calibration calibration() const noexcept override {
    if (!api_.hdCheckCalibration) return Calibration::unknown;
    return calibration_updated_ ? Calibration::updated : Calibration::ok;
  }

  bool read(double t, DeviceState& out) noexcept override {
    pose_.update();
    out = pose_.read();
    out.time = t;
    // A pose the servo has not refreshed for kStalePose (it stopped answering): not a pose.
    if (monotonic_ns() - frame_ns_.load(std::memory_order_relaxed) > kStalePose) return false;
    return !failed_.load(std::memory_order_relaxed);
  }

  void write(const Vec3& force, const Vec3&) noexcept override {
    TimedForce& f = force_.write_slot();
    f.force = force;
    f.written_ns = monotonic_ns();
    force_.publish();
  }

 private:
  // The servo loop, in the vendor's scheduler thread at its 1 kHz: one frame reads the pose and
  // sends the last force the haptic thread wrote (zero when it is older than 50 ms: our loop died).
  static HDCallbackCode servo(void* self_ptr) {
    auto& self = *static_cast<OpenHapticsDevice*>(self_ptr);
    const HdApi& hd = self.api_;
    hd.hdBeginFrame(self.hhd_);
    double pos[3] = {0, 0, 0}, vel[3] = {0, 0, 0}, xf[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    HDint buttons = 0;
    hd.hdGetDoublev(HD_CURRENT_POSITION, pos);
    hd.hdGetDoublev(HD_CURRENT_VELOCITY, vel);
    hd.hdGetDoublev(HD_CURRENT_TRANSFORM, xf);
    hd.hdGetIntegerv(HD_CURRENT_BUTTONS, &buttons);
    self.force_.update();
    const TimedForce& tf = self.force_.read();
    Vec3 f = tf.force;
    // The backend's own guard, whatever the caller wrote (a program on the public API may write
    // any force): zero when stale or not finite or stopping, clamped to the maximum, and changed by
    // at most max_force_rate per servo frame (the haptic loop's clock and the servo's are not
    // synchronised: two of its ticks may land between two frames). So the stale zero and the zero
    // at stop are ramps too.
    const bool stale = monotonic_ns() - tf.written_ns > 50'000'000;
    if (stale || !f.allFinite() || self.zeroing_.load(std::memory_order_relaxed)) f.setZero();
    const double max_force = self.servo_max_force_.load(std::memory_order_relaxed);
    const double max_step = self.servo_max_step_.load(std::memory_order_relaxed);
    if (const double n = f.norm(); n > max_force) f *= max_force / n;
    const Vec3 change = f - self.sent_;
    if (const double c = change.norm(); c > max_step) f = self.sent_ + change * (max_step / c);
    if (!f.allFinite()) f.setZero();  // (only from a NaN limit; never sent)
    if (const double n = f.norm(); n > max_force) f *= max_force / n;
    self.sent_ = f;
    if (self.zeroing_.load(std::memory_order_relaxed) && f.isZero()) self.zeroed_.store(true);
    self.running_.store(true, std::memory_order_relaxed);
    const double fd[3] = {f.x(), f.y(), f.z()};
    hd.hdSetDoublev(HD_CURRENT_FORCE, fd);
    hd.hdEndFrame(self.hhd_);
    const HDErrorInfo e = hd.hdGetError();
    if (e.errorCode != HD_SUCCESS) self.failed_.store(true, std::memory_order_relaxed);

    DeviceState& s = self.pose_.write_slot();
    s.position = Vec3(pos[0], pos[1], pos[2]) * 1e-3;  // mm → m
    s.velocity = Vec3(vel[0], vel[1], vel[2]) * 1e-3;  // mm/s → m/s
    Eigen::Matrix3d r;
    for (int c = 0; c < 3; ++c)
      for (int row = 0; row < 3; ++row) r(row, c) = xf[c * 4 + row];  // column-major
    s.orientation = Quat(r).normalized();
    s.buttons = static_cast<std::uint32_t>(buttons);
    self.pose_.publish();
    self.frame_ns_.store(monotonic_ns(), std::memory_order_relaxed);
    return self.stopping_.load(std::memory_order_relaxed) ? HD_CALLBACK_DONE : HD_CALLBACK_CONTINUE;
  }

  static HDCallbackCode query_limits(void* self_ptr) {
    auto& self = *static_cast<OpenHapticsDevice*>(self_ptr);
    double max_force = 0, stiffness = 0, damping = 0;
    self.api_.hdGetDoublev(HD_NOMINAL_MAX_FORCE, &max_force);
    self.api_.hdGetDoublev(HD_NOMINAL_MAX_STIFFNESS, &stiffness);
    self.api_.hdGetDoublev(HD_NOMINAL_MAX_DAMPING, &damping);
    // A device that reports no maximum (0, or garbage) gets its family's documented one: a scene
    // may ask for up to 50 N, which no Touch can take.
    if (!(max_force > 0) || !std::isfinite(max_force)) max_force = kFamilyMaxForce;
    self.limits_.max_force = std::min(self.limits_.max_force, max_force);
    if (stiffness > 0) self.limits_.stiffness = std::min(self.limits_.stiffness, stiffness * 1e3);
    if (damping > 0) self.limits_.damping = std::min(self.limits_.damping, damping * 1e3);
    return HD_CALLBACK_DONE;
  }

  // In the scheduler, once (hdScheduleSynchronous: start() waits for it). An update the library can
  // make alone is made with the style the device supports: automatic first (it needs no pose),
  // then the inkwell (a Touch's stylus resting in it), then the encoder reset.
  static HDCallbackCode check_calibration(void* self_ptr) {
    auto& self = *static_cast<OpenHapticsDevice*>(self_ptr);
    const HdApi& hd = self.api_;
    HDint styles = 0;
    hd.hdGetIntegerv(HD_CALIBRATION_STYLE, &styles);
    (void)hd.hdGetError();  // a library that does not know the query: no styles
    self.calibration_styles_ = styles;
    HDenum status = hd.hdCheckCalibration();
    if (status == HD_CALIBRATION_NEEDS_UPDATE && hd.hdUpdateCalibration) {
      const HDint style = (styles & HD_CALIBRATION_AUTO)      ? HD_CALIBRATION_AUTO
                          : (styles & HD_CALIBRATION_INKWELL) ? HD_CALIBRATION_INKWELL
                                                              : HD_CALIBRATION_ENCODER_RESET;
      hd.hdUpdateCalibration(static_cast<HDenum>(style));
      const HDErrorInfo e = hd.hdGetError();
      status = hd.hdCheckCalibration();
      self.calibration_updated_ = e.errorCode == HD_SUCCESS && status == HD_CALIBRATION_OK;
      if (e.errorCode != HD_SUCCESS) status = HD_CALIBRATION_NEEDS_UPDATE;
    }
    self.calibration_status_ = status;
    return HD_CALLBACK_DONE;
  }

  // The servo's copy of the limits (atomics: set before the scheduler starts and after the query).
  void publish_servo_limits() noexcept {
    const double mf = std::isfinite(limits_.max_force) ? std::max(0.0, limits_.max_force) : 0.0;
    const double rate = std::isfinite(limits_.max_force_rate) ? std::max(0.0, limits_.max_force_rate) : 0.0;
    servo_max_force_.store(mf);
    servo_max_step_.store(rate * kServoFrame);
  }

  HdApi api_;
  HHD hhd_;
  DeviceLimits limits_;
  std::atomic<double> servo_max_force_{0}, servo_max_step_{0};  // N, N per servo frame
  Vec3 sent_ = Vec3::Zero();                                    // servo thread only: last sent
  std::atomic<bool> zeroing_{false}, zeroed_{false}, running_{false};
  HDSchedulerHandle handle_ = 0;
  TripleBuffer<DeviceState> pose_;  // servo → haptic thread
  TripleBuffer<TimedForce> force_;  // haptic thread → servo
  std::atomic<bool> failed_{false}, stopping_{false};
  std::atomic<std::int64_t> frame_ns_{0};  // monotonic ns of the servo's last frame
  // Written by check_calibration in the scheduler before start() returns, read after.
  HDenum calibration_status_ = HD_CALIBRATION_OK;
  HDint calibration_styles_ = 0;
  bool calibration_updated_ = false;
};

}  // namespace

Result<std::unique_ptr<Device>> open_openhaptics(const std::string& library, const std::string& config,
                                                 const DeviceLimits& limits) {
  HdApi api;
  api.lib = ::dlopen(library.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!api.lib) {
    const char* why = ::dlerror();
    return Error{"openhaptics: cannot load the HD library '" + library + "' (" + (why ? why : "?") +
                 "): install OpenHaptics and the Touch device drivers, or set device.hd_library to "
                 "the path of libHD.so" + kScriptedHint};
  }
  const char* missing = nullptr;
#define PALPATE_BIND(name) \
  if (!missing && !bind(api.lib, api.name, #name)) missing = #name
  PALPATE_BIND(hdInitDevice);
  PALPATE_BIND(hdDisableDevice);
  PALPATE_BIND(hdEnable);
  PALPATE_BIND(hdStartScheduler);
  PALPATE_BIND(hdStopScheduler);
  PALPATE_BIND(hdScheduleAsynchronous);
  PALPATE_BIND(hdScheduleSynchronous);
  PALPATE_BIND(hdUnschedule);
  PALPATE_BIND(hdBeginFrame);
  PALPATE_BIND(hdEndFrame);
  PALPATE_BIND(hdGetDoublev);
  PALPATE_BIND(hdGetIntegerv);
  PALPATE_BIND(hdSetDoublev);
  PALPATE_BIND(hdGetError);
#undef PALPATE_BIND
  bind(api.lib, api.hdCheckCalibration, "hdCheckCalibration");
  bind(api.lib, api.hdUpdateCalibration, "hdUpdateCalibration");
  if (missing) {
    ::dlclose(api.lib);
    return Error{"openhaptics: '" + library + "' has no function " + missing +
                 ": it is not the OpenHaptics HD library" + kScriptedHint};
  }
  const HHD hhd = api.hdInitDevice(config.empty() ? nullptr : config.c_str());
  const HDErrorInfo e = api.hdGetError();
  if (hhd == HD_INVALID_HANDLE || e.errorCode != HD_SUCCESS) {
    ::dlclose(api.lib);
    return Error{"openhaptics: no haptic device " +
                 (config.empty() ? std::string("(default configuration)") : "'" + config + "'") +
                 " could be opened (HD error " + hex(e.errorCode) +
                 "): check that the Touch is connected and set up with Touch Setup" + kScriptedHint};
  }
  auto dev = std::make_unique<OpenHapticsDevice>(api, hhd, limits);
  if (Status s = dev->start(); !s) return s.error();
  return std::unique_ptr<Device>(std::move(dev));
}

}  // namespace palpate
