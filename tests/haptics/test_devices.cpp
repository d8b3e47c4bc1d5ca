// test_devices.cpp — the replay, virtual and openhaptics backends (the last against a fake
// libHD.so built by the tests), and make_device's choice and errors.
#include <palpate/device.h>
#include <palpate/haptics.h>
#include <palpate/run.h>

#include "haptics/doubles.h"
#include "run_csv_rows.h"
#include "haptics/fake_hd_client.h"

#include <gtest/gtest.h>

#include <dlfcn.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

namespace fs = std::filesystem;
using palpate::Vec3;
using namespace palpate::test;

namespace {

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

fs::path write_tmp(const std::string& name, const std::string& text) {
  auto p = fs::temp_directory_path() / ("palpate_test_" + name);
  std::ofstream(p) << text;
  return p;
}

std::vector<std::vector<std::string>> csv_cells(const fs::path& p) {
  std::vector<std::vector<std::string>> out;
  std::istringstream in(slurp(p));
  std::string line;
  while (std::getline(in, line)) {
    out.push_back(palpate::test::csv_cells_of(line));
  }
  return out;
}

std::vector<std::unique_ptr<palpate::Tissue>> one_floor() {
  std::vector<std::unique_ptr<palpate::Tissue>> v;
  v.push_back(std::make_unique<LinearFloor>(400.0));
  return v;
}

}  // namespace

TEST(HapticReplay, ReplaysARecordedRunTickForTick) {
  palpate::SceneDef s;
  s.name = "record";
  s.duration = 0.5;
  s.device.waypoints = {{0.0, Vec3(0.001, 0.002, 0)}, {0.2, Vec3(0, -0.001, 0.002)},
                        {0.5, Vec3(-0.002, -0.003, 0)}};
  const fs::path a = fs::temp_directory_path() / "palpate_test_replay_a";
  const fs::path b = fs::temp_directory_path() / "palpate_test_replay_b";
  palpate::RunOptions o;
  o.plots = false;
  o.out = a;
  auto first = palpate::run_scene(s, one_floor(), o);
  ASSERT_TRUE(first.ok()) << first.error().message;

  s.device.kind = "replay";
  s.device.waypoints.clear();
  s.device.recording = a / "run.csv";
  o.out = b;
  auto second = palpate::run_scene(s, one_floor(), o);
  ASSERT_TRUE(second.ok()) << second.error().message;
  const auto ra = csv_cells(a / "run.csv"), rb = csv_cells(b / "run.csv");
  ASSERT_EQ(ra.size(), 501u);
  ASSERT_EQ(ra.size(), rb.size());
  for (size_t k = 0; k < ra.size(); ++k) {
    for (size_t c = 0; c < 4; ++c) ASSERT_EQ(ra[k][c], rb[k][c]) << "row " << k << " col " << c;
    if (k == 0) continue;
    for (size_t c = 4; c < 8; ++c)  // the same poses (to the CSV's 9 digits) give the same forces
      ASSERT_NEAR(std::stod(ra[k][c]), std::stod(rb[k][c]), 1e-8) << "row " << k << " col " << c;
  }
}

TEST(HapticReplay, RecordingErrorsNameFileLineAndColumn) {
  auto r = palpate::load_recording_csv(write_tmp("rec_nocol.csv", "t,tool_x,tool_z\n0,0,0\n"));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("palpate_test_rec_nocol.csv:1: no column 'tool_y'"), std::string::npos)
      << r.error().message;
  r = palpate::load_recording_csv(write_tmp("rec_bad.csv", "t,tool_x,tool_y,tool_z\n0,0,0,0\n0.001,abc,0,0\n"));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("palpate_test_rec_bad.csv:3: column 'tool_x': expected a number, got 'abc'"),
            std::string::npos)
      << r.error().message;
  r = palpate::load_recording_csv(write_tmp("rec_back.csv", "t,tool_x,tool_y,tool_z\n0.002,0,0,0\n0.001,0,0,0\n"));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find(":3: time 0.001"), std::string::npos) << r.error().message;
  r = palpate::load_recording_csv(write_tmp("rec_short.csv", "t,tool_x,tool_y,tool_z\n0,0,0\n"));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find(":2: row has 3 fields, column 'tool_z' is number 4"), std::string::npos)
      << r.error().message;
  r = palpate::load_recording_csv(write_tmp("rec_empty.csv", "t,tool_x,tool_y,tool_z\n"));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("header but no rows"), std::string::npos);

  palpate::SceneDef s;
  s.device.kind = "replay";
  auto d = palpate::make_device(s);
  ASSERT_FALSE(d.ok());
  EXPECT_EQ(d.error().message, "scene: device kind 'replay' needs device.recording (a run's run.csv)");
  s.device.kind = "joystick";
  d = palpate::make_device(s);
  ASSERT_FALSE(d.ok());
  EXPECT_EQ(d.error().message,
            "scene: device kind 'joystick' is not one of scripted | replay | openhaptics | forcedimension (use kind: "
            "scripted)");
}

