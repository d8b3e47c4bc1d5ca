// test_forcedimension.cpp — the forcedimension backend against a fake libdhd.so.3 built by the
// tests (tests/fake_dhd): missing library and device, opening by index and serial, the device's
// limits, calibration before forces, the SDK's non-error returns, its watchdog and velocity
// threshold, torque and gripper force, and faults mid-run through the haptic loop beside a scripted
// tool.
#include <palpate/device.h>
#include <palpate/haptics.h>
#include <palpate/scene.h>

#include "fake_dhd/fake_dhd_client.h"
#include "sanitized.h"
#include "haptics/doubles.h"

#include <gtest/gtest.h>

#include <dlfcn.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

namespace fs = std::filesystem;
using palpate::Quat;
using palpate::Vec3;
using namespace palpate::test;

namespace {

bool has(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// Wait (at most 2 s) until the servo has delivered a pose; false if it never did.
bool first_pose(palpate::Device& d, palpate::DeviceState& s) {
  for (int i = 0; i < 2000; ++i) {
    if (d.read(0.0, s)) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return false;
}

void press_for(palpate::Device& d, const Vec3& f, const Vec3& t, double grip, int ms) {
  for (int i = 0; i < ms; ++i) {
    d.write(f, t);
    d.write_gripper(grip);
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

// The same until the fake's motors have had `frames` more servo frames (a sanitizer's build runs
// the servo slower than one frame a millisecond; 10 s at most).
void press_frames(palpate::Device& d, FakeDhd& dhd, const Vec3& f, const Vec3& t, double grip, int frames) {
  double none = 0;
  const int start = dhd.forces(0, &none, 0);
  for (int i = 0; i < 10000 && dhd.forces(0, &none, 0) < start + frames; ++i) {
    d.write(f, t);
    d.write_gripper(grip);
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

// Every record the fake's motors got: finite, within the limits, and changing per servo frame by
// at most the rate limit (the torque and gripper force in proportion to their maxima).
void check_sent(const std::vector<DhdSent>& sent, const palpate::DeviceLimits& lim) {
  const double step = lim.max_force_rate * 1e-3, fraction = step / lim.max_force;
  DhdSent last;
  for (size_t i = 0; i < sent.size(); ++i) {
    const DhdSent& s = sent[i];
    ASSERT_TRUE(s.force.allFinite() && s.torque.allFinite() && std::isfinite(s.gripper)) << i;
    ASSERT_LE(s.force.norm(), lim.max_force + 1e-12) << i;
    ASSERT_LE(s.torque.norm(), lim.max_torque + 1e-12) << i;
    ASSERT_LE(std::abs(s.gripper), lim.max_gripper_force + 1e-12) << i;
    ASSERT_LE((s.force - last.force).norm(), step + 1e-12) << "frame " << i;
    ASSERT_LE((s.torque - last.torque).norm(), lim.max_torque * fraction + 1e-12) << "frame " << i;
    ASSERT_LE(std::abs(s.gripper - last.gripper), lim.max_gripper_force * fraction + 1e-12)
        << "frame " << i;
    last = s;
  }
}

}  // namespace

TEST(ForceDimension, MissingLibraryErrorSaysWhatToDo) {
  auto d = palpate::open_forcedimension("/nonexistent/libdhd.so.3", 0, 0, {});
  ASSERT_FALSE(d.ok());
  std::string m = d.error().message;
  EXPECT_TRUE(has(m, "forcedimension: cannot load the DHD library '/nonexistent/libdhd.so.3'"))
      << m;
  EXPECT_TRUE(has(m, "install the Force Dimension SDK")) << m;
  EXPECT_TRUE(has(m, "device.dhd_library")) << m;
  EXPECT_TRUE(has(m, "device: {kind: scripted}")) << m;
  // The default: libdhd.so.3, then libdhd.so (not installed where the tests run).
  if (void* real = ::dlopen("libdhd.so.3", RTLD_NOW | RTLD_NOLOAD);
      !real && !::dlopen("libdhd.so", RTLD_NOW | RTLD_NOLOAD)) {
    d = palpate::open_forcedimension("", 0, 0, {});
    if (!d.ok() && has(d.error().message, "cannot load")) {
      m = d.error().message;
      EXPECT_TRUE(has(m, "(libdhd.so.3, libdhd.so)")) << m;
      EXPECT_TRUE(has(m, "libdhd.so.3: ")) << m;  // what each name gave
      EXPECT_TRUE(has(m, "; libdhd.so: ")) << m;
    }
  }
  // A library that is not DHD: libc has none of its functions.
  d = palpate::open_forcedimension("libc.so.6", 0, 0, {});
  ASSERT_FALSE(d.ok());
  EXPECT_TRUE(has(d.error().message,
                  "has no function dhdGetDeviceCount: it is not Force Dimension's DHD library"))
      << d.error().message;
}

TEST(ForceDimension, NoDeviceIsAClearErrorWithTheUsbAccessHint) {
  FakeDhd dhd;
  ASSERT_NE(dhd.lib, nullptr) << ::dlerror();
  dhd.reset(0);
  auto d = palpate::open_forcedimension(PALPATE_FAKE_DHD, 0, 0, {});
  ASSERT_FALSE(d.ok());
  std::string m = d.error().message;
  EXPECT_TRUE(has(
      m,
      "forcedimension: no Force Dimension device found (DHD: no compatible haptic device found)"))
      << m;
  EXPECT_TRUE(has(m, "udev rule")) << m;
  EXPECT_TRUE(has(m, "run as root")) << m;
  EXPECT_TRUE(has(m, "kind: scripted")) << m;
  EXPECT_EQ(dhd.calls("dhdEnableForce"), 0);

  dhd.reset(1);
  d = palpate::open_forcedimension(PALPATE_FAKE_DHD, 2, 0, {});
  ASSERT_FALSE(d.ok());
  EXPECT_TRUE(
      has(d.error().message, "device.dhd_index 2 asked for, but 1 device is connected (index 0)"))
      << d.error().message;

  dhd.reset(2);
  d = palpate::open_forcedimension(PALPATE_FAKE_DHD, 0, 4242, {});
  ASSERT_FALSE(d.ok());
  m = d.error().message;
  EXPECT_TRUE(has(
      m,
      "cannot open the device with serial 4242 (DHD: no compatible haptic device found; 2 devices "
      "connected): check the serial number"))
      << m;
  EXPECT_TRUE(has(m, "udev rule")) << m;
  EXPECT_EQ(dhd.calls("dhdEnableForce"), 0);
}

TEST(ForceDimension, OpensByIndexAndBySerialAndReadsTheDevicesLimits) {
  FakeDhd dhd;
  ASSERT_NE(dhd.lib, nullptr) << ::dlerror();
  dhd.reset(2);
  dhd.set_device(1, kSigma7, 5555, 1);
  palpate::DeviceLimits scene;  // 3.3 N, 200 N/s, 1000 N/m, 2 N·s/m
  scene.max_force = 50.0;       // a scene's most: the device's own is lower
  {
    auto d = palpate::open_forcedimension(PALPATE_FAKE_DHD, 1, 0, scene);
    ASSERT_TRUE(d.ok()) << d.error().message;
    const palpate::DeviceLimits& l = (*d)->limits();
    EXPECT_EQ(l.max_force, 12.0);  // sigma.7
    EXPECT_TRUE(l.has_torque);
    EXPECT_EQ(l.max_torque, 0.2);
    EXPECT_EQ(l.max_gripper_force, 8.0);
    EXPECT_EQ(l.stiffness, 1000.0);  // the scene's, lower than the device's nominal
    EXPECT_EQ(l.damping, 2.0);
    EXPECT_NEAR(l.workspace_max.x(), 0.095, 1e-12);
    EXPECT_NEAR(l.workspace_max.z(), 0.065, 1e-12);
    EXPECT_EQ(dhd.forces_enabled(1), 1);
    EXPECT_EQ(dhd.forces_enabled(0), 0);
    EXPECT_EQ(dhd.sdk_max_force(1), 12.0);  // handed to the SDK too
  }
  EXPECT_EQ(dhd.calls("dhdOpenID"), 1);
  EXPECT_EQ(dhd.calls("dhdOpenSerial"), 0);
  EXPECT_EQ(dhd.calls("dhdClose"), 1);
  EXPECT_EQ(dhd.forces_enabled(1), 0);  // off at close

  // By serial: the sigma.7, then the omega.7 (no active wrist: no torque; a gripper).
  dhd.reset(2);
  dhd.set_device(1, kSigma7, 5555, 1);
  {
    auto d = palpate::open_forcedimension(PALPATE_FAKE_DHD, 0, 5555, scene);
    ASSERT_TRUE(d.ok()) << d.error().message;
    EXPECT_TRUE((*d)->limits().has_torque);
    EXPECT_EQ(dhd.forces_enabled(1), 1);
  }
  EXPECT_EQ(dhd.calls("dhdOpenSerial"), 1);
  EXPECT_EQ(dhd.calls("dhdOpenID"), 0);
  {
    auto d = palpate::open_forcedimension(PALPATE_FAKE_DHD, 0, 1001, {});
    ASSERT_TRUE(d.ok()) << d.error().message;
    const palpate::DeviceLimits& l = (*d)->limits();
    EXPECT_EQ(l.max_force, 3.3);  // the scene's, lower than the omega.7's 12 N
    EXPECT_FALSE(l.has_torque);
    EXPECT_EQ(l.max_torque, 0.0);
    EXPECT_EQ(l.max_gripper_force, 8.0);
    EXPECT_EQ(dhd.emulates_button(0), 1);  // its closed gripper is button 1
  }
  // A Falcon: 8 N, no wrist, no gripper; a software limit left in the SDK lowers a device's.
  for (const auto& [type, sdk_limit, want] : {std::tuple<int, double, double>{kFalcon, -1.0, 8.0},
                                              std::tuple<int, double, double>{kDelta3, -1.0, 20.0},
                                              std::tuple<int, double, double>{kOmega3, 5.0, 5.0}}) {
    dhd.reset(1);
    dhd.set_device(0, type, 77, 1);
    dhd.set_sdk_max_force(0, sdk_limit);
    auto d = palpate::open_forcedimension(PALPATE_FAKE_DHD, 0, 0, scene);
    ASSERT_TRUE(d.ok()) << d.error().message;
    EXPECT_EQ((*d)->limits().max_force, want) << type;
    EXPECT_FALSE((*d)->limits().has_torque) << type;
    EXPECT_EQ((*d)->limits().max_gripper_force, 0.0) << type;
  }
}

// Forces are enabled only once the device is calibrated: an uncalibrated one is initialised by
// DRD first (drdAutoInit), and one that cannot be is refused with its forces never enabled.
TEST(ForceDimension, CalibrationComesBeforeAnyForce) {
  FakeDhd dhd;
  ASSERT_NE(dhd.lib, nullptr) << ::dlerror();
  dhd.reset(1);
  {
    auto d = palpate::open_forcedimension(PALPATE_FAKE_DHD, 0, 0, {});
    ASSERT_TRUE(d.ok()) << d.error().message;
    EXPECT_EQ((*d)->calibration(), palpate::Calibration::ok);
  }
  EXPECT_EQ(dhd.calls("drdAutoInit"), 0);
  EXPECT_GE(dhd.calls("drdIsInitialized"), 1);

  dhd.reset(1);
  dhd.set_device(0, kOmega7, 1001, /*calibrated=*/0);
  {
    auto d = palpate::open_forcedimension(PALPATE_FAKE_DHD, 0, 0, {});
    ASSERT_TRUE(d.ok()) << d.error().message;
    EXPECT_EQ((*d)->calibration(), palpate::Calibration::updated);
    press_for(**d, Vec3(0, 1, 0), Vec3::Zero(), 0, 30);
  }
  EXPECT_EQ(dhd.calls("drdAutoInit"), 1);
  ASSERT_GE(dhd.first_call("dhdEnableForce"), 0);
  EXPECT_LT(dhd.first_call("drdAutoInit"), dhd.first_call("dhdEnableForce"));
  EXPECT_LT(dhd.first_call("dhdEnableForce"),
            dhd.first_call("dhdSetForceAndTorqueAndGripperForce"));
  EXPECT_EQ(dhd.refused(0), 0);  // no force was asked of it before it could take one

  dhd.reset(1);
  dhd.set_device(0, kOmega7, 1001, 0);
  dhd.set_auto_init_fails(0, 1);
  auto d = palpate::open_forcedimension(PALPATE_FAKE_DHD, 0, 0, {});
  ASSERT_FALSE(d.ok());
  const std::string& m = d.error().message;
  EXPECT_TRUE(has(m,
                  "forcedimension: the omega.7 (index 0) is not calibrated and drdAutoInit could "
                  "not calibrate it "
                  "(timeout): clear the space around its arm"))
      << m;
  EXPECT_EQ(dhd.calls("dhdEnableForce"), 0);
  EXPECT_EQ(dhd.calls("dhdSetForceAndTorqueAndGripperForce"), 0);
  EXPECT_EQ(dhd.calls("dhdClose"), 1);
}

// The SDK's positive returns are not errors: DHD_TIMEGUARD (a read sooner than its time guard: the
// last value) and DHD_MOTOR_SATURATED (the force was more than the motors give: scaled down).
TEST(ForceDimension, TimeguardAndMotorSaturationAreNotErrors) {
  FakeDhd dhd;
  ASSERT_NE(dhd.lib, nullptr) << ::dlerror();
  dhd.reset(1);
  dhd.set_timeguard(0, 5000);              // 5 ms: four reads in five give DHD_TIMEGUARD
  dhd.set_motor_limits(0, 1.0, 0.0, 8.0);  // the motors give 1 N: 3 N saturates them
  auto d = palpate::open_forcedimension(PALPATE_FAKE_DHD, 0, 0, {});
  ASSERT_TRUE(d.ok()) << d.error().message;
  palpate::DeviceState s;
  ASSERT_TRUE(first_pose(**d, s));
  for (int i = 0; i < 200; ++i) {
    (*d)->write(Vec3(0, 3.0, 0), Vec3::Zero());
    ASSERT_TRUE((*d)->read(0.0, s)) << i;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  EXPECT_GT(dhd.saturated(0), 50);
  EXPECT_LE(dhd.sent(0).back().force.norm(), 1.0 + 1e-12);
  EXPECT_GT(dhd.calls("dhdGetPosition"), 100);
}

// The SDK's safety cut-offs stay on: the watchdog is set (never to 0) and turns the forces off in
// the firmware when the servo stops sending; the velocity threshold is never touched (expert mode
// never entered), and a device found with it off is refused. The velocity is the SDK's windowed
// estimate.
TEST(ForceDimension, WatchdogAndVelocityThresholdStayOn) {
  FakeDhd dhd;
  ASSERT_NE(dhd.lib, nullptr) << ::dlerror();
  dhd.reset(1);
  const double ramp[] = {0.0, 0.0, -0.01, 0.0, 10.0, 0.0, 0.49, 0.0};  // 0.05 m/s along y for 10 s
  dhd.set_trajectory(0, ramp, 2);
  {
    auto d = palpate::open_forcedimension(PALPATE_FAKE_DHD, 0, 0, {});
    ASSERT_TRUE(d.ok()) << d.error().message;
    EXPECT_EQ(dhd.watchdog(0), 255);  // 31.9 ms
    palpate::DeviceState s;
    ASSERT_TRUE(first_pose(**d, s));
    std::this_thread::sleep_for(std::chrono::milliseconds(60));
    ASSERT_TRUE((*d)->read(0.0, s));
    EXPECT_NEAR(s.velocity.y(), 0.05, 1e-9);
    EXPECT_NEAR(s.velocity.x(), 0.0, 1e-12);
    EXPECT_EQ(dhd.watchdog_trips(0), 0);
    // The device stops answering for 100 ms: the servo is stuck in the SDK, no force reaches the
    // device, and its watchdog turns the forces off; read() fails meanwhile and after (the device's
    // forces are off: it has failed for this run).
    dhd.fault(0, kFaultStall);
    std::this_thread::sleep_for(std::chrono::milliseconds(30));
    EXPECT_FALSE((*d)->read(0.0, s));
    std::this_thread::sleep_for(std::chrono::milliseconds(70));
    EXPECT_GE(dhd.watchdog_trips(0), 1);
    EXPECT_EQ(dhd.forces_enabled(0), 0);
    dhd.fault(0, kFaultNone);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    EXPECT_FALSE((*d)->read(0.0, s));
  }
  EXPECT_EQ(dhd.calls("dhdSetVelocityThreshold"), 0);
  EXPECT_EQ(dhd.calls("dhdEnableExpertMode"), 0);
  EXPECT_EQ(dhd.velocity_threshold(0), 4u);
  EXPECT_EQ(dhd.first_call("dhdSetWatchdog") >= 0, true);

  dhd.reset(1);
  dhd.set_velocity_threshold(0, 0);  // left off by another program
  auto d = palpate::open_forcedimension(PALPATE_FAKE_DHD, 0, 0, {});
  ASSERT_FALSE(d.ok());
  EXPECT_TRUE(has(d.error().message, "has its velocity threshold off (0)")) << d.error().message;
  EXPECT_EQ(dhd.calls("dhdEnableForce"), 0);
}

// Torque and gripper force reach a device that has them, through the backend's guard: clamped to
// the device's maxima, rate-limited in proportion to the force's rate, NaN made zero, and ramped to
// zero at the end; a device without them gets zero. The wrist's rotation and the gripper's angle
// come back in the pose; a closed gripper is button 1.
TEST(ForceDimension, TorqueAndGripperAreRenderedAndClamped) {
  // Under ThreadSanitizer the backend's servo thread is held past the SDK's 32 ms watchdog now and
  // then (measured 2026-11-28: the forces' ramps stopped short, the watchdog tripped), which this
  // test's exact end values cannot take; its threads are checked there by the other tests here.
  if (kSanitized && !kAddressSanitized) GTEST_SKIP() << "servo timing under ThreadSanitizer";
  FakeDhd dhd;
  ASSERT_NE(dhd.lib, nullptr) << ::dlerror();
  dhd.reset(1);
  dhd.set_device(0, kSigma7, 1001, 1);
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.4, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  double row_major[9];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) row_major[i * 3 + j] = r(i, j);
  dhd.set_rotation(0, row_major);
  dhd.set_gripper(0, 0.05, 0);  // closed
  palpate::DeviceLimits lim;
  {
    auto d = palpate::open_forcedimension(PALPATE_FAKE_DHD, 0, 0, {});
    ASSERT_TRUE(d.ok()) << d.error().message;
    lim = (*d)->limits();
    palpate::DeviceState s;
    ASSERT_TRUE(first_pose(**d, s));
    EXPECT_LT(s.orientation.angularDistance(Quat(r)), 1e-9);
    EXPECT_NEAR(s.gripper_angle, 0.05, 1e-15);
    EXPECT_EQ(s.buttons & 1u, 1u);
    press_frames(**d, dhd, Vec3(0, 1.0, 0), Vec3(0, 0, 5.0), 20.0, 120);  // 5 N·m and 20 N asked
    DhdSent last = dhd.sent(0).back();
    EXPECT_NEAR(last.torque.z(), 0.2, 1e-9);
    EXPECT_NEAR(last.gripper, 8.0, 1e-9);
    EXPECT_NEAR(last.force.y(), 1.0, 1e-9);
    press_frames(**d, dhd, Vec3(0, 1.0, 0), Vec3(std::nan(""), 0, 0), -20.0, 60);  // NaN torque: zero, ramped
    last = dhd.sent(0).back();
    EXPECT_EQ(last.torque, Vec3::Zero());
    EXPECT_NEAR(last.gripper, -8.0, 1e-9);
  }
  const std::vector<DhdSent> sent = dhd.sent(0);
  ASSERT_GT(sent.size(), 150u);
  check_sent(sent, lim);
  EXPECT_EQ(sent.back().force, Vec3::Zero());
  EXPECT_EQ(sent.back().torque, Vec3::Zero());
  EXPECT_EQ(sent.back().gripper, 0.0);

  // An omega.3: torque and gripper force asked, none sent.
  dhd.reset(1);
  dhd.set_device(0, kOmega3, 1001, 1);
  {
    auto d = palpate::open_forcedimension(PALPATE_FAKE_DHD, 0, 0, {});
    ASSERT_TRUE(d.ok()) << d.error().message;
    press_for(**d, Vec3(0, 1.0, 0), Vec3(0, 0, 5.0), 20.0, 40);
  }
  for (const DhdSent& s : dhd.sent(0)) {
    ASSERT_EQ(s.torque, Vec3::Zero());
    ASSERT_EQ(s.gripper, 0.0);
  }
}

// The scene's keys: a forcedimension device by index or serial (not both: the error names the
// file, line and key), its ranges checked at load, and make_device building it.
TEST(ForceDimension, SceneKeysLoadAndMakeTheDevice) {
  const std::string tissue =
      "tissues:\n  - name: a\n    patch: {width: 0.01, height: 0.01, spacing: 0.001}\n";
  auto s =
      palpate::parse_scene("device:\n  kind: forcedimension\n  dhd_serial: 1002\n  dhd_library: " +
                               std::string(PALPATE_FAKE_DHD) + "\n" + tissue,
                           "fd.yaml");
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->device.kind, "forcedimension");
  EXPECT_EQ(s->device.dhd_serial, 1002);
  EXPECT_EQ(s->device.dhd_index, 0);
  auto both = palpate::parse_scene(
      "device:\n  kind: forcedimension\n  dhd_index: 1\n  dhd_serial: 1002\n" + tissue, "fd.yaml");
  ASSERT_FALSE(both.ok());
  EXPECT_EQ(both.error().message,
            "fd.yaml:4: device.dhd_serial: give either 'dhd_index' or 'dhd_serial', not both (a "
            "serial number "
            "names one device)");
  auto range = palpate::parse_scene("device:\n  kind: forcedimension\n  dhd_index: 99\n" + tissue,
                                    "fd.yaml");
  ASSERT_FALSE(range.ok());
  EXPECT_TRUE(has(range.error().message, "fd.yaml:3: device.dhd_index")) << range.error().message;

  FakeDhd dhd;
  ASSERT_NE(dhd.lib, nullptr) << ::dlerror();
  dhd.reset(2);
  auto d = palpate::make_device(*s);
  ASSERT_TRUE(d.ok()) << d.error().message;
  EXPECT_EQ(dhd.forces_enabled(1), 1);  // serial 1002 is the second device
  EXPECT_EQ(dhd.forces_enabled(0), 0);
}

// A process that is not a test (the palpate command) gives the fake its poses in FAKE_DHD_POSES.
TEST(ForceDimension, TheFakePlaysPosesFromTheEnvironment) {
  FakeDhd dhd;
  ASSERT_NE(dhd.lib, nullptr) << ::dlerror();
  const fs::path csv = fs::temp_directory_path() / "palpate_test_fake_dhd_poses.csv";
  std::ofstream(csv) << "t,x,y,z\n0,0.01,0.02,0.03\n100,0.01,0.02,0.03\n";
  ::setenv("FAKE_DHD_POSES", csv.c_str(), 1);
  dhd.reload_environment();
  ::unsetenv("FAKE_DHD_POSES");
  {
    auto d = palpate::open_forcedimension(PALPATE_FAKE_DHD, 0, 0, {});
    ASSERT_TRUE(d.ok()) << d.error().message;
    palpate::DeviceState s;
    ASSERT_TRUE(first_pose(**d, s));
    EXPECT_LT((s.position - Vec3(0.01, 0.02, 0.03)).norm(), 1e-15);
  }
  dhd.reset(1);
  fs::remove(csv);
}

// --- faults mid-run (issue 38, part 4): the device stops answering, returns errors, or is
// unplugged while the haptic loop runs it as a second tool beside a scripted needle.
namespace {

// A wall under y = 0 the probe presses: 800 N/m.
class Wall final : public palpate::ToolForceModel {
 public:
  Vec3 force(const Vec3& position, const Quat&, double) noexcept override {
    return Vec3(0, 800.0 * std::max(0.0, -position.y()), 0);
  }
};

Vec3 needle_pressing(long tick) {
  return Vec3(0, 0.002 - 1e-5 * double(tick), 0);
}

}  // namespace

TEST(ForceDimension, AFaultMidRunZeroesOnlyThatToolWithinTheRateLimit) {
  FakeDhd dhd;
  ASSERT_NE(dhd.lib, nullptr) << ::dlerror();
  for (const int fault : {kFaultStall, kFaultErrors, kFaultUnplugged}) {
    SCOPED_TRACE("fault " + std::to_string(fault));
    dhd.reset(1);
    const double press[] = {0.0, 0.0, -0.001, 0.0, 10.0, 0.0, -0.001, 0.0};  // 1 mm into the wall
    dhd.set_trajectory(0, press, 2);
    palpate::DeviceLimits asked;
    asked.max_force = 1.5, asked.max_force_rate = 80.0;
    auto d = palpate::open_forcedimension(PALPATE_FAKE_DHD, 0, 0, asked);
    ASSERT_TRUE(d.ok()) << d.error().message;
    const palpate::DeviceLimits lim = (*d)->limits();

    const double dt = 0.001;
    const size_t ticks = 600;
    FunctionDevice needle(needle_pressing, dt, ticks + 1100);
    LinearFloor floor(800.0);
    Wall wall;
    palpate::LoopSettings s;
    s.dt = dt;
    s.max_ticks = ticks;
    s.ramp_in = 0.02;
    s.try_realtime_priority = false;
    s.watchdog.overrun_margin = 1.0;  // a loaded machine's late tick is not what this checks
    s.csv = fs::temp_directory_path() / "palpate_test_forcedimension_fault" / "run.csv";
    fs::create_directories(s.csv.parent_path());
    auto built = palpate::HapticLoop::create(needle, {{&floor, 0.0}}, s,
                                             {{"probe", d->get(), &wall, 0.02, std::nullopt, {}}});
    ASSERT_TRUE(built.ok()) << built.error().message;
    ASSERT_TRUE((*built)->start());
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
    dhd.fault(0, fault);
    (*built)->wait();
    dhd.fault(0, kFaultNone);  // a stalled fake answers again, so that the device can close
    ASSERT_TRUE((*built)->finish_recording());

    // The run's outputs are complete, and the needle went on as if nothing happened.
    const auto& ser = (*built)->series();
    ASSERT_EQ(ser.size(), 23u);
    ASSERT_EQ(ser[0].size(), ticks);
    const palpate::LoopStats st = (*built)->stats();
    EXPECT_EQ(st.safety.device_failed, 0u);
    EXPECT_GT(st.max_force, 0.5);
    ASSERT_GE(needle.written.size(), ticks);
    // The probe: device_failed counted, its force within its limits at every tick and zero from
    // (at most) the stale-pose time plus the ramp down after the fault on.
    EXPECT_GT(st.tools[0].safety.device_failed, 0u);
    Vec3 prev = Vec3::Zero();
    size_t first_zero_after = 0;
    const size_t fault_tick = 250;
    for (size_t k = 0; k < ticks; ++k) {
      const Vec3 f(ser[19][k], ser[20][k], ser[21][k]);
      ASSERT_TRUE(f.allFinite()) << k;
      ASSERT_LE(f.norm(), lim.max_force + 1e-12) << k;
      ASSERT_LE((f - prev).norm(), lim.max_force_rate * dt + 1e-12) << k;
      if (k > fault_tick && !first_zero_after && f == Vec3::Zero()) first_zero_after = k;
      prev = f;
    }
    EXPECT_GT(ser[22][fault_tick - 10], 0.5) << "it pressed before the fault";
    ASSERT_GT(first_zero_after, 0u);
    // 20 ms to notice a silent device (less for an error), then its force down at the rate limit;
    // 150 ms of slack for a loaded machine's scheduling.
    EXPECT_LE(double(first_zero_after - fault_tick) * dt,
              0.020 + lim.max_force / lim.max_force_rate + 0.15);
    for (size_t k = first_zero_after; k < ticks; ++k) ASSERT_EQ(ser[22][k], 0.0) << k;
    built->reset();
    d->reset();
    fs::remove_all(s.csv.parent_path());
  }
}

// `palpate doctor` reports whether the DHD library loads, how many devices it sees, and what to do
// when it sees none (the USB access hint); it opens no device (that could move an arm).
namespace {
std::string run_command(const std::string& cmd) {
  std::string out;
  if (FILE* p = ::popen((cmd + " 2>&1").c_str(), "r")) {
    char buf[4096];
    while (size_t n = std::fread(buf, 1, sizeof buf, p)) out.append(buf, n);
    ::pclose(p);
  }
  return out;
}
}  // namespace

TEST(ForceDimension, DoctorReportsTheLibraryTheDevicesAndTheUsbHint) {
  if (std::string(PALPATE_CLI).empty()) GTEST_SKIP() << "built without the palpate command";
  const std::string doctor =
      std::string(PALPATE_CLI) + " doctor --no-device-open --hd-library /nonexistent/libHD.so";
  std::string out =
      run_command("FAKE_DHD_DEVICES=2 " + doctor + " --dhd-library " + PALPATE_FAKE_DHD);
  EXPECT_TRUE(has(out, std::string("forcedimension found ") + PALPATE_FAKE_DHD + " (SDK 3.17.0-0)"))
      << out;
  EXPECT_TRUE(has(out, "2 Force Dimension devices connected")) << out;
  out = run_command("FAKE_DHD_DEVICES=0 " + doctor + " --dhd-library " + PALPATE_FAKE_DHD);
  EXPECT_TRUE(has(out, "no Force Dimension device found")) << out;
  EXPECT_TRUE(has(out, "udev rule")) << out;
  out = run_command(doctor + " --dhd-library /nonexistent/libdhd.so.3");
  EXPECT_TRUE(has(out, "the DHD library (/nonexistent/libdhd.so.3) not found")) << out;
  EXPECT_TRUE(has(out, "--dhd-library /path/to/libdhd.so.3")) << out;
}
