// test_loop.cpp — the haptic loop: adversarial devices stay within the safety rules, realtime runs
// record every tick and report timing, the overrun watchdog zeroes force and the loop recovers,
// the needle's axis follows the device's orientation and holds through a failed read.
#include <palpate/haptics.h>
#include <palpate/run.h>

#include "haptics/doubles.h"
#include "run_csv_rows.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace fs = std::filesystem;
using palpate::Vec3;
using namespace palpate::test;

namespace {

constexpr double kDt = 0.001;
constexpr double kMaxForce = 3.3, kMaxStep = 200.0 * kDt;  // N, N per tick (a Touch's defaults)

using CsvRow = RunRow;

size_t count_event(const std::vector<CsvRow>& rows, const std::string& name) {
  size_t n = 0;
  for (const auto& r : rows) n += r.events.find(name) != std::string::npos ? 1 : 0;
  return n;
}

// Press 3 mm into the floor, teleport 1 m down, NaN poses, 500 Hz oscillation, then hold.
Vec3 adversarial_pose(long k) {
  if (k < 300) return Vec3(0, 0.002 - 0.004 * double(k) / 300.0, 0);
  if (k < 350) return Vec3(0, -1.0, 0);                                      // teleport
  if (k < 400) return Vec3(std::numeric_limits<double>::quiet_NaN(), 0, 0);  // NaN pose
  if (k < 1000) return Vec3(0, (k % 2) ? 0.003 : -0.003, 0);                 // 500 Hz
  return Vec3(0, -0.002, 0);
}

palpate::LoopSettings settings(const fs::path& csv, bool realtime) {
  palpate::LoopSettings s;
  s.dt = kDt;
  s.realtime = realtime;
  s.ramp_in = 0.05;
  s.csv = csv;
  s.try_realtime_priority = false;  // a shared test machine: no SCHED_FIFO spinning in tests
  return s;
}

}  // namespace

TEST(Loop, AdversarialDeviceStaysWithinSafetyLimits) {
  const fs::path csv = fs::temp_directory_path() / "palpate_test_loop_adv" / "run.csv";
  LinearFloor floor(500.0);
  FunctionDevice dev(&adversarial_pose, kDt, 1300);
  auto loop = palpate::HapticLoop::create(dev, {{&floor, 0.0}}, settings(csv, false));
  ASSERT_TRUE(loop.ok()) << loop.error().message;
  (*loop)->run_headless(1300);
  ASSERT_TRUE((*loop)->finish_recording());
  const palpate::LoopStats st = (*loop)->stats();

  // What the hand felt: finite, within the maximum, changing by at most the rate limit.
  ASSERT_EQ(dev.written.size(), 1300u);
  Vec3 last = Vec3::Zero();
  for (size_t k = 0; k < dev.written.size(); ++k) {
    const Vec3& f = dev.written[k];
    ASSERT_TRUE(f.allFinite()) << k;
    ASSERT_LE(f.norm(), kMaxForce + 1e-12) << k;
    ASSERT_LE((f - last).norm(), kMaxStep + 1e-9) << k;
    last = f;
  }
  EXPECT_EQ(st.safety.device_failed, 50u);  // the 50 NaN ticks, each counted
  EXPECT_GT(st.safety.clamped, 0u);         // the teleport asked for 500 N
  EXPECT_GT(st.safety.rate_limited, 0u);    // the oscillation asked for jumps
  EXPECT_LE(st.max_force, kMaxForce + 1e-12);
  // The loop recovers on its own: holding 3 mm into 500 N/m gives 1.5 N again.
  EXPECT_NEAR(dev.written.back().y(), 1.5, 1e-9);

  // The recorder lost no tick, and marked the events it saw.
  const auto rows = read_run_rows(csv);
  ASSERT_EQ(rows.size(), 1300u);
  for (size_t k = 0; k < rows.size(); ++k) {
    ASSERT_EQ(rows[k].tick, long(k));
    EXPECT_NEAR(rows[k].force.y(), dev.written[k].y(), 1e-8);
  }
  EXPECT_EQ(count_event(rows, "device_failed"), 50u);
  EXPECT_EQ(count_event(rows, "clamped"), st.safety.clamped);
  // During the NaN poses the recorded tool position holds the last good one, never NaN.
  EXPECT_EQ(rows[360].tool.y(), -1.0);
}

