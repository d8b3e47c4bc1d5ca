// openhaptics_device.cpp — the openhaptics backend: Phantom Omni / Geomagic Touch through the
// vendor's HD API, loaded at run time with dlopen; its servo callback runs in the HD scheduler.
// Several devices at once share one library and one scheduler (a process-wide registry).
#include <palpate/device.h>

#include "haptics/pacing.h"
#include "haptics/triple_buffer.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <dlfcn.h>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

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
constexpr HDerror HD_DEVICE_ALREADY_INITIATED = 0x0301;  // the configuration is initialised already
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
// The largest change of force the library lets through in one servo frame, N per ms (its software
// force-impulse check: a larger change is an HD_EXCEEDED_MAX_FORCE_IMPULSE error, a device fault).
constexpr HDenum HD_SOFTWARE_FORCE_IMPULSE_LIMIT = 0x2607;
constexpr HDenum HD_CURRENT_FORCE = 0x2700;          // N
constexpr HDenum HD_FORCE_OUTPUT = 0x4000;
constexpr HDenum HD_CALIBRATION_STYLE = 0x2555;      // the styles a device supports (bit mask)
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
  void (*hdMakeCurrentDevice)(HHD) = nullptr;
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

// One HD library per process, shared by every device opened through it. HD has one scheduler (one
// servo thread running every device's callback, each frame made on the device it makes current)
// and a device configuration can be initialised once: two devices that each loaded, initialised
// and started their own failed with HD_DEVICE_ALREADY_INITIATED. As HD asks, devices are
// initialised while the scheduler is stopped: it is stopped for the time a later device is
// initialised and started again at once, and stopped for good when the last device closes.
// Guarded by registry_mutex(): opening and closing only, never the servo or the haptic thread.
struct HdLibrary {
  std::string path;                  // as given to open_openhaptics (the registry's key)
  HdApi api;
  std::vector<std::string> configs;  // the open devices' configuration names ("" = the default)
  bool scheduler_running = false;
};

std::mutex& registry_mutex() {
  static std::mutex m;
  return m;
}
std::vector<std::unique_ptr<HdLibrary>>& registry() {
  static std::vector<std::unique_ptr<HdLibrary>> libs;
  return libs;
}

std::string config_text(const std::string& config) {
  return config.empty() ? std::string("the default HD device configuration")
                        : "the HD device configuration '" + config + "'";
}

class OpenHapticsDevice final : public Device {
 public:
  OpenHapticsDevice(HdLibrary& lib, HHD hhd, std::string config, DeviceLimits limits)
      : lib_(lib), api_(lib.api), hhd_(hhd), config_(std::move(config)), limits_(limits) {
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
    // The scheduler is the library's, shared: stopped while this device leaves it, started again
    // for the devices still open; the library is unloaded with the last of them.
    std::lock_guard<std::mutex> lock(registry_mutex());
    if (lib_.scheduler_running) api_.hdStopScheduler();
    lib_.scheduler_running = false;
    if (handle_) api_.hdUnschedule(handle_);
    api_.hdMakeCurrentDevice(hhd_);
    api_.hdDisableDevice(hhd_);
    auto& names = lib_.configs;
    if (auto it = std::find(names.begin(), names.end(), config_); it != names.end())
      names.erase(it);
    if (!names.empty()) {
      api_.hdStartScheduler();
      (void)api_.hdGetError();
      lib_.scheduler_running = true;
      return;
    }
    ::dlclose(api_.lib);
    auto& libs = registry();
    libs.erase(
        std::remove_if(libs.begin(), libs.end(), [&](const auto& l) { return l.get() == &lib_; }),
        libs.end());
  }
  OpenHapticsDevice(const OpenHapticsDevice&) = delete;
  OpenHapticsDevice& operator=(const OpenHapticsDevice&) = delete;