TEST(HapticVirtualDevice, PoseSetFromAnotherThreadIsNeverTorn) {
  palpate::VirtualDevice dev;
  std::atomic<bool> done{false};
  std::thread producer([&] {
    for (int i = 1; i <= 50000; ++i) {
      palpate::DeviceState s;
      s.position = Vec3(i, i, i) * 1e-6;
      s.buttons = std::uint32_t(i);
      dev.set_pose(s);
    }
    done = true;
  });
  std::uint32_t last = 0;
  palpate::DeviceState s;
  while (!done.load() || last < 50000) {
    ASSERT_TRUE(dev.read(0.0, s));
    ASSERT_EQ(s.position.x(), s.position.y());
    ASSERT_EQ(s.position.x(), s.position.z());
    ASSERT_EQ(s.position.x(), double(s.buttons) * 1e-6);
    ASSERT_GE(s.buttons, last);  // never goes back
    last = s.buttons;
  }
  producer.join();
  EXPECT_EQ(last, 50000u);
}

// --- openhaptics, against tests/fake_hd (libHD.so built beside the tests).
namespace {

// What the hand felt, frame by frame: finite, within `max_force`, changing by at most `max_step`
// per servo frame, ending at zero. Returns the largest frame-to-frame change.
double check_servo_forces(const std::vector<Vec3>& sent, double max_force, double max_step) {
  Vec3 last = Vec3::Zero();
  double largest = 0;
  for (size_t i = 0; i < sent.size(); ++i) {
    EXPECT_TRUE(sent[i].allFinite()) << i;
    EXPECT_LE(sent[i].norm(), max_force + 1e-12) << i;
    const double step = (sent[i] - last).norm();
    EXPECT_LE(step, max_step + 1e-12) << "frame " << i << ": " << last.transpose() << " -> " << sent[i].transpose();
    largest = std::max(largest, step);
    last = sent[i];
  }
  if (!sent.empty()) {
    EXPECT_EQ(sent.back(), Vec3::Zero());
  }
  return largest;
}
}  // namespace

TEST(HapticOpenHaptics, MissingLibraryErrorSaysHowToRunScripted) {
  auto d = palpate::open_openhaptics("/nonexistent/libHD.so", "", {});
  ASSERT_FALSE(d.ok());
  const std::string& m = d.error().message;
  EXPECT_NE(m.find("cannot load the HD library '/nonexistent/libHD.so'"), std::string::npos) << m;
  EXPECT_NE(m.find("device: {kind: scripted}"), std::string::npos) << m;
  // A library that is not HD: libc has none of its functions.
  d = palpate::open_openhaptics("libc.so.6", "", {});
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.error().message.find("has no function hdInitDevice"), std::string::npos) << d.error().message;
}

TEST(HapticOpenHaptics, NoDeviceIsAClearError) {
  FakeHd hd;
  ASSERT_NE(hd.lib, nullptr) << ::dlerror();
  hd.reset(0);
  auto d = palpate::open_openhaptics(PALPATE_FAKE_HD, "Default Device", {});
  ASSERT_FALSE(d.ok());
  const std::string& m = d.error().message;
  EXPECT_NE(m.find("no haptic device 'Default Device' could be opened (HD error 0x0300)"), std::string::npos) << m;
  EXPECT_NE(m.find("kind: scripted"), std::string::npos) << m;
  EXPECT_EQ(hd.calls("hdStartScheduler"), 0);
}