TEST(Loop, RealtimeRecordsEveryTickAndReportsTiming) {
  const fs::path csv = fs::temp_directory_path() / "palpate_test_loop_rt" / "run.csv";
  LinearFloor floor(500.0);
  palpate::VirtualDevice dev;
  auto s = settings(csv, true);
  s.max_ticks = 800;
  auto loop = palpate::HapticLoop::create(dev, {{&floor, 0.0}}, s);
  ASSERT_TRUE(loop.ok()) << loop.error().message;
  ASSERT_TRUE((*loop)->start());
  // Another thread moves the device and reads the live statistics while the loop runs.
  std::uint64_t seen = 0;
  for (int i = 0; (*loop)->stats().running; ++i) {
    palpate::DeviceState p;
    p.position = Vec3(0, 0.002 - 0.00001 * (i % 500), 0);
    dev.set_pose(p);
    const palpate::LoopStats live = (*loop)->stats();
    EXPECT_GE(live.ticks, seen);
    seen = live.ticks;
    EXPECT_LE(dev.force().norm(), kMaxForce + 1e-12);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  (*loop)->wait();
  ASSERT_TRUE((*loop)->finish_recording());
  const palpate::LoopStats st = (*loop)->stats();
  EXPECT_EQ(st.ticks, 800u);
  EXPECT_EQ(st.recorder_dropped, 0u);
  EXPECT_FALSE(st.running);
  // Loose bounds only: a shared 2-core machine; the benchmark reports the real figures.
  EXPECT_GT(st.period.median, 0.5e-3);
  EXPECT_LT(st.period.median, 2.0e-3);
  EXPECT_GE(st.period.max, st.period.p99);
  EXPECT_GE(st.period.p99, st.period.median);
  EXPECT_GT(st.step.median, 0.0);
  const auto rows = read_run_rows(csv);
  ASSERT_EQ(rows.size(), 800u);
  for (size_t k = 0; k < rows.size(); ++k) ASSERT_EQ(rows[k].tick, long(k));
  EXPECT_FALSE(fs::exists(csv.string() + ".part"));
}

TEST(Loop, OverrunWatchdogSendsZeroAndRecovers) {
  const fs::path csv = fs::temp_directory_path() / "palpate_test_loop_overrun" / "run.csv";
  LinearFloor floor(500.0);
  // Steps 250, 500 and 750 take 30 ms: ticks far past their deadlines. The margin is 15 ms, so the
  // shared test machine's own scheduling delays (often past 0.5 ms under load) rarely add one.
  floor.sleep_every = 250;
  floor.sleep_until = 750;
  floor.step_sleep = 0.030;
  palpate::VirtualDevice dev;
  palpate::DeviceState p;
  p.position = Vec3(0, -0.002, 0);  // 3 mm into the floor: 1.5 N
  dev.set_pose(p);
  auto s = settings(csv, true);
  s.max_ticks = 1100;
  s.watchdog.overrun_margin = 0.015;
  auto loop = palpate::HapticLoop::create(dev, {{&floor, 0.0}}, s);
  ASSERT_TRUE(loop.ok()) << loop.error().message;
  ASSERT_TRUE((*loop)->start());
  (*loop)->wait();
  ASSERT_TRUE((*loop)->finish_recording());
  const palpate::LoopStats st = (*loop)->stats();
  const auto rows = read_run_rows(csv);
  ASSERT_EQ(rows.size(), 1100u);
  EXPECT_GE(st.safety.overrun, 3u);
  EXPECT_EQ(count_event(rows, "overrun"), st.safety.overrun);
  std::vector<size_t> overruns;
  for (size_t k = 1; k < rows.size(); ++k) {
    ASSERT_LE(rows[k].force.norm(), kMaxForce + 1e-12);
    ASSERT_LE((rows[k].force - rows[k - 1].force).norm(), kMaxStep + 1e-9) << k;
    if (rows[k].events.find("overrun") != std::string::npos) {
      // An overrunning tick never pushes harder: the force heads to zero.
      EXPECT_LE(rows[k].force.norm(), rows[k - 1].force.norm() + 1e-12) << k;
      overruns.push_back(k);
    }
  }
  // And the loop recovers by itself: 150 ticks after an overrun (ramp-in 50 ms) it pushes the full
  // force again. Each injected overrun is followed by 250 ticks or more; an overrun the shared
  // machine adds is checked too when 150 clean ticks follow it.
  size_t recoveries = 0;
  for (size_t i = 0; i < overruns.size(); ++i) {
    const size_t k = overruns[i], next = i + 1 < overruns.size() ? overruns[i + 1] : rows.size();
    if (k + 150 >= next) continue;
    EXPECT_NEAR(rows[k + 150].force.y(), 1.5, 1e-9) << "150 ticks after the overrun at tick " << k;
    ++recoveries;
  }
  EXPECT_GE(recoveries, 1u);
}

// A tissue whose step fails (a blow-up reset inside the step) returns an ordinary zero: the loop
// still counts each failed tick as `step_failed`, marks it in run.csv and restarts the ramp-in.
TEST(Loop, AFailedStepIsCountedAndRestartsTheRamp) {
  const fs::path csv = fs::temp_directory_path() / "palpate_test_loop_step_failed" / "run.csv";
  LinearFloor floor(500.0);
  floor.fail_from = 200;  // steps 200..204 fail
  floor.fail_steps = 5;
  FunctionDevice dev([](long) { return Vec3(0, -0.002, 0); }, kDt, 400);  // 1.5 N when it works
  auto loop = palpate::HapticLoop::create(dev, {{&floor, 0.0}}, settings(csv, false));
  ASSERT_TRUE(loop.ok()) << loop.error().message;
  (*loop)->run_headless(400);
  ASSERT_TRUE((*loop)->finish_recording());
  EXPECT_EQ((*loop)->stats().safety.step_failed, 5u);
  const auto rows = read_run_rows(csv);
  ASSERT_EQ(rows.size(), 400u);
  EXPECT_EQ(count_event(rows, "step_failed"), 5u);
  for (size_t k = 199; k < 204; ++k) EXPECT_NE(rows[k].events.find("step_failed"), std::string::npos) << k;
  EXPECT_NEAR(rows[198].force.y(), 1.5, 1e-9);  // full force before
  // After the failure the force comes back through the ramp-in (50 ms), not in one rate-limited
  // climb: 10 ticks after the last failed one it is at most 10/50 of the full force.
  EXPECT_LE(rows[213].force.y(), 1.5 * 11.0 / 50.0 + 1e-9);
  EXPECT_NEAR(rows.back().force.y(), 1.5, 1e-9);
}

// At stop the force goes to zero within the rate limit, one tick at a time (not one step).
TEST(Loop, StopRampsTheForceToZeroWithinTheRateLimit) {
  LinearFloor floor(500.0);
  FunctionDevice dev([](long) { return Vec3(0, -0.004, 0); }, kDt, 400);  // 2.5 N
  auto s = settings("", true);
  s.max_ticks = 200;
  s.watchdog.overrun_margin = 1.0;  // no overrun on a loaded machine: this is about the stop
  auto loop = palpate::HapticLoop::create(dev, {{&floor, 0.0}}, s);
  ASSERT_TRUE(loop.ok()) << loop.error().message;
  ASSERT_TRUE((*loop)->start());
  (*loop)->wait();
  ASSERT_GT(dev.written.size(), 200u);
  EXPECT_NEAR(dev.written[199].y(), 2.5, 1e-9);
  EXPECT_GE(dev.written.size(), 200u + 13u);  // 2.5 N at 0.2 N per tick: 13 ticks down
  Vec3 last = Vec3::Zero();
  for (size_t k = 0; k < dev.written.size(); ++k) {
    ASSERT_LE((dev.written[k] - last).norm(), kMaxStep + 1e-9) << k;
    last = dev.written[k];
  }
  EXPECT_EQ(dev.written.back(), Vec3::Zero());
  EXPECT_EQ((*loop)->stats().last_force, Vec3::Zero());
}

TEST(Loop, CreateRejectsBadSettings) {
  palpate::VirtualDevice dev;
  palpate::LoopSettings s;
  s.dt = 0;
  auto r = palpate::HapticLoop::create(dev, {}, s);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, "haptic loop: dt must be a positive number of seconds");
  s.dt = 0.001;
  r = palpate::HapticLoop::create(dev, {{nullptr, 0.0}}, s);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, "haptic loop: tissue 0 is null");
  LinearFloor floor(1.0);
  r = palpate::HapticLoop::create(dev, {{&floor, -1.0}}, s);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, "haptic loop: tissue 'floor': physics_dt must be >= 0 s");
  s.realtime = false;
  r = palpate::HapticLoop::create(dev, {}, s);
  ASSERT_TRUE(r.ok());
  const palpate::Status st = (*r)->start();
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().message, "haptic loop: built for headless runs (settings.realtime = false)");
}

