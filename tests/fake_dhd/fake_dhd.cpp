// fake_dhd.cpp — a stand-in for Force Dimension's DHD library (libdhd.so.3, with the DRD calls
// palpate uses) for the tests: it records every call, plays a timed trajectory (m, as DHD gives
// it), and behaves as the SDK documents: a windowed velocity estimate from the positions it was
// asked for (20 ms by default; an error with fewer than two in the window), saturation at the
// device's force limit (DHD_MOTOR_SATURATED), a time guard (DHD_TIMEGUARD), a watchdog that turns
// forces off when no force arrives for its period, and no force before the device is calibrated
// and its forces enabled. Faults on demand: a device that stops answering (calls block), returns
// errors, or is unplugged. Control and inspection functions are prefixed fake_dhd_. A process that
// is not a test is given poses with FAKE_DHD_POSES=file.csv (rows t,x,y,z in s and m) and a device
// count with FAKE_DHD_DEVICES=n.
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace {

constexpr int kTimeguard = 1, kMotorSaturated = 2;
enum Err {
  kNoError = 0,
  kError = 1,
  kCom = 2,
  kNoDevice = 5,
  kTimeout = 7,
  kInvalidIndex = 15,
  kNotEnabled = 19
};
enum Fault { kNone = 0, kStall = 1, kFails = 2, kUnplugged = 3 };

std::int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

struct Dev {
  int type = 35;  // DHD_DEVICE_OMEGA331: omega.7
  int serial = 1001;
  bool present = true;
  bool open = false, drd_open = false;
  bool initialised = true;  // calibrated (drdIsInitialized)
  bool auto_init_fails = false;
  bool forces_enabled = false;
  int watchdog = 200;               // x 125 us; the device's own default here (0 = off)
  unsigned velocity_threshold = 4;  // the SDK's cut-off (0 = off)
  double hw_force = 12, hw_torque = 0, hw_gripper = 8;       // what the motors give (N, N·m, N)
  double max_force = -1, max_torque = -1, max_gripper = -1;  // software limits (negative: none)
  std::vector<double> traj;                                  // t, x, y, z per row (s, m)
  double rot[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};               // row-major
  double gripper_angle = 0.3;
  unsigned buttons = 0;
  bool emulate_button = false;
  bool gravity = true;
  std::int64_t opened_ns = 0;
  std::deque<std::pair<std::int64_t, std::array<double, 3>>> window;
  int window_ms = 20;
  int timeguard_us = 0;
  std::int64_t last_get_ns = 0;
  double cached[3] = {0, 0, 0};
  std::int64_t last_set_ns = 0;
  int watchdog_trips = 0;
  int fault = kNone;
  std::vector<double> applied;  // fx, fy, fz, tx, ty, tz, fg per set call: what reached the motors
  int refused = 0;              // set calls asking a non-zero force before calibration and enable
  int saturated = 0;

  bool has_wrist() const {
    return type == 34 || type == 35 || type == 36 || type == 37 || type == 64 ||
           (type >= 104 && type <= 107);
  }
  bool active_wrist() const { return type == 64 || (type >= 104 && type <= 107); }
  bool has_gripper() const { return type == 35 || type == 37 || type == 104 || type == 105; }
};

struct Fake {
  std::mutex m;
  std::vector<Dev> devs;
  std::map<std::string, int> calls;
  std::map<std::string, int> first;  // the sequence number of a function's first call
  int seq = 0;
  int error = kNoError;
  int current = -1;
  Fake() { from_environment(); }
  void from_environment() {
    devs.clear();
    int n = 1;
    if (const char* c = std::getenv("FAKE_DHD_DEVICES")) n = std::atoi(c);
    for (int i = 0; i < n; ++i) {
      devs.emplace_back();
      devs.back().serial = 1001 + i;
    }
    if (const char* p = std::getenv("FAKE_DHD_POSES"); p && !devs.empty()) {
      std::ifstream in(p);
      for (std::string line; std::getline(in, line);) {
        if (line.empty() || line[0] == '#' || std::isalpha(static_cast<unsigned char>(line[0])))
          continue;
        std::replace(line.begin(), line.end(), ',', ' ');
        std::istringstream row(line);
        double t, x, y, z;
        if (row >> t >> x >> y >> z) devs[0].traj.insert(devs[0].traj.end(), {t, x, y, z});
      }
    }
  }
};

Fake& fake() {
  static Fake f;
  return f;
}

// Count a call; find its device (ID -1 = the current one). For a device that stopped answering,
// block (outside the lock) until it answers again.
Dev* enter(const char* name, int id, std::unique_lock<std::mutex>& lock) {
  Fake& f = fake();
  lock = std::unique_lock<std::mutex>(f.m);
  ++f.calls[name];
  f.first.emplace(name, f.seq++);
  if (id < 0) id = f.current;
  if (id < 0 || id >= int(f.devs.size())) {
    f.error = kInvalidIndex;
    return nullptr;
  }
  while (f.devs[size_t(id)].fault == kStall) {
    lock.unlock();
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
    lock.lock();
  }
  Dev& d = f.devs[size_t(id)];
  if (d.fault == kFails) {
    f.error = kCom;
    return nullptr;
  }
  if (!d.present || d.fault == kUnplugged) {
    f.error = kNoDevice;
    return nullptr;
  }
  return &d;
}

// The watchdog: forces enabled and none set for longer than its period: off, as the firmware does.
void watchdog_check(Dev& d, std::int64_t now) {
  if (d.forces_enabled && d.watchdog > 0 && d.last_set_ns > 0 &&
      now - d.last_set_ns > std::int64_t(d.watchdog) * 125'000) {
    d.forces_enabled = false;
    ++d.watchdog_trips;
  }
}

void position_at(const Dev& d, std::int64_t now, double out[3]) {
  const size_t n = d.traj.size() / 4;
  out[0] = out[1] = out[2] = 0;
  if (n == 0) return;
  const double t = double(now - d.opened_ns) * 1e-9;
  size_t i = 0;
  while (i + 1 < n && d.traj[(i + 1) * 4] <= t) ++i;
  if (i + 1 >= n || t <= d.traj[0]) {
    const size_t k = t <= d.traj[0] ? 0 : n - 1;
    for (int c = 0; c < 3; ++c) out[c] = d.traj[k * 4 + 1 + size_t(c)];
    return;
  }
  const double t0 = d.traj[i * 4], t1 = d.traj[(i + 1) * 4];
  const double a = t1 > t0 ? (t - t0) / (t1 - t0) : 1.0;
  for (int c = 0; c < 3; ++c)
    out[c] = (1 - a) * d.traj[i * 4 + 1 + size_t(c)] + a * d.traj[(i + 1) * 4 + 1 + size_t(c)];
}

// A position update, as the SDK's estimator sees one: into the window, the old ones out.
void sample(Dev& d, std::int64_t now, const double p[3]) {
  d.window.push_back({now, {p[0], p[1], p[2]}});
  while (!d.window.empty() && now - d.window.front().first > std::int64_t(d.window_ms) * 1'000'000)
    d.window.pop_front();
}

double clamp_to(double* v, int n, double limit) {
  double s = 0;
  for (int i = 0; i < n; ++i) s += v[i] * v[i];
  s = std::sqrt(s);
  if (limit >= 0 && s > limit) {
    for (int i = 0; i < n; ++i) v[i] *= s > 0 ? limit / s : 0;
    return s;
  }
  return s;
}

int set_all(const char* name, double fx, double fy, double fz, double tx, double ty, double tz,
            double fg, char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter(name, id, lock);
  if (!d) return -1;
  const std::int64_t now = now_ns();
  watchdog_check(*d, now);
  d->last_set_ns = now;
  double f[3] = {fx, fy, fz}, t[3] = {tx, ty, tz}, g[1] = {fg};
  const bool asked =
      std::sqrt(fx * fx + fy * fy + fz * fz + tx * tx + ty * ty + tz * tz + fg * fg) > 0;
  if (!(d->initialised && d->forces_enabled)) {
    if (asked) ++d->refused;
    d->applied.insert(d->applied.end(), {0, 0, 0, 0, 0, 0, 0});
    return 0;
  }
  int rc = 0;
  if (d->max_force >= 0) clamp_to(f, 3, d->max_force);
  if (clamp_to(f, 3, d->hw_force) > d->hw_force) rc = kMotorSaturated;
  if (!d->active_wrist()) t[0] = t[1] = t[2] = 0;
  if (d->max_torque >= 0) clamp_to(t, 3, d->max_torque);
  if (clamp_to(t, 3, d->hw_torque) > d->hw_torque) rc = kMotorSaturated;
  if (!d->has_gripper()) g[0] = 0;
  if (d->max_gripper >= 0) clamp_to(g, 1, d->max_gripper);
  if (clamp_to(g, 1, d->hw_gripper) > d->hw_gripper) rc = kMotorSaturated;
  if (rc == kMotorSaturated) ++d->saturated;
  d->applied.insert(d->applied.end(), {f[0], f[1], f[2], t[0], t[1], t[2], g[0]});
  return rc;
}

const char* error_text(int e) {
  switch (e) {
    case kNoError:
      return "no error";
    case kCom:
      return "communication error between the host and the haptic device";
    case kNoDevice:
      return "no compatible haptic device found";
    case kTimeout:
      return "timeout";
    case kInvalidIndex:
      return "invalid device index";
    case kNotEnabled:
      return "feature not enabled";
    default:
      return "undocumented error";
  }
}

}  // namespace