// The calibration is checked as the device opens (hdCheckCalibration, in the scheduler): a
// calibrated device opens as it is; one whose library can update it alone is updated, in a style
// it supports; one that needs the user's hand does not open, and the error says what to do.
TEST(HapticOpenHaptics, CalibrationIsCheckedAndUpdatedOrRefusedWithWhatToDo) {
  FakeHd hd;
  ASSERT_NE(hd.lib, nullptr) << ::dlerror();
  ASSERT_NE(hd.set_calibration, nullptr);
  constexpr unsigned kOk = 0x5000, kNeedsUpdate = 0x5001, kNeedsHand = 0x5002;
  constexpr int kReset = 1, kAuto = 2, kInkwell = 4;
  hd.reset(1);
  {
    auto d = palpate::open_openhaptics(PALPATE_FAKE_HD, "", {});
    ASSERT_TRUE(d.ok()) << d.error().message;
    EXPECT_EQ((*d)->calibration(), palpate::Calibration::ok);
  }
  EXPECT_EQ(hd.calls("hdCheckCalibration"), 1);
  EXPECT_EQ(hd.calls("hdUpdateCalibration"), 0);

  // Needs an update, the device supports the inkwell and the automatic style: the automatic one.
  hd.reset(1);
  hd.set_calibration(kNeedsUpdate, kInkwell | kAuto);
  {
    auto d = palpate::open_openhaptics(PALPATE_FAKE_HD, "", {});
    ASSERT_TRUE(d.ok()) << d.error().message;
    EXPECT_EQ((*d)->calibration(), palpate::Calibration::updated);
  }
  EXPECT_EQ(hd.calls("hdUpdateCalibration"), 1);
  EXPECT_EQ(hd.update_style(), kAuto);
  // A Touch (the inkwell only): updated in that style.
  hd.reset(1);
  hd.set_calibration(kNeedsUpdate, kInkwell);
  {
    auto d = palpate::open_openhaptics(PALPATE_FAKE_HD, "", {});
    ASSERT_TRUE(d.ok()) << d.error().message;
    EXPECT_EQ((*d)->calibration(), palpate::Calibration::updated);
  }
  EXPECT_EQ(hd.update_style(), kInkwell);

  // Needs the hand: no device, the way to calibrate it named by the style it supports; the
  // scheduler stopped and the device let go as for any failed open.
  for (const auto& [styles, how] : {std::pair<int, const char*>{kInkwell, "put the stylus in its inkwell"},
                                    std::pair<int, const char*>{kReset, "hold the arm in its reset position"},
                                    std::pair<int, const char*>{0, "Touch Setup"}}) {
    hd.reset(1);
    hd.set_calibration(kNeedsHand, styles);
    auto d = palpate::open_openhaptics(PALPATE_FAKE_HD, "", {});
    ASSERT_FALSE(d.ok()) << styles;
    const std::string& m = d.error().message;
    EXPECT_NE(m.find("openhaptics: the device is not calibrated (it needs your hand): "), std::string::npos) << m;
    EXPECT_NE(m.find(how), std::string::npos) << m;
    EXPECT_EQ(hd.calls("hdUpdateCalibration"), 0) << styles;
    EXPECT_GE(hd.calls("hdStopScheduler"), 1) << styles;
    EXPECT_EQ(hd.calls("hdDisableDevice"), 1) << styles;
  }
  (void)kOk;
}