TEST(Loop, RunSceneRealtimeWritesTimingToSummary) {
  // `palpate run --realtime`: the same outputs as a headless run, plus the period statistics.
  palpate::SceneDef s;
  s.name = "realtime";
  s.duration = 0.3;
  s.device.waypoints = {{0.0, Vec3(0, 0.002, 0)}, {0.3, Vec3(0, -0.002, 0)}};
  palpate::RunOptions o;
  o.out = fs::temp_directory_path() / "palpate_test_run_realtime";
  o.realtime = true;
  o.realtime_priority = false;
  o.plots = false;
  std::vector<std::unique_ptr<palpate::Tissue>> tissues;
  tissues.push_back(std::make_unique<LinearFloor>(500.0));
  auto r = palpate::run_scene(s, std::move(tissues), o);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_TRUE(r->realtime);
  EXPECT_EQ(r->ticks, 300u);
  EXPECT_EQ(r->recorder_dropped, 0u);
  EXPECT_GT(r->period.median, 0.0);
  const auto rows = read_run_rows(o.out / "run.csv");
  ASSERT_EQ(rows.size(), 300u);
  for (size_t k = 0; k < rows.size(); ++k) ASSERT_EQ(rows[k].tick, long(k));
  std::ifstream in(o.out / "summary.json");
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string j = ss.str();
  for (const char* key : {"\"period_s\"", "\"deadline_misses\"", "\"realtime\": true", "\"overrun\"",
                          "\"stalled\"", "\"recorder_dropped\": 0"})
    EXPECT_NE(j.find(key), std::string::npos) << key << " in " << j;
}