extern "C" {

// --- the DHD API subset palpate uses (signatures as the SDK documents them).
int dhdErrorGetLast() {
  std::lock_guard<std::mutex> lock(fake().m);
  return fake().error;
}
const char* dhdErrorGetLastStr() {
  std::lock_guard<std::mutex> lock(fake().m);
  return error_text(fake().error);
}
void dhdGetSDKVersion(int* major, int* minor, int* release, int* revision) {
  *major = 3, *minor = 17, *release = 0, *revision = 0;  // a fake's
}
int dhdGetDeviceCount() {
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  ++f.calls["dhdGetDeviceCount"];
  int n = 0;
  for (const Dev& d : f.devs) n += d.present && d.fault != kUnplugged;
  f.error = n ? kNoError : kNoDevice;
  return n;
}
static int open_at(int index) {
  Fake& f = fake();
  Dev& d = f.devs[size_t(index)];
  d.open = true;
  d.opened_ns = now_ns();
  d.window.clear();
  f.current = index;
  f.error = kNoError;
  return index;
}
int dhdOpenID(char index) {
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  ++f.calls["dhdOpenID"];
  f.first.emplace("dhdOpenID", f.seq++);
  if (index < 0 || index >= int(f.devs.size()) || !f.devs[size_t(index)].present) {
    f.error = f.devs.empty() ? kNoDevice : kInvalidIndex;
    return -1;
  }
  return open_at(index);
}
int dhdOpenSerial(int serial) {
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  ++f.calls["dhdOpenSerial"];
  f.first.emplace("dhdOpenSerial", f.seq++);
  for (size_t i = 0; i < f.devs.size(); ++i)
    if (f.devs[i].serial == serial && f.devs[i].present) return open_at(int(i));
  f.error = kNoDevice;
  return -1;
}
int dhdClose(char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("dhdClose", id, lock);
  if (!d) return -1;
  d->open = false;
  d->forces_enabled = false;
  return 0;
}
int dhdStop(char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("dhdStop", id, lock);
  if (!d) return -1;
  d->forces_enabled = false;
  return 0;
}
int dhdEnableForce(unsigned char on, char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("dhdEnableForce", id, lock);
  if (!d) return -1;
  d->forces_enabled = on != 0;
  d->last_set_ns = 0;
  return 0;
}
int dhdGetSystemType(char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("dhdGetSystemType", id, lock);
  return d ? d->type : -1;
}
const char* dhdGetSystemName(char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("dhdGetSystemName", id, lock);
  if (!d) return nullptr;
  switch (d->type) {
    case 33:
      return "omega.3";
    case 34:
      return "omega.6";
    case 35:
      return "omega.7";
    case 60:
      return "Falcon";
    case 63:
      return "delta.3";
    case 64:
      return "delta.6";
    case 104:
      return "sigma.7";
    default:
      return "unknown";
  }
}
int dhdGetSerialNumber(unsigned short* sn, char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("dhdGetSerialNumber", id, lock);
  if (!d) return -1;
  *sn = static_cast<unsigned short>(d->serial);
  return 0;
}
bool dhdHasWrist(char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("dhdHasWrist", id, lock);
  return d && d->has_wrist();
}
bool dhdHasActiveWrist(char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("dhdHasActiveWrist", id, lock);
  return d && d->active_wrist();
}
bool dhdHasGripper(char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("dhdHasGripper", id, lock);
  return d && d->has_gripper();
}
bool dhdHasActiveGripper(char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("dhdHasActiveGripper", id, lock);
  return d && d->has_gripper();
}
int dhdEmulateButton(unsigned char on, char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("dhdEmulateButton", id, lock);
  if (!d) return -1;
  d->emulate_button = on != 0;
  return 0;
}
int dhdSetGravityCompensation(int on, char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("dhdSetGravityCompensation", id, lock);
  if (!d) return -1;
  d->gravity = on != 0;
  return 0;
}
int dhdSetWatchdog(unsigned char units, char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("dhdSetWatchdog", id, lock);
  if (!d) return -1;
  d->watchdog = units;
  return 0;
}
int dhdGetVelocityThreshold(unsigned int* v, char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("dhdGetVelocityThreshold", id, lock);
  if (!d) return -1;
  *v = d->velocity_threshold;
  return 0;
}
// Present so that a test can see it is never called (palpate keeps the threshold on).
int dhdSetVelocityThreshold(unsigned int v, char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("dhdSetVelocityThreshold", id, lock);
  if (!d) return -1;
  d->velocity_threshold = v;
  return 0;
}
int dhdEnableExpertMode() {
  std::lock_guard<std::mutex> lock(fake().m);
  ++fake().calls["dhdEnableExpertMode"];
  return 0;
}
double dhdGetMaxForce(char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("dhdGetMaxForce", id, lock);
  return d ? d->max_force : -1.0;
}
double dhdGetMaxTorque(char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("dhdGetMaxTorque", id, lock);
  return d ? d->max_torque : -1.0;
}
double dhdGetMaxGripperForce(char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("dhdGetMaxGripperForce", id, lock);
  return d ? d->max_gripper : -1.0;
}
int dhdSetMaxForce(double v, char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("dhdSetMaxForce", id, lock);
  if (!d) return -1;
  d->max_force = v;
  return 0;
}
int dhdSetMaxTorque(double v, char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("dhdSetMaxTorque", id, lock);
  if (!d) return -1;
  d->max_torque = v;
  return 0;
}
int dhdSetMaxGripperForce(double v, char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("dhdSetMaxGripperForce", id, lock);
  if (!d) return -1;
  d->max_gripper = v;
  return 0;
}
int dhdGetPosition(double* px, double* py, double* pz, char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("dhdGetPosition", id, lock);
  if (!d) return -1;
  const std::int64_t now = now_ns();
  watchdog_check(*d, now);
  if (d->timeguard_us > 0 && d->last_get_ns > 0 &&
      now - d->last_get_ns < std::int64_t(d->timeguard_us) * 1000) {
    *px = d->cached[0], *py = d->cached[1], *pz = d->cached[2];
    return kTimeguard;  // too soon: the last value, as the SDK's time guard gives it
  }
  double p[3];
  position_at(*d, now, p);
  sample(*d, now, p);
  d->last_get_ns = now;
  std::memcpy(d->cached, p, sizeof p);
  *px = p[0], *py = p[1], *pz = p[2];
  return 0;
}
int dhdGetLinearVelocity(double* vx, double* vy, double* vz, char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("dhdGetLinearVelocity", id, lock);
  if (!d) return -1;
  const std::int64_t now = now_ns();
  double p[3];
  position_at(*d, now, p);
  sample(*d, now, p);
  if (d->window.size() < 2 || d->window.back().first <= d->window.front().first) {
    fake().error = kTimeout;  // fewer than two positions in the window
    return -1;
  }
  const auto& a = d->window.front();
  const auto& b = d->window.back();
  const double dt = double(b.first - a.first) * 1e-9;
  *vx = (b.second[0] - a.second[0]) / dt, *vy = (b.second[1] - a.second[1]) / dt,
  *vz = (b.second[2] - a.second[2]) / dt;
  return 0;
}
int dhdGetOrientationFrame(double m[3][3], char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("dhdGetOrientationFrame", id, lock);
  if (!d) return -1;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) m[i][j] = d->has_wrist() ? d->rot[i * 3 + j] : double(i == j);
  return 0;
}
int dhdGetGripperAngleRad(double* a, char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("dhdGetGripperAngleRad", id, lock);
  if (!d) return -1;
  *a = d->has_gripper() ? d->gripper_angle : 0.0;
  return 0;
}
unsigned int dhdGetButtonMask(char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("dhdGetButtonMask", id, lock);
  if (!d) return 0;
  // A closed gripper (under 0.1 rad) is button 1 where the emulation is on.
  return d->buttons | (d->emulate_button && d->has_gripper() && d->gripper_angle < 0.1 ? 1u : 0u);
}
int dhdSetForce(double fx, double fy, double fz, char id) {
  return set_all("dhdSetForce", fx, fy, fz, 0, 0, 0, 0, id);
}
int dhdSetForceAndTorque(double fx, double fy, double fz, double tx, double ty, double tz,
                         char id) {
  return set_all("dhdSetForceAndTorque", fx, fy, fz, tx, ty, tz, 0, id);
}
int dhdSetForceAndTorqueAndGripperForce(double fx, double fy, double fz, double tx, double ty,
                                        double tz, double fg, char id) {
  return set_all("dhdSetForceAndTorqueAndGripperForce", fx, fy, fz, tx, ty, tz, fg, id);
}