TEST(HapticOpenHaptics, ServoLoopExchangesPoseAndForceInSI) {
  FakeHd hd;
  ASSERT_NE(hd.lib, nullptr) << ::dlerror();
  hd.reset(1);
  const double mm[3] = {10, 20, 30};
  hd.set_poses(mm, 1);
  palpate::DeviceLimits asked;  // 3.3 N, 1000 N/m, 2 N·s/m; the fake device says 0.8 N/mm
  {
    auto d = palpate::open_openhaptics(PALPATE_FAKE_HD, "", asked);
    ASSERT_TRUE(d.ok()) << d.error().message;
    palpate::Device& dev = **d;
    EXPECT_EQ(dev.limits().max_force, 3.3);
    EXPECT_NEAR(dev.limits().stiffness, 800.0, 1e-9);  // the device's nominal maximum is lower
    EXPECT_NEAR(dev.limits().damping, 2.0, 1e-12);
    palpate::DeviceState s;
    for (int i = 0; i < 2000 && s.position.isZero(); ++i) {
      ASSERT_TRUE(dev.read(0.0, s));
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    EXPECT_LT((s.position - Vec3(0.010, 0.020, 0.030)).norm(), 1e-15);  // mm → m
    const palpate::Quat about_y(Eigen::AngleAxisd(M_PI / 2, Vec3::UnitY()));
    EXPECT_LT(s.orientation.angularDistance(about_y), 1e-9);
    dev.write(Vec3(0, 1.25, 0), Vec3::Zero());
    Vec3 seen = Vec3::Zero();
    for (int i = 0; i < 2000 && seen != Vec3(0, 1.25, 0); ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      seen = hd.last_force();
    }
    EXPECT_EQ(seen, Vec3(0, 1.25, 0));
    // The servo zeroes a force the haptic thread stopped refreshing (50 ms): the loop died.
    for (int i = 0; i < 2000 && seen != Vec3::Zero(); ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      seen = hd.last_force();
    }
    EXPECT_EQ(seen, Vec3::Zero());
  }
  EXPECT_EQ(hd.calls("hdInitDevice"), 1);
  EXPECT_EQ(hd.enabled(0x4000), 1);  // HD_FORCE_OUTPUT
  EXPECT_EQ(hd.calls("hdScheduleAsynchronous"), 1);
  EXPECT_GE(hd.calls("hdStartScheduler"), 1);
  EXPECT_GE(hd.calls("hdStopScheduler"), 1);
  EXPECT_EQ(hd.calls("hdDisableDevice"), 1);
  EXPECT_GT(hd.calls("hdBeginFrame"), 10);
  EXPECT_EQ(hd.calls("hdBeginFrame"), hd.calls("hdEndFrame"));
  EXPECT_EQ(hd.frame_errors(), 0);
}

TEST(HapticOpenHaptics, LoopDrivesTheDeviceWithinLimits) {
  FakeHd hd;
  ASSERT_NE(hd.lib, nullptr) << ::dlerror();
  hd.reset(1);
  std::vector<double> mm;
  for (int i = 0; i < 200; ++i) mm.insert(mm.end(), {0.0, 2.0 - 0.03 * i, 0.0});  // into the floor
  hd.set_poses(mm.data(), 200);
  auto d = palpate::open_openhaptics(PALPATE_FAKE_HD, "", {});
  ASSERT_TRUE(d.ok()) << d.error().message;
  LinearFloor floor(800.0);
  palpate::LoopSettings s;
  s.max_ticks = 300;
  s.ramp_in = 0.02;
  s.try_realtime_priority = false;
  auto loop = palpate::HapticLoop::create(**d, {{&floor, 0.0}}, s);
  ASSERT_TRUE(loop.ok()) << loop.error().message;
  ASSERT_TRUE((*loop)->start());
  (*loop)->wait();
  EXPECT_GT((*loop)->stats().max_force, 0.5);  // it did press
  std::vector<double> f(3 * 100000);
  const int n = hd.forces(f.data(), 100000);
  ASSERT_GT(n, 10);
  for (int i = 0; i < std::min(n, 100000); ++i) {
    const Vec3 v(f[size_t(i) * 3], f[size_t(i) * 3 + 1], f[size_t(i) * 3 + 2]);
    ASSERT_TRUE(v.allFinite());
    ASSERT_LE(v.norm(), 3.3 + 1e-12);
  }
  // The loop's last word is zero force.
  Vec3 last = hd.last_force();
  for (int i = 0; i < 1000 && last != Vec3::Zero(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
    last = hd.last_force();
  }
  EXPECT_EQ(last, Vec3::Zero());
  // The loop's ticks and the servo's frames run on two unsynchronised 1 kHz clocks, so two ticks
  // (0.4 N) could land between two frames: the servo holds the rate limit per frame itself
  // (200 N/s = 0.2 N per 1 ms frame), the zero at stop included.
  (*loop).reset();
  (*d).reset();
  check_servo_forces(hd.all_forces(), 3.3, 200.0 * 1e-3);
}

// A program on the public API (examples/embed) may write any force straight to the device: the
// backend clamps it, limits its change per servo frame, zeroes NaN and ramps to zero at the end.
TEST(HapticOpenHaptics, BackendClampsAndRateLimitsWhatAnyCallerWrites) {
  FakeHd hd;
  ASSERT_NE(hd.lib, nullptr) << ::dlerror();
  hd.reset(1);
  palpate::DeviceLimits asked;
  asked.max_force = 50.0;  // a scene's most; the device says 3.3 N
  {
    auto d = palpate::open_openhaptics(PALPATE_FAKE_HD, "", asked);
    ASSERT_TRUE(d.ok()) << d.error().message;
    EXPECT_EQ((*d)->limits().max_force, 3.3);
    auto press = [&](const Vec3& f, int ms) {
      for (int i = 0; i < ms; ++i) {
        (*d)->write(f, Vec3::Zero());
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
      }
    };
    press(Vec3(0, 40, 0), 80);   // 40 N asked: clamped, and ramped up at 0.2 N per frame
    EXPECT_NEAR(hd.last_force().norm(), 3.3, 1e-9);
    press(Vec3(0, -40, 0), 80);  // reversed at once: 6.6 N of change, spread over 33 frames
    press(Vec3(std::nan(""), 0, 0), 40);  // NaN: to zero, ramped
    press(Vec3(0, 3.0, 0), 60);
    EXPECT_NEAR(hd.last_force().y(), 3.0, 1e-9);
    // Destroyed while pushing 3 N (no stale force yet): the zero at stop is a ramp too.
  }
  const std::vector<Vec3> sent = hd.all_forces();
  ASSERT_GT(sent.size(), 200u);
  const double largest = check_servo_forces(sent, 3.3, 0.2);
  EXPECT_GT(largest, 0.19);  // the limit was reached, so it was what held the steps
  EXPECT_EQ(hd.frame_errors(), 0);
}

// A device that reports no nominal maximum force (0) gets its family's documented one (a Touch's
// 3.3 N), not the scene's, which may be up to 50 N; and a force it stops receiving is ramped out.
TEST(HapticOpenHaptics, NoReportedMaximumFallsBackToTheTouchLimit) {
  FakeHd hd;
  ASSERT_NE(hd.lib, nullptr) << ::dlerror();
  hd.reset(1);
  hd.set_max_force(0.0);
  palpate::DeviceLimits asked;
  asked.max_force = 50.0;
  {
    auto d = palpate::open_openhaptics(PALPATE_FAKE_HD, "", asked);
    ASSERT_TRUE(d.ok()) << d.error().message;
    EXPECT_EQ((*d)->limits().max_force, 3.3);
    for (int i = 0; i < 60; ++i) {
      (*d)->write(Vec3(25, 0, 0), Vec3::Zero());
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    EXPECT_NEAR(hd.last_force().norm(), 3.3, 1e-9);
    // The writer dies: after 50 ms the servo takes the force to zero, within the rate limit.
    Vec3 seen = hd.last_force();
    for (int i = 0; i < 2000 && seen != Vec3::Zero(); ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      seen = hd.last_force();
    }
    EXPECT_EQ(seen, Vec3::Zero());
  }
  check_servo_forces(hd.all_forces(), 3.3, 0.2);
  // A scene's lower maximum still stands.
  hd.reset(1);
  hd.set_max_force(0.0);
  asked.max_force = 1.0;
  auto d = palpate::open_openhaptics(PALPATE_FAKE_HD, "", asked);
  ASSERT_TRUE(d.ok()) << d.error().message;
  EXPECT_EQ((*d)->limits().max_force, 1.0);
}

TEST(HapticOpenHaptics, ARotatedStylusTiltsTheNeedleTheTissuesSee) {
  FakeHd hd;
  ASSERT_NE(hd.lib, nullptr) << ::dlerror();
  hd.reset(1);
  const double mm[3] = {0, 5, 0};
  hd.set_poses(mm, 1);
  // The stylus turned 30 degrees about z, then 20 about x (HD's transform, column-major).
  const Eigen::Matrix3d r = (Eigen::AngleAxisd(0.5235987755982988, Vec3::UnitZ()) *
                             Eigen::AngleAxisd(0.3490658503988659, Vec3::UnitX()))
                                .toRotationMatrix();
  hd.set_rotation(r.data());  // Eigen's default storage is column-major too
  auto d = palpate::open_openhaptics(PALPATE_FAKE_HD, "", {});
  ASSERT_TRUE(d.ok()) << d.error().message;
  // Wait for the servo thread's first frame, so every tick below reads the rotated stylus.
  palpate::DeviceState first;
  for (int i = 0; i < 2000 && first.position.isZero(); ++i) {
    ASSERT_TRUE((*d)->read(0.0, first));
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ToolRecorder rec(400);
  palpate::LoopSettings s;
  s.max_ticks = 100;
  s.try_realtime_priority = false;
  s.tool.kind = "needle";
  s.tool.axis = Vec3(0, -1, 0);
  auto loop = palpate::HapticLoop::create(**d, {{&rec, 0.0}}, s);
  ASSERT_TRUE(loop.ok()) << loop.error().message;
  ASSERT_TRUE((*loop)->start());
  (*loop)->wait();
  ASSERT_GE(rec.seen.size(), 50u);
  const Vec3 want = r * Vec3(0, -1, 0);
  for (const palpate::ToolState& tool : rec.seen) {
    ASSERT_NEAR((tool.axis - want).norm(), 0.0, 1e-12);
    ASSERT_NEAR((tool.tip - Vec3(0, 0.005, 0)).norm(), 0.0, 1e-15);
  }
  EXPECT_GT(std::acos(-want.y()), 0.3);  // tilted well away from straight down
}
