// test_loop_tools.cpp — two tools, two hands: HapticLoop's extra tools (LoopTool), each read,
// evaluated and written on the needle's tick through its own safety filter; realtime runs with two
// scripted devices, and with one scripted device and the fake libHD (tests/fake_hd).
#include <palpate/haptics.h>

#include "haptics/doubles.h"
#include "haptics/fake_hd_client.h"

#include <gtest/gtest.h>

#include <dlfcn.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <thread>

namespace fs = std::filesystem;
using palpate::Vec3;
using palpate::Quat;
using palpate::test::FunctionDevice;
using palpate::test::LinearFloor;

namespace {

// A wall the second tool presses: a stiff spring under y = 0, far past what its device renders (so
// its filter must clamp), with a kick (a jump of the force) every 100 ticks' worth of time (so it
// must rate-limit), and NaN now and then when asked (so it must zero and ramp in again).
class KickingWall final : public palpate::ToolForceModel {
 public:
  explicit KickingWall(double stiffness, bool nan_every_300 = false) : k_(stiffness), nan_(nan_every_300) {}
  Vec3 force(const Vec3& position, const Quat&, double t) noexcept override {
    const long tick = std::lround(t * 1000);
    if (nan_ && tick % 300 == 150) return Vec3::Constant(std::nan(""));
    const double pen = std::max(0.0, -position.y());
    const double kick = (tick / 100) % 2 ? 2.5 : 0.0;  // N, on and off every 100 ms
    return Vec3(0, k_ * pen + kick, 0);
  }

 private:
  double k_;
  bool nan_;
};

// Presses down 1 mm per 100 ticks from 2 mm above y = 0.
Vec3 pressing(long tick) { return Vec3(0, 0.002 - 1e-5 * double(tick), 0); }
Vec3 pressing_beside(long tick) { return Vec3(0.03, 0.001 - 2e-5 * double(tick), 0.01); }

// Every force a device was sent stays within its maximum and changes by at most its rate · dt — on
// the run's `ticks` ticks and on the stop's ramp down after them, which ends at zero (the loop's
// last word is zero force, reached within the rate limit).
void expect_within_limits(const std::vector<Vec3>& written, size_t ticks, const palpate::DeviceLimits& lim,
                          double dt, const char* which) {
  ASSERT_GE(written.size(), ticks) << which;
  Vec3 prev = Vec3::Zero();
  for (size_t i = 0; i < written.size(); ++i) {
    const Vec3& f = written[i];
    ASSERT_TRUE(f.allFinite()) << which << " tick " << i;
    ASSERT_LE(f.norm(), lim.max_force + 1e-12) << which << " tick " << i;
    ASSERT_LE((f - prev).norm(), lim.max_force_rate * dt + 1e-12) << which << (i < ticks ? " tick " : " stop ") << i;
    prev = f;
  }
  if (written.size() > ticks) {
    EXPECT_EQ(written.back(), Vec3::Zero()) << which << ": the last word";
  }
}

}  // namespace