  // With registry_mutex() held; the scheduler stopped, the device initialised and current.
  Status start() {
    frame_ns_.store(monotonic_ns(), std::memory_order_relaxed);  // the first frame's grace
    api_.hdMakeCurrentDevice(hhd_);
    api_.hdEnable(HD_FORCE_OUTPUT);  // acts on the current device
    handle_ = api_.hdScheduleAsynchronous(&OpenHapticsDevice::servo, this, HD_DEFAULT_SCHEDULER_PRIORITY);
    api_.hdStartScheduler();
    HDErrorInfo e = api_.hdGetError();
    if (e.errorCode != HD_SUCCESS)
      return Error{"openhaptics: the HD scheduler did not start (HD error " + hex(e.errorCode) + ")" +
                   kScriptedHint};
    lib_.scheduler_running = true;
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
  // The scheduler runs every open device's callback in turn: each makes its own device current
  // before its frame, so its gets and sets act on it and on no other.
  static HDCallbackCode servo(void* self_ptr) {
    auto& self = *static_cast<OpenHapticsDevice*>(self_ptr);
    const HdApi& hd = self.api_;
    hd.hdMakeCurrentDevice(self.hhd_);
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
    // any force): zero when stale or not finite or stopping or the device failed, clamped to the
    // maximum, and changed by at most max_force_rate per servo frame (the haptic loop's clock and
    // the servo's are not synchronised: two of its ticks may land between two frames). So the
    // stale zero, the zero after a fault and the zero at stop are ramps too.
    const bool stale = monotonic_ns() - tf.written_ns > 50'000'000;
    if (stale || !f.allFinite() || self.zeroing_.load(std::memory_order_relaxed) ||
        self.failed_.load(std::memory_order_relaxed))
      f.setZero();
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
    // Any error of this frame (a device fault, a communication error when it is unplugged, a
    // force the library refused) fails the device for the rest of the run: read() fails from now
    // on (a device_failed fault for its tool only) and its force ramps to zero. Errors are taken
    // off the library's stack until it is empty (bounded), so none is left for another device.
    for (int k = 0; k < 8; ++k) {
      const HDErrorInfo e = hd.hdGetError();
      if (e.errorCode == HD_SUCCESS) break;
      self.failed_.store(true, std::memory_order_relaxed);
    }

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

  // In the scheduler, once, with this device current: its nominal maximum force, stiffness and
  // damping, and the force-impulse limit of the library's software check (N per 1 ms servo frame),
  // each lowering the scene's where it is lower.
  static HDCallbackCode query_limits(void* self_ptr) {
    auto& self = *static_cast<OpenHapticsDevice*>(self_ptr);
    const HdApi& hd = self.api_;
    hd.hdMakeCurrentDevice(self.hhd_);
    double max_force = 0, stiffness = 0, damping = 0, impulse = 0;
    hd.hdGetDoublev(HD_NOMINAL_MAX_FORCE, &max_force);
    hd.hdGetDoublev(HD_NOMINAL_MAX_STIFFNESS, &stiffness);
    hd.hdGetDoublev(HD_NOMINAL_MAX_DAMPING, &damping);
    hd.hdGetDoublev(HD_SOFTWARE_FORCE_IMPULSE_LIMIT, &impulse);
    for (int k = 0; k < 8 && hd.hdGetError().errorCode != HD_SUCCESS; ++k) {
    }  // a library that does not know a query: that value stays 0, not used
    // A device that reports no maximum (0, or garbage) gets its family's documented one: a scene
    // may ask for up to 50 N, which no Touch can take.
    if (!(max_force > 0) || !std::isfinite(max_force)) max_force = kFamilyMaxForce;
    self.limits_.max_force = std::min(self.limits_.max_force, max_force);
    if (stiffness > 0) self.limits_.stiffness = std::min(self.limits_.stiffness, stiffness * 1e3);
    if (damping > 0) self.limits_.damping = std::min(self.limits_.damping, damping * 1e3);
    // N per ms → N/s: the servo's per-frame step (max_force_rate · 1 ms) never exceeds it, so the
    // library's impulse check never fails the device on a force palpate sent.
    if (impulse > 0 && std::isfinite(impulse))
      self.limits_.max_force_rate = std::min(self.limits_.max_force_rate, impulse / kServoFrame);
    return HD_CALLBACK_DONE;
  }

  // In the scheduler, once (hdScheduleSynchronous: start() waits for it), with this device current.
  // An update the library can make alone is made with the style the device supports: automatic
  // first (it needs no pose), then the inkwell (a Touch's stylus resting in it), then the encoder
  // reset.
  static HDCallbackCode check_calibration(void* self_ptr) {
    auto& self = *static_cast<OpenHapticsDevice*>(self_ptr);
    const HdApi& hd = self.api_;
    hd.hdMakeCurrentDevice(self.hhd_);
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

  HdLibrary& lib_;
  const HdApi& api_;
  HHD hhd_;
  std::string config_;
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

// The library loaded from `library` (dlopen, every function bound), or an error saying what is
// missing. With registry_mutex() held; the caller adds it to the registry.
Result<std::unique_ptr<HdLibrary>> load_library(const std::string& library) {
  auto lib = std::make_unique<HdLibrary>();
  lib->path = library;
  HdApi& api = lib->api;
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
  PALPATE_BIND(hdMakeCurrentDevice);
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
  return lib;
}

}  // namespace

Result<std::unique_ptr<Device>> open_openhaptics(const std::string& library,
                                                 const std::string& config,
                                                 const DeviceLimits& limits) {
  std::unique_lock<std::mutex> lock(registry_mutex());
  auto& libs = registry();
  // A configuration names one physical device: a second tool on it is refused before HD is asked
  // (HD would answer HD_DEVICE_ALREADY_INITIATED, and two safety filters would fight over one arm).
  for (const auto& l : libs)
    if (std::find(l->configs.begin(), l->configs.end(), config) != l->configs.end())
      return Error{
          "openhaptics: " + config_text(config) +
          " is already open in this process, by another tool: each tool needs its own device "
          "(set device.hd_device, probe.device.hd_device, grasper.device.hd_device to the "
          "configuration names Touch Setup gave your devices)"};
  HdLibrary* lib = nullptr;
  for (const auto& l : libs)
    if (l->path == library) lib = l.get();
  if (!lib) {
    auto loaded = load_library(library);
    if (!loaded) return loaded.error();
    libs.push_back(std::move(*loaded));
    lib = libs.back().get();
  }
  const HdApi& api = lib->api;
  // HD initialises devices while its scheduler is stopped: stopped for this one if it runs for
  // the others (they miss a few servo frames, at open: before any run).
  if (lib->scheduler_running) api.hdStopScheduler();
  lib->scheduler_running = false;
  const HHD hhd = api.hdInitDevice(config.empty() ? nullptr : config.c_str());
  const HDErrorInfo e = api.hdGetError();
  if (hhd == HD_INVALID_HANDLE || e.errorCode != HD_SUCCESS) {
    if (!lib->configs.empty()) {
      api.hdStartScheduler();
      (void)api.hdGetError();
      lib->scheduler_running = true;
    } else {
      ::dlclose(api.lib);
      libs.erase(
          std::remove_if(libs.begin(), libs.end(), [&](const auto& l) { return l.get() == lib; }),
          libs.end());
    }
    const std::string which =
        config.empty() ? std::string("(default configuration)") : "'" + config + "'";
    if (e.errorCode == HD_DEVICE_ALREADY_INITIATED)
      return Error{
          "openhaptics: the haptic device " + which +
          " is already initialised (HD error 0x0301, HD_DEVICE_ALREADY_INITIATED): another "
          "program holds it (a second palpate, Touch Diagnostic), or two configuration names of "
          "this scene are the same device; close the other program, or give each tool its own "
          "device" +
          kScriptedHint};
    return Error{"openhaptics: no haptic device " + which + " could be opened (HD error " +
                 hex(e.errorCode) +
                 "): check that the Touch is connected and set up with Touch Setup" +
                 kScriptedHint};
  }
  lib->configs.push_back(config);
  auto dev = std::make_unique<OpenHapticsDevice>(*lib, hhd, config, limits);
  if (Status s = dev->start(); !s) {
    lock.unlock();  // the device's destructor takes the registry's lock to close it
    return s.error();
  }
  return std::unique_ptr<Device>(std::move(dev));
}

}  // namespace palpate
