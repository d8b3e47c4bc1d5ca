// fake_hd.cpp — a stand-in for the OpenHaptics HD library (libHD.so) for the tests: it records the
// calls it receives, runs scheduled callbacks on its own 1 kHz "servo" thread, and models several
// devices by configuration name ("Default Device", "Left", "Right"): each with its own pose
// sequence (mm, as HD does), stylus rotation (by default 90 degrees about y), forces, nominal
// maximum force, force-impulse limit and faults. hdGet/hdSet act on the current device
// (hdMakeCurrentDevice), as in HD. Control and inspection functions are prefixed fake_hd_; those
// without a device name act on the default device, "Default Device"
// (hdInitDevice(HD_DEFAULT_DEVICE) opens it).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace {

using HDCallback = unsigned int (*)(void*);
struct ErrorInfo {
  unsigned int errorCode;
  int internalErrorCode;
  unsigned int hHD;
};

constexpr unsigned kInvalidHandle = 0xFFFFFFFF;
constexpr unsigned kDeviceFault = 0x0300;       // HD_DEVICE_FAULT
constexpr unsigned kAlreadyInitiated = 0x0301;  // HD_DEVICE_ALREADY_INITIATED
constexpr unsigned kExceededImpulse = 0x0202;   // HD_EXCEEDED_MAX_FORCE_IMPULSE
constexpr unsigned kInvalidEnum = 0x0100;       // HD_INVALID_ENUM

struct Scheduled {
  HDCallback fn;
  void* data;
  unsigned long handle;
  bool done;
  int device;        // the device the callback last began a frame on (-1: none yet)
  bool synchronous;  // hdScheduleSynchronous: run until done, then the caller is woken
};

// One device (a configuration name the fake knows).
struct FakeDevice {
  std::string name;
  bool initialised = false;
  bool in_frame = false;
  long frame = 0;
  std::vector<double> poses;  // x,y,z in mm per frame
  // The stylus rotation, column-major as in HD_CURRENT_TRANSFORM: 90 degrees about y by default.
  double rotation[9] = {0, 0, -1, 0, 1, 0, 1, 0, 0};
  std::vector<double> forces;  // x,y,z per hdSetDoublev(HD_CURRENT_FORCE)
  double last_force[3] = {0, 0, 0};
  double max_force = 3.3;      // HD_NOMINAL_MAX_FORCE, N (a Touch's); 0 = a device reporting none
  double impulse_limit = 1.0;  // HD_SOFTWARE_FORCE_IMPULSE_LIMIT, N per ms (per servo frame)
  bool nan_position = false;   // HD_CURRENT_POSITION reads NaN
  bool stalled = false;        // its callbacks are not run (the device stopped answering)
  unsigned fault = 0;          // an HD error its frames raise at hdEndFrame (0 = none)
  bool fault_persistent = false;  // raised every frame (unplugged) or once
  long fault_at_frame = -1;       // the fault starts at this frame of the device (-1: as set)
  std::vector<unsigned int> enabled;
};

struct Fake {
  std::mutex m;
  std::condition_variable sync_done;
  std::map<std::string, int> calls;
  std::vector<FakeDevice> devices;
  std::vector<Scheduled> scheduled;
  unsigned long next_handle = 1;
  bool device_present = true;
  int current = -1;           // index of the current device
  int running_callback = -1;  // index into `scheduled` of the callback the servo runs now
  int frame_errors =
      0;  // begin/end mismatches, gets outside a frame, a frame on a device not current
  int init_while_running = 0;   // hdInitDevice called while the scheduler ran
  int start_while_running = 0;  // hdStartScheduler called while it ran
  unsigned int error = 0;
  unsigned int error_hhd = 0;
  std::thread servo;
  std::atomic<bool> running{false};
  std::atomic<bool> stalled{
      false};  // the servo calls no callback (a library blocked inside a call)
  // hdCheckCalibration's answer (HD_CALIBRATION_OK 0x5000, _NEEDS_UPDATE 0x5001,
  // _NEEDS_MANUAL_INPUT 0x5002; a process that is not a test sets it with
  // FAKE_HD_CALIBRATION=ok|update|manual) and the styles the device supports (HD_CALIBRATION_STYLE;
  // a Touch's: the inkwell, 1 << 2).
  unsigned int calibration = initial_calibration();
  int calibration_styles = 1 << 2;
  int update_style = -1;  // the style of the last hdUpdateCalibration, -1 = none
  Fake() { reset_devices(); }
  void reset_devices() {
    devices.clear();
    for (const char* n : {"Default Device", "Left", "Right"}) {
      devices.emplace_back();
      devices.back().name = n;
    }
  }
  static unsigned int initial_calibration() {
    const char* c = std::getenv("FAKE_HD_CALIBRATION");
    if (c && std::strcmp(c, "update") == 0) return 0x5001;
    if (c && std::strcmp(c, "manual") == 0) return 0x5002;
    return 0x5000;
  }
  // The device a handle names (handles are index + 1), or nullptr.
  FakeDevice* by_handle(unsigned h) {
    return h >= 1 && h <= devices.size() ? &devices[h - 1] : nullptr;
  }
  int index_of(const char* name) const {
    for (size_t i = 0; i < devices.size(); ++i)
      if (devices[i].name == (name ? name : "")) return int(i);
    return -1;
  }
  FakeDevice* cur() { return current >= 0 ? &devices[size_t(current)] : nullptr; }
};