// --- the needle's axis: orientation * tool.axis, every tick.
namespace {

using palpate::Quat;

// A needle that turns every tick about a swinging axis (1 rad over 500 ticks) while it moves.
bool turning_pose(long k, Vec3& p, Quat& q) {
  p = Vec3(0.001 * std::sin(0.01 * double(k)), 0.002, 0);
  const Vec3 about = Vec3(std::cos(0.003 * double(k)), 0.5, std::sin(0.003 * double(k))).normalized();
  q = Quat(Eigen::AngleAxisd(0.002 * double(k), about));
  return true;
}

// Turning about z, with bad reads: NaN orientation (ticks 100-109), a failed read (110-119), a zero
// quaternion (120-129), a NaN position (130-139); then a quaternion of norm 3 (140-149).
bool faulty_pose(long k, Vec3& p, Quat& q) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  p = Vec3(0, 0.002, 0);
  q = Quat(Eigen::AngleAxisd(0.004 * double(k), Vec3::UnitZ()));
  if (k >= 100 && k < 110) q.coeffs().setConstant(nan);
  if (k >= 110 && k < 120) return false;
  if (k >= 120 && k < 130) q.coeffs().setZero();
  if (k >= 130 && k < 140) p.x() = nan;
  if (k >= 140 && k < 150) q.coeffs() *= 3.0;
  return true;
}

}  // namespace