TEST(LoopTools, TwoScriptedDevicesInOneRealtimeRunEachWithinItsOwnLimits) {
  const double dt = 0.001;
  const size_t ticks = 600;
  palpate::DeviceLimits needle_lim;
  needle_lim.max_force = 1.0, needle_lim.max_force_rate = 40.0;
  palpate::DeviceLimits probe_lim;
  probe_lim.max_force = 2.0, probe_lim.max_force_rate = 120.0;
  FunctionDevice needle(pressing, dt, ticks + 1100, needle_lim);
  FunctionDevice probe(pressing_beside, dt, ticks + 1100, probe_lim);
  LinearFloor floor(2000.0);  // up to 36 N on the needle: its 1 N must clamp
  KickingWall wall(5000.0, /*nan_every_300=*/true);

  palpate::LoopSettings s;
  s.dt = dt;
  s.realtime = true;
  s.max_ticks = ticks;
  s.ramp_in = 0.02;
  s.try_realtime_priority = false;
  s.watchdog.overrun_margin = 1.0;  // a loaded test machine's late tick is not what this checks
  s.csv = fs::temp_directory_path() / "palpate_test_loop_tools" / "run.csv";
  fs::create_directories(s.csv.parent_path());
  auto built = palpate::HapticLoop::create(needle, {{&floor, 0.0}}, s, {{"probe", &probe, &wall, 0.05, std::nullopt, {}}});
  ASSERT_TRUE(built.ok()) << built.error().message;
  palpate::HapticLoop& loop = **built;
  ASSERT_EQ(loop.tool_count(), 2u);
  ASSERT_TRUE(loop.start());
  loop.wait();
  ASSERT_TRUE(loop.finish_recording());

  // Each device got one force per tick plus the stop's ramp to zero (room for 1 s of it), each
  // within its own limits.
  ASSERT_GE(needle.written.size(), ticks);
  ASSERT_GE(probe.written.size(), ticks);
  expect_within_limits(needle.written, ticks, needle_lim, dt, "needle");
  expect_within_limits(probe.written, ticks, probe_lim, dt, "probe");
  EXPECT_EQ(needle.written.back(), Vec3::Zero());
  EXPECT_EQ(probe.written.back(), Vec3::Zero());

  // Both filters had work to do, each counting its own.
  const palpate::LoopStats st = loop.stats();
  ASSERT_EQ(st.tools.size(), 1u);
  const palpate::LoopToolStats& pt = st.tools[0];
  EXPECT_EQ(pt.name, "probe");
  EXPECT_GT(st.safety.clamped, 0u);
  EXPECT_GT(pt.safety.clamped, 0u);
  EXPECT_GT(pt.safety.rate_limited, 0u);
  EXPECT_EQ(pt.safety.non_finite, 2u);  // t = 0.15 and 0.45 s
  EXPECT_EQ(st.safety.non_finite, 0u) << "the probe's NaN is the probe's alone";
  EXPECT_NEAR(pt.max_force, 2.0, 1e-9);
  EXPECT_NEAR(st.max_force, 1.0, 1e-9);
  EXPECT_EQ(pt.max_force_limit, 2.0);

  // The recording: the probe's pose and force columns, kept in series() after the needle's.
  const auto& cols = loop.columns();
  for (const char* c : {"probe_x", "probe_y", "probe_z", "probe_qw", "probe_qx", "probe_qy", "probe_qz",
                        "probe_force_x", "probe_force_y", "probe_force_z", "probe_force_N", "probe_events"})
    EXPECT_NE(std::find(cols.begin(), cols.end(), c), cols.end()) << c;
  const auto& ser = loop.series();
  ASSERT_EQ(ser.size(), 12u + 11u);
  ASSERT_EQ(ser[0].size(), ticks);
  for (size_t k = 0; k < ticks; ++k) {
    ASSERT_NEAR(ser[12 + 1][k], pressing_beside(long(k)).y(), 1e-15) << k;       // probe_y
    ASSERT_EQ(ser[12 + 3][k], 1.0) << k;                                          // probe_qw
    ASSERT_LE(ser[12 + 10][k], probe_lim.max_force + 1e-12) << k;                 // probe_force_N
    ASSERT_NEAR(ser[12 + 10][k], Vec3(ser[12 + 7][k], ser[12 + 8][k], ser[12 + 9][k]).norm(), 1e-9) << k;
    ASSERT_LE(ser[7][k], needle_lim.max_force + 1e-12) << k;                      // force_N
  }
  // The newest tick of each tool, readable from this thread.
  const palpate::ToolSample n = loop.tool_sample(0), p = loop.tool_sample(1);
  ASSERT_TRUE(n.valid && p.valid);
  EXPECT_EQ(n.tick, ticks);
  EXPECT_EQ(p.tick, ticks);
  EXPECT_NEAR(p.position.y(), pressing_beside(long(ticks) - 1).y(), 1e-15);
  EXPECT_FALSE(loop.tool_sample(2).valid);
  fs::remove_all(s.csv.parent_path());
}

TEST(LoopTools, AFailingProbeDeviceZeroesOnlyTheProbe) {
  const double dt = 0.001;
  FunctionDevice needle(pressing, dt, 400);
  palpate::test::PoseDevice probe(
      [](long tick, Vec3& p, Quat& q) {
        p = Vec3(0, -0.001, 0);
        q = Quat::Identity();
        return tick < 200 || tick >= 250;  // the read fails for 50 ticks
      },
      dt);
  LinearFloor floor(300.0);
  KickingWall wall(500.0);
  palpate::LoopSettings s;
  s.dt = dt;
  s.realtime = false;
  s.ramp_in = 0.0;
  auto built = palpate::HapticLoop::create(needle, {{&floor, 0.0}}, s, {{"probe", &probe, &wall, 0.0, std::nullopt, {}}});
  ASSERT_TRUE(built.ok()) << built.error().message;
  (*built)->run_headless(400);
  const palpate::LoopStats st = (*built)->stats();
  EXPECT_EQ(st.tools[0].safety.device_failed, 50u);
  EXPECT_EQ(st.safety.device_failed, 0u);
  // The needle's forces are those of the same run without a probe, tick for tick.
  FunctionDevice alone(pressing, dt, 400);
  LinearFloor floor2(300.0);
  auto solo = palpate::HapticLoop::create(alone, {{&floor2, 0.0}}, s);
  ASSERT_TRUE(solo.ok());
  (*solo)->run_headless(400);
  ASSERT_EQ(alone.written.size(), needle.written.size());
  for (size_t i = 0; i < alone.written.size(); ++i) ASSERT_EQ(alone.written[i], needle.written[i]) << i;
}

