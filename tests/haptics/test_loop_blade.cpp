// test_loop_blade.cpp — a blade tool in the haptic loop (issue 37): the tissues meet it as an edge
// (ToolState::blade, its length, its axis turned by the device as a needle's); a tick whose edge
// jumps farther than blade_max_speed · dt, or whose pose could not be read, presses without cutting
// and a jump is counted (SafetyCounters::blade_teleport, the `blade_teleport` event); an edge of no
// length is refused when the loop is built; a tissue stepped at its own rate never misses a no-cut tick.
#include <palpate/haptics.h>

#include "haptics/doubles.h"
#include "haptics/multirate.h"
#include "haptics/pacing.h"
#include "run_csv_rows.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <thread>
#include <vector>

namespace fs = std::filesystem;
using palpate::Quat;
using palpate::ToolState;
using palpate::Vec3;
using namespace palpate::test;

namespace {

constexpr double kDt = 0.001;
constexpr double kEdge = 0.02;  // m

palpate::LoopSettings blade_settings(const fs::path& csv = {}) {
  palpate::LoopSettings s;
  s.dt = kDt;
  s.realtime = false;
  s.ramp_in = 0.02;
  s.csv = csv;
  s.try_realtime_priority = false;
  s.tool.kind = "blade";
  s.tool.radius = 0.0002;
  s.tool.length = kEdge;
  s.tool.axis = Vec3(0, -1, 0);
  return s;
}

// A slow stroke along x, 1 mm into a floor at y = 0, the blade turning about z at 0.5 rad/s (up to
// 30°): what a hand does.
bool stroke(long k, Vec3& p, Quat& q) {
  p = Vec3(-0.02 + 1e-4 * double(k), -0.001, 0);  // 0.1 m/s
  q = Quat(Eigen::AngleAxisd(std::min(0.5 * 1e-3 * double(k), 0.52), Vec3::UnitZ()));
  return true;
}

// The same stroke with glitches: at tick 200 the tip jumps 5 cm along x for one tick and comes back;
// from tick 400 the blade is turned 90° about z at once (the tip stays; the heel jumps 28 mm); ticks
// 600–609 read NaN (the stroke goes on meanwhile: 1 mm in 10 ticks, no jump when it comes back).
bool glitchy(long k, Vec3& p, Quat& q) {
  p = Vec3(-0.02 + 1e-4 * double(k), -0.001, 0);
  q = Quat::Identity();
  if (k == 200) p.x() += 0.05;
  if (k >= 400) q = Quat(Eigen::AngleAxisd(0.5 * M_PI, Vec3::UnitZ()));
  if (k >= 600 && k < 610) p.x() = std::numeric_limits<double>::quiet_NaN();
  return true;
}

// A steady stroke along x at `g_speed` m/s.
double g_speed = 0;
bool steady(long k, Vec3& p, Quat& q) {
  p = Vec3(g_speed * kDt * double(k), 0.01, 0);
  q = Quat::Identity();
  return true;
}

}  // namespace

TEST(LoopBlade, ABladeReachesTheTissuesAsAnEdgeTurnedByTheDeviceLikeTheNeedle) {
  ToolRecorder rec(1000);
  PoseDevice dev(&stroke, kDt);
  auto loop = palpate::HapticLoop::create(dev, {{&rec, 0.0}}, blade_settings());
  ASSERT_TRUE(loop.ok()) << loop.error().message;
  (*loop)->run_headless(1000);
  ASSERT_EQ(rec.seen.size(), 1000u);
  for (size_t k = 0; k < rec.seen.size(); ++k) {
    const ToolState& t = rec.seen[k];
    Vec3 p;
    Quat q;
    stroke(long(k), p, q);
    ASSERT_TRUE(t.blade) << k;
    ASSERT_FALSE(t.needle) << k;
    ASSERT_EQ(t.length, kEdge) << k;
    ASSERT_EQ(t.radius, 0.0002) << k;
    ASSERT_EQ(t.tip, p) << k;
    // The axis as a needle's: the device's orientation (normalised by the loop) applied to tool.axis.
    ASSERT_LT((t.axis - palpate::needle_axis(Vec3(0, -1, 0), q.normalized())).norm(), 1e-15) << k;
    ASSERT_NEAR(t.axis.norm(), 1.0, 1e-12) << k;
  }
  // The edge turned with the device: 0.4995 rad from tool.axis at the last tick (k = 999).
  EXPECT_NEAR(std::acos(-rec.seen.back().axis.y()), 0.4995, 1e-9);
  const palpate::LoopStats st = (*loop)->stats();
  EXPECT_EQ(st.safety.blade_teleport, 0u) << "a hand's stroke is never a teleport";
  EXPECT_EQ(st.safety.zeroed(), 0u);
}