Fake& fake() {
  static Fake f;
  return f;
}

void count(const char* name) {
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  ++f.calls[name];
}

void servo_main() {
  Fake& f = fake();
  while (f.running.load()) {
    if (f.stalled.load()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      continue;
    }
    std::vector<Scheduled> now;
    {
      std::lock_guard<std::mutex> lock(f.m);
      now = f.scheduled;
    }
    for (size_t k = 0; k < now.size(); ++k) {
      Scheduled& s = now[k];
      if (s.done) continue;
      {
        std::lock_guard<std::mutex> lock(f.m);
        // A stalled device's callbacks wait: its frames stop, the other devices' go on.
        if (s.device >= 0 && f.devices[size_t(s.device)].stalled) continue;
        f.running_callback = int(k);
      }
      const bool done = s.fn(s.data) == 0;  // HD_CALLBACK_DONE
      std::lock_guard<std::mutex> lock(f.m);
      f.running_callback = -1;
      if (done) {
        for (auto& x : f.scheduled)
          if (x.handle == s.handle) x.done = true;
        if (s.synchronous) f.sync_done.notify_all();
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

}  // namespace

extern "C" {

// --- the HD API subset palpate uses.
unsigned int hdInitDevice(const char* name) {
  count("hdInitDevice");
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  if (f.running.load()) ++f.init_while_running;
  const int i = f.index_of(name && *name ? name : "Default Device");
  if (!f.device_present || i < 0) {
    f.error = kDeviceFault;
    f.error_hhd = kInvalidHandle;
    return kInvalidHandle;
  }
  FakeDevice& d = f.devices[size_t(i)];
  if (d.initialised) {  // as the real library: the same configuration twice
    f.error = kAlreadyInitiated;
    f.error_hhd = kInvalidHandle;
    return kInvalidHandle;
  }
  d.initialised = true;
  d.in_frame = false;
  f.current = i;  // hdInitDevice makes the new device current
  f.error = 0;
  return unsigned(i) + 1;
}
void hdDisableDevice(unsigned int hhd) {
  count("hdDisableDevice");
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  if (FakeDevice* d = f.by_handle(hhd)) d->initialised = false;
  if (f.current == int(hhd) - 1) f.current = -1;
}
void hdMakeCurrentDevice(unsigned int hhd) {
  count("hdMakeCurrentDevice");
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  FakeDevice* d = f.by_handle(hhd);
  if (!d || !d->initialised) {
    f.error = 0x0104;  // HD_BAD_HANDLE
    f.error_hhd = hhd;
    return;
  }
  f.current = int(hhd) - 1;
}
unsigned int hdGetCurrentDevice() {
  count("hdGetCurrentDevice");
  std::lock_guard<std::mutex> lock(fake().m);
  return fake().current >= 0 ? unsigned(fake().current) + 1 : kInvalidHandle;
}
void hdEnable(unsigned int cap) {
  count("hdEnable");
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  if (FakeDevice* d = f.cur()) d->enabled.push_back(cap);
}
void hdStartScheduler() {
  count("hdStartScheduler");
  Fake& f = fake();
  if (!f.running.exchange(true)) {
    f.servo = std::thread(servo_main);
  } else {
    std::lock_guard<std::mutex> lock(f.m);
    ++f.start_while_running;
  }
}
void hdStopScheduler() {
  count("hdStopScheduler");
  Fake& f = fake();
  if (f.running.exchange(false) && f.servo.joinable()) f.servo.join();
  std::lock_guard<std::mutex> lock(f.m);
  f.sync_done.notify_all();  // a synchronous call waiting on a scheduler that stopped returns
}
unsigned long hdScheduleAsynchronous(HDCallback fn, void* data, unsigned short) {
  count("hdScheduleAsynchronous");
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  f.scheduled.push_back({fn, data, f.next_handle, false, -1, false});
  return f.next_handle++;
}
// In the servo thread when the scheduler runs (the caller waits, as in HD), else at once here.
void hdScheduleSynchronous(HDCallback fn, void* data, unsigned short) {
  count("hdScheduleSynchronous");
  Fake& f = fake();
  std::unique_lock<std::mutex> lock(f.m);
  if (!f.running.load()) {
    lock.unlock();
    while (fn(data) != 0) {
    }
    return;
  }
  const unsigned long handle = f.next_handle++;
  f.scheduled.push_back({fn, data, handle, false, -1, true});
  f.sync_done.wait(lock, [&] {
    for (const auto& s : f.scheduled)
      if (s.handle == handle) return s.done || !f.running.load();
    return true;
  });
}
void hdUnschedule(unsigned long handle) {
  count("hdUnschedule");
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  for (auto& s : f.scheduled)
    if (s.handle == handle) s.done = true;
}
void hdBeginFrame(unsigned int hhd) {
  count("hdBeginFrame");
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  FakeDevice* d = f.by_handle(hhd);
  // A frame on a device that is not current: the gets and sets in it would act on another.
  if (!d || int(hhd) - 1 != f.current) {
    ++f.frame_errors;
    return;
  }
  if (d->in_frame) ++f.frame_errors;
  d->in_frame = true;
  ++d->frame;
  if (f.running_callback >= 0 && size_t(f.running_callback) < f.scheduled.size())
    f.scheduled[size_t(f.running_callback)].device = int(hhd) - 1;
}
void hdEndFrame(unsigned int hhd) {
  count("hdEndFrame");
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  FakeDevice* d = f.by_handle(hhd);
  if (!d || !d->in_frame) {
    ++f.frame_errors;
    return;
  }
  d->in_frame = false;
  if (d->fault && (d->fault_at_frame < 0 || d->frame >= d->fault_at_frame)) {
    f.error = d->fault;
    f.error_hhd = hhd;
    if (!d->fault_persistent) d->fault = 0;
  }
}
void hdGetDoublev(unsigned int what, double* out) {
  count("hdGetDoublev");
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  FakeDevice* d = f.cur();
  if (!d) {
    f.error = 0x0104;  // HD_BAD_HANDLE: no current device
    return;
  }
  const size_t n = d->poses.size() / 3;
  const size_t i = n ? size_t(d->frame) % n : 0;
  switch (what) {
    case 0x2050:  // HD_CURRENT_POSITION, mm
      if (!d->in_frame) ++f.frame_errors;
      for (int k = 0; k < 3; ++k) out[k] = n ? d->poses[i * 3 + size_t(k)] : 0.0;
      if (d->nan_position) out[1] = std::nan("");
      break;
    case 0x2051:  // HD_CURRENT_VELOCITY, mm/s
      for (int k = 0; k < 3; ++k) out[k] = 0.0;
      break;
    case 0x2052: {  // HD_CURRENT_TRANSFORM: the stylus rotation, translation = position
      const double* r = d->rotation;
      const double m[16] = {r[0], r[1], r[2], 0, r[3], r[4], r[5], 0,
                            r[6], r[7], r[8], 0, 0,    0,    0,    1};
      std::memcpy(out, m, sizeof m);
      for (int k = 0; k < 3; ++k) out[12 + k] = n ? d->poses[i * 3 + size_t(k)] : 0.0;
      break;
    }
    case 0x2603:
      out[0] = d->max_force;
      break;  // HD_NOMINAL_MAX_FORCE, N
    case 0x2607:
      out[0] = d->impulse_limit;
      break;  // HD_SOFTWARE_FORCE_IMPULSE_LIMIT, N/ms
    case 0x2602:
      out[0] = 0.8;
      break;  // HD_NOMINAL_MAX_STIFFNESS, N/mm
    case 0x2609:
      out[0] = 0.002;
      break;  // HD_NOMINAL_MAX_DAMPING, N·s/mm
    default:
      f.error = kInvalidEnum;
  }
}
void hdGetIntegerv(unsigned int what, int* out) {
  count("hdGetIntegerv");
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  FakeDevice* d = f.cur();
  if (what == 0x2000 && d)
    *out = int(d->frame % 2 == 0 ? 1 : 0);  // HD_CURRENT_BUTTONS: toggles
  else if (what == 0x2555)
    *out = f.calibration_styles;  // HD_CALIBRATION_STYLE
  else
    f.error = kInvalidEnum;
}
unsigned int hdCheckCalibration() {
  count("hdCheckCalibration");
  std::lock_guard<std::mutex> lock(fake().m);
  return fake().calibration;
}
// An update is possible only when the check said so, and only in a style the device supports.
void hdUpdateCalibration(unsigned int style) {
  count("hdUpdateCalibration");
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  f.update_style = int(style);
  if ((int(style) & f.calibration_styles) == 0)
    f.error = kInvalidEnum;
  else if (f.calibration == 0x5001)
    f.calibration = 0x5000;
}
// HD_CURRENT_FORCE, in a frame of the current device. As the library does (its software impulse
// check), a change of force above the impulse limit in one frame is an error, not sent.
void hdSetDoublev(unsigned int what, const double* v) {
  count("hdSetDoublev");
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  FakeDevice* d = f.cur();
  if (what != 0x2700 || !d || !d->in_frame) {
    ++f.frame_errors;
    return;
  }
  const double change = std::sqrt((v[0] - d->last_force[0]) * (v[0] - d->last_force[0]) +
                                  (v[1] - d->last_force[1]) * (v[1] - d->last_force[1]) +
                                  (v[2] - d->last_force[2]) * (v[2] - d->last_force[2]));
  if (d->impulse_limit > 0 && change > d->impulse_limit + 1e-12) {
    f.error = kExceededImpulse;
    f.error_hhd = unsigned(f.current) + 1;
    return;
  }
  std::memcpy(d->last_force, v, sizeof d->last_force);
  d->forces.insert(d->forces.end(), v, v + 3);
}
ErrorInfo hdGetError() {
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  ErrorInfo e{f.error, 0,
              f.error ? f.error_hhd : (f.current >= 0 ? unsigned(f.current) + 1 : kInvalidHandle)};
  f.error = 0;
  return e;
}

// --- control and inspection, for the tests.
void fake_hd_reset(int device_present) {
  hdStopScheduler();
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  f.calls.clear();
  f.reset_devices();
  f.scheduled.clear();
  f.device_present = device_present != 0;
  f.current = -1;
  f.running_callback = -1;
  f.frame_errors = 0;
  f.init_while_running = 0;
  f.start_while_running = 0;
  f.error = 0;
  f.error_hhd = 0;
  f.stalled.store(false);
  f.calibration = 0x5000;
  f.calibration_styles = 1 << 2;
  f.update_style = -1;
}

namespace {
// The named device ("" or null: the default one); nullptr for a name the fake does not know.
FakeDevice* named(Fake& f, const char* name) {
  const int i = f.index_of(name && *name ? name : "Default Device");
  return i < 0 ? nullptr : &f.devices[size_t(i)];
}
int copy_forces(const FakeDevice* d, double* out, int max) {
  if (!d) return 0;
  const int n = int(d->forces.size() / 3);
  if (n > 0 && max > 0)  // (memcpy from an empty vector's null data() is undefined, even for 0 bytes)
    std::memcpy(out, d->forces.data(), sizeof(double) * 3 * size_t(std::min(n, max)));
  return n;
}
}  // namespace

// hdCheckCalibration's answer and the supported styles from now on.
void fake_hd_set_calibration(unsigned int status, int styles) {
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  f.calibration = status;
  f.calibration_styles = styles;
}
int fake_hd_update_style() {
  std::lock_guard<std::mutex> lock(fake().m);
  return fake().update_style;
}
// While `on`, the servo thread runs no callback: the library blocked inside a call.
void fake_hd_stall(int on) {
  fake().stalled.store(on != 0);
}
int fake_hd_calls(const char* name) {
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  auto it = f.calls.find(name);
  return it == f.calls.end() ? 0 : it->second;
}
int fake_hd_frame_errors() {
  std::lock_guard<std::mutex> lock(fake().m);
  return fake().frame_errors;
}
// How often hdInitDevice or hdStartScheduler was called while the scheduler ran (HD: devices are
// initialised before the scheduler starts; it is started once).
int fake_hd_init_while_running() {
  std::lock_guard<std::mutex> lock(fake().m);
  return fake().init_while_running;
}
int fake_hd_start_while_running() {
  std::lock_guard<std::mutex> lock(fake().m);
  return fake().start_while_running;
}
int fake_hd_scheduler_running() {
  return fake().running.load() ? 1 : 0;
}

// --- per device, by configuration name ("" = the default device).
// While `on`, the device's callbacks are not run: it stopped answering; the others go on.
void fake_hd_device_stall(const char* name, int on) {
  std::lock_guard<std::mutex> lock(fake().m);
  if (FakeDevice* d = named(fake(), name)) d->stalled = on != 0;
}
// From the device's frame `at_frame` on (-1: its next), its frames raise HD error `code` at
// hdEndFrame: every frame when `persistent` (an unplugged device: HD_COMM_ERROR 0x0302), else once.
void fake_hd_device_fault(const char* name, unsigned int code, int persistent, long at_frame) {
  std::lock_guard<std::mutex> lock(fake().m);
  if (FakeDevice* d = named(fake(), name)) {
    d->fault = code;
    d->fault_persistent = persistent != 0;
    d->fault_at_frame = at_frame;
  }
}
void fake_hd_device_set_poses(const char* name, const double* xyz_mm, int n) {
  std::lock_guard<std::mutex> lock(fake().m);
  if (FakeDevice* d = named(fake(), name)) d->poses.assign(xyz_mm, xyz_mm + 3 * n);
}
// The nominal maximum force (N; 0 = none reported) and the force-impulse limit (N per ms) the
// device reports from now on.
void fake_hd_device_set_limits(const char* name, double max_force, double impulse_limit) {
  std::lock_guard<std::mutex> lock(fake().m);
  if (FakeDevice* d = named(fake(), name)) {
    d->max_force = max_force;
    d->impulse_limit = impulse_limit;
  }
}
int fake_hd_device_forces(const char* name, double* out, int max) {
  std::lock_guard<std::mutex> lock(fake().m);
  return copy_forces(named(fake(), name), out, max);
}
long fake_hd_device_frames(const char* name) {
  std::lock_guard<std::mutex> lock(fake().m);
  const FakeDevice* d = named(fake(), name);
  return d ? d->frame : -1;
}
int fake_hd_device_initialised(const char* name) {
  std::lock_guard<std::mutex> lock(fake().m);
  const FakeDevice* d = named(fake(), name);
  return d && d->initialised ? 1 : 0;
}
int fake_hd_device_enabled(const char* name, unsigned int cap) {
  std::lock_guard<std::mutex> lock(fake().m);
  const FakeDevice* d = named(fake(), name);
  if (!d) return 0;
  return std::find(d->enabled.begin(), d->enabled.end(), cap) != d->enabled.end() ? 1 : 0;
}

// --- the default device, for the single-device tests.
// While `on`, the device reports a NaN position (a sensor fault).
void fake_hd_set_nan_position(int on) {
  std::lock_guard<std::mutex> lock(fake().m);
  named(fake(), nullptr)->nan_position = on != 0;
}
// The nominal maximum force the device reports from now on (N; 0 = none reported).
void fake_hd_set_max_force(double newtons) {
  std::lock_guard<std::mutex> lock(fake().m);
  named(fake(), nullptr)->max_force = newtons;
}
void fake_hd_set_poses(const double* xyz_mm, int n) {
  fake_hd_device_set_poses(nullptr, xyz_mm, n);
}
// The stylus rotation from now on: a 3x3 matrix, column-major (as HD_CURRENT_TRANSFORM holds it).
void fake_hd_set_rotation(const double* columns) {
  std::lock_guard<std::mutex> lock(fake().m);
  FakeDevice* d = named(fake(), nullptr);
  std::memcpy(d->rotation, columns, sizeof d->rotation);
}
int fake_hd_enabled(unsigned int cap) {
  return fake_hd_device_enabled(nullptr, cap);
}
// Copy up to max forces (x,y,z each) into out; returns how many were recorded in all.
int fake_hd_forces(double* out, int max) {
  return fake_hd_device_forces(nullptr, out, max);
}

}  // extern "C"