TEST(Loop, ToolAxisIsTheDeviceOrientationAppliedToTheSceneAxis) {
  for (const auto coupling : {palpate::Coupling::direct, palpate::Coupling::virtual_}) {
    SCOPED_TRACE(coupling == palpate::Coupling::direct ? "direct" : "virtual");
    PoseDevice dev(&turning_pose, kDt);
    ToolRecorder rec(600);
    palpate::LoopSettings s = settings({}, false);
    s.coupling = coupling;
    s.tool.kind = "needle";
    s.tool.axis = Vec3(0.3, -1, 0.2);  // not unit: the loop normalises it once
    auto loop = palpate::HapticLoop::create(dev, {{&rec, 0.0}}, s);
    ASSERT_TRUE(loop.ok()) << loop.error().message;
    (*loop)->run_headless(500);
    ASSERT_EQ(rec.seen.size(), 500u);
    const Vec3 axis0 = s.tool.axis.normalized();
    for (long k = 0; k < 500; ++k) {
      Vec3 p;
      Quat q;
      turning_pose(k, p, q);
      const palpate::ToolState& tool = rec.seen[size_t(k)];
      ASSERT_NEAR((tool.axis - q * axis0).norm(), 0.0, 1e-14) << k;
      ASSERT_NEAR(tool.axis.norm(), 1.0, 1e-15) << k;
      ASSERT_TRUE(tool.needle);
    }
    // It really turned: 1 rad about an axis that is not the needle's.
    EXPECT_GT(std::acos(rec.seen.front().axis.dot(rec.seen.back().axis)), 0.5);
  }
}

TEST(Loop, AFailedReadHoldsTheLastGoodOrientationNotTheSceneAxis) {
  const fs::path csv = fs::temp_directory_path() / "palpate_test_loop_axis_fault" / "run.csv";
  PoseDevice dev(&faulty_pose, kDt);
  ToolRecorder rec(300);
  palpate::LoopSettings s = settings(csv, false);
  s.tool.kind = "needle";
  s.tool.axis = Vec3(1, 0, 0);
  auto loop = palpate::HapticLoop::create(dev, {{&rec, 0.0}}, s);
  ASSERT_TRUE(loop.ok()) << loop.error().message;
  (*loop)->run_headless(200);
  ASSERT_TRUE((*loop)->finish_recording());
  EXPECT_EQ((*loop)->stats().safety.device_failed, 40u);  // ticks 100-139; a norm-3 quaternion is fine
  const auto rows = read_run_rows(csv);
  ASSERT_EQ(rows.size(), 200u);
  ASSERT_EQ(rec.seen.size(), 200u);
  const Vec3 held = rec.seen[99].axis;
  EXPECT_GT((held - Vec3(1, 0, 0)).norm(), 0.3);  // 0.4 rad away from the scene's axis
  for (size_t k = 0; k < 200; ++k) {
    Vec3 p;
    Quat q;
    faulty_pose(long(k), p, q);
    const Vec3 want = k >= 100 && k < 140 ? held : Vec3(q.normalized() * Vec3(1, 0, 0));
    ASSERT_NEAR((rec.seen[k].axis - want).norm(), 0.0, 1e-14) << k;
    ASSERT_TRUE(rec.seen[k].tip.allFinite()) << k;
    // The recorded orientation is the one the needle had: unit, never NaN or zero.
    ASSERT_NEAR(rows[k].q.norm(), 1.0, 1e-8) << k;
    ASSERT_NEAR((rows[k].q * Vec3(1, 0, 0) - rec.seen[k].axis).norm(), 0.0, 1e-8) << k;
  }
  EXPECT_EQ(count_event(rows, "device_failed"), 40u);
}
