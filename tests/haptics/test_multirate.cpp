// test_multirate.cpp — tissues on their own physics thread: the linearised contact renders a
// linear tissue's force exactly between its steps; a stalled physics thread gives zero force.
#include <palpate/haptics.h>

#include "haptics/doubles.h"
#include "run_csv_rows.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace fs = std::filesystem;
using palpate::Vec3;
using namespace palpate::test;

namespace {

constexpr double kDt = 0.001;

// 2 mm above the floor down to 4 mm below it over one second: 6 mm/s.
Vec3 descent(long k) { return Vec3(0, 0.002 - 0.006 * double(k) / 1000.0, 0); }

double floor_force(double k_floor, long tick) {
  return k_floor * std::max(0.0, 0.001 - descent(tick).y());  // tool radius 1 mm
}

// The device held 3 mm into a 500 N/m floor (1.5 N), and a realtime loop over `ticks` whose
// watchdog stalls after `stall_timeout`; overruns of a loaded test machine (tested elsewhere) get a
// wide margin, so they do not keep restarting the ramp-in.
void press_into_floor(palpate::VirtualDevice& dev) {
  palpate::DeviceState p;
  p.position = Vec3(0, -0.002, 0);
  dev.set_pose(p);
}

palpate::LoopSettings realtime(std::uint64_t ticks, double stall_timeout) {
  palpate::LoopSettings s;
  s.dt = kDt;
  s.realtime = true;
  s.try_realtime_priority = false;
  s.ramp_in = 0.05;
  s.max_ticks = ticks;
  s.watchdog.stall_timeout = stall_timeout;
  s.watchdog.overrun_margin = 0.05;
  return s;
}

palpate::LoopSettings headless() {
  palpate::LoopSettings s;
  s.dt = kDt;
  s.realtime = false;
  s.ramp_in = 0;
  return s;
}

}  // namespace

TEST(MultiRate, LinearisedContactRendersLinearTissueExactlyBetweenSteps) {
  // The tissue steps every 10 ticks; between its steps the loop renders F0 + J·(x − x0) with J
  // from the secant of its last two steps: exact for a linear floor once both are in contact.
  const double k = 300.0;
  LinearFloor floor(k);
  FunctionDevice dev(&descent, kDt, 1000);
  auto loop = palpate::HapticLoop::create(dev, {{&floor, 0.010}}, headless());
  ASSERT_TRUE(loop.ok()) << loop.error().message;
  (*loop)->run_headless(1000);
  long contact = -1;
  for (long t = 0; t < 1000 && contact < 0; ++t)
    if (floor_force(k, t) > 0) contact = t;
  ASSERT_GT(contact, 0);
  double max_jump = 0;
  for (long t = contact + 30; t < 1000; ++t) {
    EXPECT_NEAR(dev.written[size_t(t)].y(), floor_force(k, t), 1e-9) << "tick " << t;
    max_jump = std::max(max_jump, std::abs(dev.written[size_t(t)].y() - dev.written[size_t(t - 1)].y()));
  }
  // Smooth at 1 kHz: each tick changes by k·v·dt, not by the 10-tick jump a hold would give.
  EXPECT_LT(max_jump, 1.001 * k * 0.006 * kDt);
  // The loop's report of the physics (summary.json's "physics"): headless, a step every 10 ticks
  // from the first, none late (inline steps have no schedule to miss), no contact patch (the floor
  // offers none).
  const palpate::LoopStats st = (*loop)->stats();
  ASSERT_EQ(st.physics.size(), 1u);
  const palpate::LoopPhysicsStats& ps = st.physics[0];
  EXPECT_EQ(ps.tissue, 0);
  EXPECT_DOUBLE_EQ(ps.period, 0.010);
  EXPECT_EQ(ps.steps, 100u);
  EXPECT_EQ(ps.late, 0u);
  EXPECT_EQ(ps.patch_ticks + ps.patch_fallbacks, 0u);
  EXPECT_GT(ps.step.median, 0.0);
  EXPECT_LE(ps.step.median, ps.step.p99);
  EXPECT_LE(ps.step.p99, ps.step.max);
}

TEST(MultiRate, ModelSuppliedJacobianIsUsedFromItsFirstStep) {
  const double k = 300.0;
  FloorWithJacobian floor(k);
  FunctionDevice dev(&descent, kDt, 1000);
  auto loop = palpate::HapticLoop::create(dev, {{&floor, 0.010}}, headless());
  ASSERT_TRUE(loop.ok()) << loop.error().message;
  (*loop)->run_headless(1000);
  long contact = -1;
  for (long t = 0; t < 1000 && contact < 0; ++t)
    if (floor_force(k, t) > 0) contact = t;
  // The first physics step in contact already carries the exact stiffness.
  for (long t = contact + 11; t < 1000; ++t)
    EXPECT_NEAR(dev.written[size_t(t)].y(), floor_force(k, t), 1e-9) << "tick " << t;
}