// --- DRD: calibration.
int drdOpenID(char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("drdOpenID", id, lock);
  if (!d) return -1;
  d->drd_open = true;
  return id;
}
bool drdIsInitialized(char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("drdIsInitialized", id, lock);
  return d && d->initialised;
}
int drdAutoInit(char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("drdAutoInit", id, lock);
  if (!d) return -1;
  if (d->auto_init_fails) {
    fake().error = kTimeout;
    return -1;
  }
  d->initialised = true;
  return 0;
}
int drdStop(bool, char id) {
  std::unique_lock<std::mutex> lock;
  return enter("drdStop", id, lock) ? 0 : -1;
}
int drdClose(char id) {
  std::unique_lock<std::mutex> lock;
  Dev* d = enter("drdClose", id, lock);
  if (!d) return -1;
  d->drd_open = false;
  return 0;
}

// --- control and inspection, for the tests.
// `devices` omega.7s, serials 1001.., calibrated, no trajectory; every record cleared.
void fake_dhd_reset(int devices) {
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  f.devs.assign(size_t(std::max(0, devices)), Dev{});
  for (size_t i = 0; i < f.devs.size(); ++i) f.devs[i].serial = 1001 + int(i);
  f.calls.clear();
  f.first.clear();
  f.seq = 0;
  f.error = kNoError;
  f.current = -1;
}
// A device's type (DHD_DEVICE_*), serial number and whether it is calibrated; the motors' limits
// follow the type (N, N·m, N): omega 12 / 0 / 8 (a gripper on the .7), sigma.7 20 / 0.4 / 8,
// delta 20 (0.2 N·m on the .6), Falcon 8.9.
void fake_dhd_set_device(int i, int type, int serial, int calibrated) {
  std::lock_guard<std::mutex> lock(fake().m);
  Dev& d = fake().devs[size_t(i)];
  d.type = type, d.serial = serial, d.initialised = calibrated != 0;
  d.hw_force = type >= 104 || type == 63 || type == 64 ? 20.0 : type == 60 ? 8.9 : 12.0;
  d.hw_torque = type >= 104 && type <= 107 ? 0.4 : type == 64 ? 0.2 : 0.0;
  d.hw_gripper = 8.0;
}
// What the motors give (N, N·m, N): more is scaled down and the set call returns
// DHD_MOTOR_SATURATED.
void fake_dhd_set_motor_limits(int i, double force, double torque, double gripper) {
  std::lock_guard<std::mutex> lock(fake().m);
  Dev& d = fake().devs[size_t(i)];
  d.hw_force = force, d.hw_torque = torque, d.hw_gripper = gripper;
}
// Read FAKE_DHD_DEVICES and FAKE_DHD_POSES again, as a new process would.
void fake_dhd_reload_environment() {
  Fake& f = fake();
  std::lock_guard<std::mutex> lock(f.m);
  f.from_environment();
  f.calls.clear();
  f.first.clear();
}
void fake_dhd_set_trajectory(int i, const double* txyz, int rows) {
  std::lock_guard<std::mutex> lock(fake().m);
  fake().devs[size_t(i)].traj.assign(txyz, txyz + 4 * rows);
}
void fake_dhd_set_rotation(int i, const double* row_major) {
  std::lock_guard<std::mutex> lock(fake().m);
  std::memcpy(fake().devs[size_t(i)].rot, row_major, 9 * sizeof(double));
}
void fake_dhd_set_gripper(int i, double angle, unsigned buttons) {
  std::lock_guard<std::mutex> lock(fake().m);
  fake().devs[size_t(i)].gripper_angle = angle;
  fake().devs[size_t(i)].buttons = buttons;
}
// A software force limit another program left in the SDK (dhdGetMaxForce's answer).
void fake_dhd_set_sdk_max_force(int i, double newtons) {
  std::lock_guard<std::mutex> lock(fake().m);
  fake().devs[size_t(i)].max_force = newtons;
}
void fake_dhd_set_timeguard(int i, int us) {
  std::lock_guard<std::mutex> lock(fake().m);
  fake().devs[size_t(i)].timeguard_us = us;
}
void fake_dhd_set_velocity_threshold(int i, unsigned v) {
  std::lock_guard<std::mutex> lock(fake().m);
  fake().devs[size_t(i)].velocity_threshold = v;
}
void fake_dhd_set_auto_init_fails(int i, int on) {
  std::lock_guard<std::mutex> lock(fake().m);
  fake().devs[size_t(i)].auto_init_fails = on != 0;
}
// 0: answers; 1: stops answering (every call blocks until cleared); 2: every call fails (a USB
// error); 3: unplugged (calls fail, the device is gone from the count, its forces off).
void fake_dhd_fault(int i, int kind) {
  std::lock_guard<std::mutex> lock(fake().m);
  Dev& d = fake().devs[size_t(i)];
  d.fault = kind;
  if (kind == kUnplugged) d.forces_enabled = false;
}
int fake_dhd_calls(const char* name) {
  std::lock_guard<std::mutex> lock(fake().m);
  auto it = fake().calls.find(name);
  return it == fake().calls.end() ? 0 : it->second;
}
// When a function was first called, in the order of all calls since the reset; -1 = never.
int fake_dhd_first_call(const char* name) {
  std::lock_guard<std::mutex> lock(fake().m);
  auto it = fake().first.find(name);
  return it == fake().first.end() ? -1 : it->second;
}
int fake_dhd_watchdog(int i) {
  std::lock_guard<std::mutex> lock(fake().m);
  return fake().devs[size_t(i)].watchdog;
}
unsigned fake_dhd_velocity_threshold(int i) {
  std::lock_guard<std::mutex> lock(fake().m);
  return fake().devs[size_t(i)].velocity_threshold;
}
// How often the watchdog turned forces off (evaluated now as well).
int fake_dhd_watchdog_trips(int i) {
  std::lock_guard<std::mutex> lock(fake().m);
  Dev& d = fake().devs[size_t(i)];
  watchdog_check(d, now_ns());
  return d.watchdog_trips;
}
int fake_dhd_forces_enabled(int i) {
  std::lock_guard<std::mutex> lock(fake().m);
  return fake().devs[size_t(i)].forces_enabled;
}
int fake_dhd_refused(int i) {
  std::lock_guard<std::mutex> lock(fake().m);
  return fake().devs[size_t(i)].refused;
}
int fake_dhd_saturated(int i) {
  std::lock_guard<std::mutex> lock(fake().m);
  return fake().devs[size_t(i)].saturated;
}
int fake_dhd_emulates_button(int i) {
  std::lock_guard<std::mutex> lock(fake().m);
  return fake().devs[size_t(i)].emulate_button;
}
// Copy up to `max` records (fx, fy, fz, tx, ty, tz, fg: what reached the motors) into out;
// returns how many there are in all.
int fake_dhd_forces(int i, double* out, int max) {
  std::lock_guard<std::mutex> lock(fake().m);
  const std::vector<double>& a = fake().devs[size_t(i)].applied;
  const int n = int(a.size() / 7);
  if (n > 0 && max > 0)  // (memcpy from an empty vector's null data() is undefined, even for 0 bytes)
    std::memcpy(out, a.data(), sizeof(double) * 7 * size_t(std::min(n, max)));
  return n;
}

}  // extern "C"