TEST(LoopTools, BadToolsAreRefusedWithWhatIsWrong) {
  FunctionDevice needle(pressing, 0.001, 10), probe(pressing, 0.001, 10);
  LinearFloor floor(300.0);
  KickingWall wall(500.0);
  palpate::LoopSettings s;
  s.realtime = false;
  auto a = palpate::HapticLoop::create(needle, {{&floor, 0.0}}, s, {{"probe", &probe, nullptr, 0.1, std::nullopt, {}}});
  ASSERT_FALSE(a.ok());
  EXPECT_EQ(a.error().message, "haptic loop: tool 1 'probe': needs a device and a force model");
  auto b = palpate::HapticLoop::create(needle, {{&floor, 0.0}}, s,
                                       {{"probe", &probe, &wall, 0.1, std::nullopt, {}}, {"probe", &probe, &wall, 0.1, std::nullopt, {}}});
  ASSERT_FALSE(b.ok());
  EXPECT_EQ(b.error().message, "haptic loop: tool 2 'probe': two tools have that name");
}

// --- one scripted device and the fake libHD (tests/fake_hd) in the other hand.
using palpate::test::FakeHd;

TEST(LoopTools, OneScriptedAndOneOpenHapticsDeviceInOneRealtimeRun) {
  FakeHd hd;
  ASSERT_NE(hd.lib, nullptr) << ::dlerror();
  hd.reset(1);
  std::vector<double> mm;
  for (int i = 0; i < 400; ++i) mm.insert(mm.end(), {0.0, 1.0 - 0.05 * i, 0.0});  // into the wall
  hd.set_poses(mm.data(), 400);
  palpate::DeviceLimits hd_lim;
  hd_lim.max_force = 1.5, hd_lim.max_force_rate = 80.0;
  auto d = palpate::open_openhaptics(PALPATE_FAKE_HD, "", hd_lim);
  ASSERT_TRUE(d.ok()) << d.error().message;
  const palpate::DeviceLimits lim = (*d)->limits();  // the device's own may be lower still
  ASSERT_LE(lim.max_force, 1.5);

  const double dt = 0.001;
  const size_t ticks = 500;
  FunctionDevice needle(pressing, dt, ticks + 1100);
  LinearFloor floor(800.0);
  KickingWall wall(3000.0);
  palpate::LoopSettings s;
  s.dt = dt;
  s.max_ticks = ticks;
  s.ramp_in = 0.02;
  s.try_realtime_priority = false;
  s.watchdog.overrun_margin = 1.0;
  s.csv = fs::temp_directory_path() / "palpate_test_loop_tools_hd" / "run.csv";
  fs::create_directories(s.csv.parent_path());
  auto built = palpate::HapticLoop::create(needle, {{&floor, 0.0}}, s, {{"probe", d->get(), &wall, 0.02, std::nullopt, {}}});
  ASSERT_TRUE(built.ok()) << built.error().message;
  ASSERT_TRUE((*built)->start());
  (*built)->wait();
  ASSERT_TRUE((*built)->finish_recording());

  expect_within_limits(needle.written, ticks, needle.limits(), dt, "needle (scripted)");
  // What the loop sent the HD device, tick by tick: within its limit and rate.
  const auto& ser = (*built)->series();
  ASSERT_EQ(ser.size(), 23u);
  std::vector<Vec3> sent;
  for (size_t k = 0; k < ser[0].size(); ++k) sent.emplace_back(ser[19][k], ser[20][k], ser[21][k]);
  expect_within_limits(sent, sent.size(), lim, dt, "probe (openhaptics)");
  EXPECT_GT((*built)->stats().tools[0].max_force, 0.5 * lim.max_force) << "it did press";
  // What reached the (fake) device's servo loop: never above its limit, and zero at the end.
  std::vector<double> f(3 * 100000);
  const int n = hd.forces(f.data(), 100000);
  ASSERT_GT(n, 10);
  for (int i = 0; i < std::min(n, 100000); ++i) {
    const Vec3 v(f[size_t(i) * 3], f[size_t(i) * 3 + 1], f[size_t(i) * 3 + 2]);
    ASSERT_TRUE(v.allFinite());
    ASSERT_LE(v.norm(), lim.max_force + 1e-12);
  }
  Vec3 last = Vec3::Constant(-1);
  for (int i = 0; i < 1000 && last != Vec3::Zero(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
    const int m = hd.forces(f.data(), 100000);
    if (m > 0 && m <= 100000) last = Vec3(f[size_t(m - 1) * 3], f[size_t(m - 1) * 3 + 1], f[size_t(m - 1) * 3 + 2]);
  }
  EXPECT_EQ(last, Vec3::Zero());
  fs::remove_all(s.csv.parent_path());
}