TEST(LoopBlade, ATeleportOrAnUnreadablePosePressesWithoutCuttingAndTheJumpIsCounted) {
  const fs::path csv = fs::temp_directory_path() / "palpate_test_loop_blade" / "run.csv";
  constexpr size_t kTicks = 800;
  auto floor = std::make_unique<LinearFloor>(300.0);
  ToolRecorder rec(kTicks, std::move(floor));
  PoseDevice dev(&glitchy, kDt);
  auto loop = palpate::HapticLoop::create(dev, {{&rec, 0.0}}, blade_settings(csv));
  ASSERT_TRUE(loop.ok()) << loop.error().message;
  (*loop)->run_headless(kTicks);
  ASSERT_TRUE((*loop)->finish_recording());
  ASSERT_EQ(rec.seen.size(), kTicks);
  // Cutting on exactly the ticks a hand could have made: not the jump out (200), the turn (400) or
  // the unreadable poses (600–609); the jump back from 200 is a jump too (201).
  for (size_t k = 0; k < kTicks; ++k) {
    const bool glitch = k == 200 || k == 201 || k == 400 || (k >= 600 && k < 610);
    EXPECT_EQ(rec.seen[k].blade, !glitch) << "tick " << k;
  }
  // The tool still reached the tissues on those ticks, as it was: it presses.
  EXPECT_NEAR(rec.seen[200].tip.x(), -0.02 + 0.02 + 0.05, 1e-12);
  EXPECT_EQ(rec.seen[605].tip, rec.seen[599].tip) << "an unreadable pose holds the last good one";
  const palpate::LoopStats st = (*loop)->stats();
  EXPECT_EQ(st.safety.blade_teleport, 3u);  // 200, 201, 400
  EXPECT_EQ(st.safety.device_failed, 10u);  // the NaN ticks, counted as before
  // A jump is not a fault of the force: only the unreadable ticks zeroed it.
  EXPECT_EQ(st.safety.zeroed(), 10u);
  // Each jump is marked in run.csv's events, on its tick.
  const auto rows = read_run_rows(csv);
  ASSERT_EQ(rows.size(), kTicks);
  size_t marked = 0;
  for (size_t k = 0; k < rows.size(); ++k)
    if (rows[k].events.find("blade_teleport") != std::string::npos) {
      ++marked;
      EXPECT_TRUE(k == 200 || k == 201 || k == 400) << k;
    }
  EXPECT_EQ(marked, 3u);
  fs::remove_all(csv.parent_path());
}

TEST(LoopBlade, TheSpeedLimitSeparatesAStrokeFromAJump) {
  for (const double fraction : {0.9, 1.1}) {
    auto s = blade_settings();
    s.blade_max_speed = 1.0;  // m/s: 1 mm a tick
    g_speed = fraction * s.blade_max_speed;
    ToolRecorder rec(300);
    PoseDevice dev(&steady, kDt);
    auto loop = palpate::HapticLoop::create(dev, {{&rec, 0.0}}, s);
    ASSERT_TRUE(loop.ok()) << loop.error().message;
    (*loop)->run_headless(300);
    // The first tick has nothing before it to jump from; every later one moved 0.9 or 1.1 mm.
    EXPECT_EQ((*loop)->stats().safety.blade_teleport, fraction < 1 ? 0u : 299u) << fraction;
    size_t cutting = 0;
    for (const ToolState& t : rec.seen) cutting += t.blade;
    EXPECT_EQ(cutting, fraction < 1 ? 300u : 1u) << fraction;
  }
}

