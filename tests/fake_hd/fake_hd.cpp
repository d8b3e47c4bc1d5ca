// fake_hd.cpp — a stand-in for the OpenHaptics HD library (libHD.so) for the tests: it records the
// calls it receives, runs scheduled callbacks on its own 1 kHz "servo" thread, and plays a pose
// sequence (mm, as HD does) with a stylus rotation (by default 90 degrees about y). Control and
// inspection functions are prefixed fake_hd_.
#include <atomic>
#include <chrono>
#include <cmath>
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

struct Scheduled {
  HDCallback fn;
  void* data;
  unsigned long handle;
  bool done;
};

struct Fake {
  std::mutex m;
  std::map<std::string, int> calls;
  std::vector<double> poses;  // x,y,z in mm per frame
  // The stylus rotation, column-major as in HD_CURRENT_TRANSFORM: 90 degrees about y by default.
  double rotation[9] = {0, 0, -1, 0, 1, 0, 1, 0, 0};
  std::vector<double> forces; // x,y,z per hdSetDoublev(HD_CURRENT_FORCE)
  std::vector<Scheduled> scheduled;
  unsigned long next_handle = 1;
  bool device_present = true;
  bool in_frame = false;
  int frame_errors = 0;       // begin/end mismatches and gets outside a frame
  long frame = 0;
  unsigned int error = 0;
  double max_force = 3.3;     // HD_NOMINAL_MAX_FORCE, N (a Touch's); 0 = a device reporting none
  std::thread servo;
  std::atomic<bool> running{false};
  std::atomic<bool> stalled{false};  // the servo calls no callback (a library blocked inside a call)
  bool nan_position = false;          // HD_CURRENT_POSITION reads NaN
  std::vector<unsigned int> enabled;
  // hdCheckCalibration's answer (HD_CALIBRATION_OK 0x5000, _NEEDS_UPDATE 0x5001, _NEEDS_MANUAL_INPUT
  // 0x5002; a process that is not a test sets it with FAKE_HD_CALIBRATION=ok|update|manual) and
  // the styles the device supports (HD_CALIBRATION_STYLE; a Touch's: the inkwell, 1 << 2).
  unsigned int calibration = initial_calibration();
  int calibration_styles = 1 << 2;
  int update_style = -1;  // the style of the last hdUpdateCalibration, -1 = none
  static unsigned int initial_calibration() {
    const char* c = std::getenv("FAKE_HD_CALIBRATION");
    if (c && std::strcmp(c, "update") == 0) return 0x5001;
    if (c && std::strcmp(c, "manual") == 0) return 0x5002;
    return 0x5000;
  }
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
    for (Scheduled& s : now) {
      if (s.done) continue;
      if (s.fn(s.data) == 0) {  // HD_CALLBACK_DONE
        std::lock_guard<std::mutex> lock(f.m);
        for (auto& x : f.scheduled)
          if (x.handle == s.handle) x.done = true;
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

}  // namespace

extern "C" {

// --- the HD API subset palpate uses.
unsigned int hdInitDevice(const char*) {
  count("hdInitDevice");
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  if (!f.device_present) {
    f.error = 0x0300;  // HD_DEVICE_FAULT
    return 0xFFFFFFFF;
  }
  f.error = 0;
  return 1;
}
void hdDisableDevice(unsigned int) { count("hdDisableDevice"); }
void hdEnable(unsigned int cap) {
  count("hdEnable");
  std::lock_guard<std::mutex> lock(fake().m);
  fake().enabled.push_back(cap);
}
void hdStartScheduler() {
  count("hdStartScheduler");
  Fake& f = fake();
  if (!f.running.exchange(true)) f.servo = std::thread(servo_main);
}
void hdStopScheduler() {
  count("hdStopScheduler");
  Fake& f = fake();
  if (f.running.exchange(false) && f.servo.joinable()) f.servo.join();
}
unsigned long hdScheduleAsynchronous(HDCallback fn, void* data, unsigned short) {
  count("hdScheduleAsynchronous");
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  f.scheduled.push_back({fn, data, f.next_handle, false});
  return f.next_handle++;
}
void hdScheduleSynchronous(HDCallback fn, void* data, unsigned short) {
  count("hdScheduleSynchronous");
  while (fn(data) != 0) {
  }
}
void hdUnschedule(unsigned long handle) {
  count("hdUnschedule");
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  for (auto& s : f.scheduled)
    if (s.handle == handle) s.done = true;
}
void hdBeginFrame(unsigned int) {
  count("hdBeginFrame");
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  if (f.in_frame) ++f.frame_errors;
  f.in_frame = true;
  ++f.frame;
}
void hdEndFrame(unsigned int) {
  count("hdEndFrame");
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  if (!f.in_frame) ++f.frame_errors;
  f.in_frame = false;
}
void hdGetDoublev(unsigned int what, double* out) {
  count("hdGetDoublev");
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  const size_t n = f.poses.size() / 3;
  const size_t i = n ? size_t(f.frame) % n : 0;
  switch (what) {
    case 0x2050:  // HD_CURRENT_POSITION, mm
      if (!f.in_frame) ++f.frame_errors;
      for (int k = 0; k < 3; ++k) out[k] = n ? f.poses[i * 3 + size_t(k)] : 0.0;
      if (f.nan_position) out[1] = std::nan("");
      break;
    case 0x2051:  // HD_CURRENT_VELOCITY, mm/s
      for (int k = 0; k < 3; ++k) out[k] = 0.0;
      break;
    case 0x2052: {  // HD_CURRENT_TRANSFORM: the stylus rotation, translation = position
      const double* r = f.rotation;
      const double m[16] = {r[0], r[1], r[2], 0, r[3], r[4], r[5], 0, r[6], r[7], r[8], 0, 0, 0, 0, 1};
      std::memcpy(out, m, sizeof m);
      for (int k = 0; k < 3; ++k) out[12 + k] = n ? f.poses[i * 3 + size_t(k)] : 0.0;
      break;
    }
    case 0x2603: out[0] = f.max_force; break;  // HD_NOMINAL_MAX_FORCE, N
    case 0x2602: out[0] = 0.8; break;   // HD_NOMINAL_MAX_STIFFNESS, N/mm
    case 0x2609: out[0] = 0.002; break; // HD_NOMINAL_MAX_DAMPING, N·s/mm
    default: f.error = 0x0100;          // HD_INVALID_ENUM
  }
}
void hdGetIntegerv(unsigned int what, int* out) {
  count("hdGetIntegerv");
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  if (what == 0x2000) *out = int(f.frame % 2 == 0 ? 1 : 0);  // HD_CURRENT_BUTTONS: toggles
  else if (what == 0x2650) *out = f.calibration_styles;       // HD_CALIBRATION_STYLE
  else f.error = 0x0100;
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
  if ((int(style) & f.calibration_styles) == 0) f.error = 0x0100;
  else if (f.calibration == 0x5001) f.calibration = 0x5000;
}
void hdSetDoublev(unsigned int what, const double* v) {
  count("hdSetDoublev");
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  if (what != 0x2700 || !f.in_frame) {
    ++f.frame_errors;
    return;
  }
  f.forces.insert(f.forces.end(), v, v + 3);
}
ErrorInfo hdGetError() {
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  ErrorInfo e{f.error, 0, 1};
  f.error = 0;
  return e;
}

// --- control and inspection, for the tests.
void fake_hd_reset(int device_present) {
  hdStopScheduler();
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  f.calls.clear();
  f.poses.clear();
  const double about_y[9] = {0, 0, -1, 0, 1, 0, 1, 0, 0};
  std::memcpy(f.rotation, about_y, sizeof about_y);
  f.forces.clear();
  f.scheduled.clear();
  f.enabled.clear();
  f.device_present = device_present != 0;
  f.in_frame = false;
  f.frame_errors = 0;
  f.frame = 0;
  f.error = 0;
  f.max_force = 3.3;
  f.stalled.store(false);
  f.nan_position = false;
  f.calibration = 0x5000;
  f.calibration_styles = 1 << 2;
  f.update_style = -1;
}
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
// While `on`, the servo thread runs no callback: the library blocked inside a call, or a device
// that stopped answering.
void fake_hd_stall(int on) { fake().stalled.store(on != 0); }
// While `on`, the device reports a NaN position (a sensor fault).
void fake_hd_set_nan_position(int on) {
  std::lock_guard<std::mutex> lock(fake().m);
  fake().nan_position = on != 0;
}
// The nominal maximum force the device reports from now on (N; 0 = none reported).
void fake_hd_set_max_force(double newtons) {
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  f.max_force = newtons;
}
void fake_hd_set_poses(const double* xyz_mm, int n) {
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  f.poses.assign(xyz_mm, xyz_mm + 3 * n);
}
// The stylus rotation from now on: a 3x3 matrix, column-major (as HD_CURRENT_TRANSFORM holds it).
void fake_hd_set_rotation(const double* columns) {
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  std::memcpy(f.rotation, columns, sizeof f.rotation);
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
int fake_hd_enabled(unsigned int cap) {
  std::lock_guard<std::mutex> lock(fake().m);
  for (unsigned int c : fake().enabled)
    if (c == cap) return 1;
  return 0;
}
// Copy up to max forces (x,y,z each) into out; returns how many were recorded in all.
int fake_hd_forces(double* out, int max) {
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  const int n = int(f.forces.size() / 3);
  std::memcpy(out, f.forces.data(), sizeof(double) * 3 * size_t(std::min(n, max)));
  return n;
}

}  // extern "C"