TEST(MultiRate, StalledPhysicsThreadGivesZeroForceAndRecovers) {
  const fs::path csv = fs::temp_directory_path() / "palpate_test_multirate_stall" / "run.csv";
  LinearFloor floor(500.0);
  palpate::VirtualDevice dev;
  press_into_floor(dev);  // 1.5 N
  palpate::LoopSettings s = realtime(2000, 0.1);
  s.csv = csv;
  auto loop = palpate::HapticLoop::create(dev, {{&floor, 0.004}}, s);
  ASSERT_TRUE(loop.ok()) << loop.error().message;
  ASSERT_TRUE((*loop)->start());
  // Stall once the full force is being sent (not after a fixed time: a loaded machine is slower).
  for (int i = 0; i < 2000 && std::abs(dev.force().y() - 1.5) > 1e-9; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  ASSERT_NEAR(dev.force().y(), 1.5, 1e-9) << "the loop never reached the full force";
  floor.stall = true;  // the physics thread blocks inside its step
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  floor.stall = false;
  (*loop)->wait();
  ASSERT_TRUE((*loop)->finish_recording());
  const palpate::LoopStats st = (*loop)->stats();

  std::vector<double> fy;
  std::vector<bool> stalled;
  long expect_tick = 0;
  for (const palpate::test::RunRow& r : palpate::test::read_run_rows(csv)) {
    ASSERT_EQ(r.tick, expect_tick++);
    fy.push_back(r.force.y());
    stalled.push_back(r.events.find("stalled") != std::string::npos);
  }
  ASSERT_EQ(fy.size(), 2000u);
  // On a loaded machine the physics thread may also be starved for over the timeout at other
  // times: the watchdog rightly reports those as stalls too, so each episode is checked alike.
  size_t n_stalled = 0, first = fy.size(), episode = 0;
  for (size_t k = 0; k < fy.size(); ++k) {
    ASSERT_LE(std::abs(fy[k]), 3.3 + 1e-12);
    if (k) {
      ASSERT_LE(std::abs(fy[k] - fy[k - 1]), 0.2 + 1e-9) << k;
    }
    if (!stalled[k]) continue;
    ++n_stalled;
    first = std::min(first, k);
    if (k == 0 || !stalled[k - 1]) episode = k;
    // Zero during a stall, once the rate limit has brought it down (1.5 N at 0.2 N a tick).
    if (k >= episode + 8) {
      ASSERT_EQ(fy[k], 0.0) << "tick " << k << " (stalled since tick " << episode << ")";
    }
  }
  EXPECT_GE(n_stalled, 150u);  // a 500 ms stall minus the 100 ms timeout, with slack for load
  EXPECT_EQ(n_stalled, st.safety.stalled);
  // It was pressing before the stall (overruns on a loaded machine may restart the ramp-in, so
  // look for the full force anywhere before), and it recovers on its own once the physics thread
  // moves again.
  size_t last_stalled = 0;
  for (size_t k = 0; k < fy.size(); ++k)
    if (stalled[k]) last_stalled = k;
  double before = 0, after = 0;
  for (size_t k = 0; k < first; ++k) before = std::max(before, fy[k]);
  for (size_t k = last_stalled + 1; k < fy.size(); ++k) after = std::max(after, fy[k]);
  EXPECT_NEAR(before, 1.5, 1e-6);
  EXPECT_NEAR(after, 1.5, 1e-6);
  // The stall is in the physics report too: one step of about 500 ms, ending long after the next
  // was due (4 ms period).
  ASSERT_EQ(st.physics.size(), 1u);
  EXPECT_GE(st.physics[0].step.max, 0.45);
  EXPECT_GE(st.physics[0].late, 1u);
  EXPECT_GT(st.physics[0].steps, 50u);
}

TEST(MultiRate, ASlowPhysicsStepIsLateNotAStall) {
  // A 20 ms physics period whose every step takes 60 ms (the 54k organ on a 2-core machine): the
  // physics falls behind its rate (counted late) but keeps publishing, so the haptic side renders
  // its last contact instead of zeroing the force at the 50 ms stall timeout; a silence of ten
  // periods (200 ms) would still be a stall (StalledPhysicsThreadGivesZeroForceAndRecovers).
  LinearFloor floor(500.0);
  floor.sleep_every = 1;
  floor.step_sleep = 0.060;
  palpate::VirtualDevice dev;
  press_into_floor(dev);  // 1.5 N
  const palpate::LoopSettings s = realtime(1500, 0.05);
  auto loop = palpate::HapticLoop::create(dev, {{&floor, 0.020}}, s);
  ASSERT_TRUE(loop.ok()) << loop.error().message;
  ASSERT_TRUE((*loop)->start());
  // Once the full force is sent it stays until the run's end (the stop ramps it out after tick 1500).
  bool full = false;
  double lowest_after_full = 1e9;
  while ((*loop)->stats().ticks < 1400) {
    const double f = dev.force().y();
    if (std::abs(f - 1.5) < 1e-9) full = true;
    if (full) lowest_after_full = std::min(lowest_after_full, f);
    std::this_thread::sleep_for(std::chrono::microseconds(500));
  }
  (*loop)->wait();
  const palpate::LoopStats st = (*loop)->stats();
  EXPECT_EQ(st.safety.stalled, 0u);
  ASSERT_EQ(st.physics.size(), 1u);
  EXPECT_GE(st.physics[0].step.median, 0.055);
  EXPECT_GE(st.physics[0].late, st.physics[0].steps / 2) << st.physics[0].steps << " steps";
  EXPECT_TRUE(full) << "the loop never reached the full force";
  EXPECT_NEAR(lowest_after_full, 1.5, 1e-9);
}