TEST(LoopBlade, AnEdgeOfNoLengthOrANonsenseSpeedLimitIsRefused) {
  ToolRecorder rec(10);
  PoseDevice dev(&stroke, kDt);
  for (const double length : {0.0, -0.01, std::numeric_limits<double>::quiet_NaN()}) {
    auto s = blade_settings();
    s.tool.length = length;
    auto loop = palpate::HapticLoop::create(dev, {{&rec, 0.0}}, s);
    ASSERT_FALSE(loop.ok()) << length;
    EXPECT_EQ(loop.error().message, "haptic loop: a blade tool needs an edge length > 0 m (tool.length)");
  }
  auto s = blade_settings();
  s.blade_max_speed = 0;
  auto loop = palpate::HapticLoop::create(dev, {{&rec, 0.0}}, s);
  ASSERT_FALSE(loop.ok());
  EXPECT_EQ(loop.error().message, "haptic loop: blade_max_speed must be a positive number of m/s");
  // A needle or a sphere is not a blade, whatever the speed limit.
  s.tool.kind = "needle";
  EXPECT_TRUE(palpate::HapticLoop::create(dev, {{&rec, 0.0}}, s).ok());
}

// A tissue stepped at its own rate sees one tick in ten here (physics_dt 10 ms, headless: inline):
// a jump on a tick between its steps still reaches it as a blade that does not cut, on the next
// step, so that step's sweep never spans the jump; the steps before and after cut.
TEST(LoopBlade, AMultiRateTissueSeesTheJumpOnItsNextStepNotASweepAcrossIt) {
  ToolRecorder rec(100);
  PoseDevice dev(&glitchy, kDt);  // jumps at ticks 200 and 201 (out and back), turns at 400
  auto loop = palpate::HapticLoop::create(dev, {{&rec, 0.01}}, blade_settings());
  ASSERT_TRUE(loop.ok()) << loop.error().message;
  (*loop)->run_headless(500);
  ASSERT_EQ(rec.seen.size(), 50u);  // ticks 0, 10, ..., 490
  for (size_t i = 0; i < rec.seen.size(); ++i) {
    const long tick = long(10 * i);
    // Ticks 200–201 fall in the step of tick 200 (gated itself) and before that of 210; the turn at
    // 400 is the step's own tick.
    const bool no_cut = tick == 200 || tick == 210 || tick == 400;
    EXPECT_EQ(rec.seen[i].blade, !no_cut) << "the step at tick " << tick;
  }
  EXPECT_EQ((*loop)->stats().safety.blade_teleport, 3u);
}

// The same on a physics thread: the haptic thread hands a tool over every tick, the physics thread
// reads whichever is newest when it steps. The one tick the blade jumped must still reach it: the
// first step that sees the tool on the far side of the jump sees a blade that does not cut.
TEST(LoopBlade, AThreadedTissueNeverSweepsAcrossAJumpItDidNotSee) {
  for (int attempt = 0; attempt < 3; ++attempt) {
    ToolRecorder rec(10000);
    palpate::PhysicsWorker w(rec, 0, 0.005, kDt, 1000.0, /*threaded=*/true);
    w.start();
    ToolState t;
    t.blade = true, t.length = kEdge, t.radius = 0.0002;
    Vec3 f;
    std::vector<double> figs;
    auto tick = [&](const Vec3& tip, bool blade) {
      t.tip = tip, t.blade = blade;
      (void)w.render(t, palpate::monotonic_ns(), 0.0, f, figs);
      std::this_thread::sleep_for(std::chrono::microseconds(1000));
    };
    for (int k = 0; k < 30; ++k) tick(Vec3(0.0001 * k, 0, 0), true);
    tick(Vec3(0.05, 0, 0), false);  // the jump: one tick, not cutting
    // On past it until the physics thread has stepped a few times more (however loaded the machine).
    const std::uint64_t after = w.physics_steps();
    for (int k = 0; k < 40 || (w.physics_steps() < after + 4 && k < 4000); ++k) tick(Vec3(0.05 + 1e-6 * k, 0, 0), true);
    w.stop();
    size_t first_far = 0;
    while (first_far < rec.seen.size() && rec.seen[first_far].tip.x() < 0.04) ++first_far;
    ASSERT_LT(first_far, rec.seen.size()) << "the physics thread stepped after the jump";
    EXPECT_FALSE(rec.seen[first_far].blade) << "attempt " << attempt << ": step " << first_far;
    // And it cuts again afterwards.
    EXPECT_TRUE(rec.seen.back().blade);
  }
}
