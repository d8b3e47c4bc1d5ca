// test_passivity.cpp — the time-domain passivity observer and controller (safety.h,
// PassivityController; Hannaford & Ryu 2002) on every device's force path: its law against the
// closed form, its forgetting, and the haptic loop with deliberately unstable settings — a stiff wall
// sampled at a low physics rate, a wall seen through a delay of several ticks, a virtual coupling
// tuned too stiff — held by a simulated hand: each oscillates with growing energy without the
// controller and stays bounded with it.
#include <palpate/haptics.h>
#include <palpate/run.h>
#include <palpate/safety.h>
#include <palpate/scene.h>

#include "haptics/doubles.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <vector>

using palpate::DeviceLimits;
using palpate::DeviceState;
using palpate::PassivityController;
using palpate::PassivitySettings;
using palpate::Quat;
using palpate::Vec3;

namespace {

DeviceLimits limits_with_damping(double damping) {
  DeviceLimits l;
  l.damping = damping;
  return l;
}

// The law itself: α set at once, not slewed (PassivitySettings::damping_rise 0).
PassivitySettings instant() {
  PassivitySettings p;
  p.damping_rise = 0;
  return p;
}

// --- The law, tick by tick.

// A device moving at a constant velocity, ticked through a controller: each tick it moves v·dt, the
// controller observes the work of the force it held, then shapes this tick's request, which is sent
// as it comes out (no safety filter here).
struct Ticker {
  PassivityController& pc;
  Vec3 x = Vec3::Zero();
  double dt = 1e-3;
  Vec3 tick(const Vec3& request, const Vec3& v) {
    x += v * dt;
    const Vec3 out = pc.control(request, x, v, dt);
    pc.sent(out, dt);
    return out;
  }
};

TEST(Passivity, AnActiveForceGetsExactlyTheDampingThatBringsTheEnergyBackToZero) {
  PassivityController pc(limits_with_damping(20.0), instant());
  Ticker t{pc};
  const Vec3 v(0.1, 0, 0), f(1, 0, 0);  // the force along the hand's motion: it would give energy
  const Vec3 out = t.tick(f, v);
  // E would be −f·v·dt = −1e-4 J by the next tick; α = 1e-4 / (dt · |v|²) = 10 N·s/m, under the
  // cap of 18, and the force along v is gone.
  EXPECT_NEAR(pc.damping(), 10.0, 1e-9);
  EXPECT_NEAR(out.x(), 0.0, 1e-12);
  t.tick(Vec3::Zero(), v);  // the next tick observes the work of what was held: none
  EXPECT_NEAR(pc.energy(), 0.0, 1e-15);
  EXPECT_EQ(pc.counters().active_ticks, 1u);
  EXPECT_EQ(pc.counters().capped_ticks, 0u);
  EXPECT_NEAR(pc.counters().dissipated, 1e-4, 1e-12);
}

TEST(Passivity, TheObserverCountsTheWorkOfTheHeldForceOverTheMotionNotASampledVelocity) {
  PassivitySettings off;
  off.enabled = false;
  PassivityController pc(limits_with_damping(2.0), off);
  pc.control(Vec3::Zero(), Vec3::Zero(), Vec3::Zero(), 1e-3);
  pc.sent(Vec3(0, 2, 0), 1e-3);
  // The device reports no velocity (a bad estimate) but moved 1 mm down against 2 N: 2 mJ put in.
  pc.control(Vec3::Zero(), Vec3(0, -0.001, 0), Vec3::Zero(), 1e-3);
  EXPECT_NEAR(pc.energy(), 0.002, 1e-15);
}

TEST(Passivity, APassiveForceIsLeftAloneAndItsEnergyIsCounted) {
  PassivityController pc(limits_with_damping(2.0), {});
  Ticker t{pc};
  const Vec3 v(0, -0.05, 0), f(0, 2.0, 0);  // pressing into a tissue that pushes back
  for (int i = 0; i < 100; ++i) {
    EXPECT_EQ(t.tick(f, v), f);
    EXPECT_EQ(pc.damping(), 0.0);
  }
  // 99 ticks' work observed (the first tick's motion had nothing held yet).
  EXPECT_NEAR(pc.energy(), 99 * 2.0 * 0.05 * 1e-3, 1e-12);
  EXPECT_EQ(pc.counters().active_ticks, 0u);
}

TEST(Passivity, TheDampingIsCappedBelowTheDevicesOwnLimitAndTheDeficitCarriedOn) {
  PassivityController pc(limits_with_damping(2.0), instant());  // cap 0.9 · 2 = 1.8 N·s/m
  Ticker t{pc};
  EXPECT_DOUBLE_EQ(pc.max_damping(), 1.8);
  const Vec3 v(0.1, 0, 0), f(1, 0, 0);
  const Vec3 out = t.tick(f, v);
  EXPECT_DOUBLE_EQ(pc.damping(), 1.8);
  EXPECT_NEAR(out.x(), 1.0 - 1.8 * 0.1, 1e-12);
  EXPECT_EQ(pc.counters().capped_ticks, 1u);
  t.tick(Vec3::Zero(), v);
  EXPECT_LT(pc.energy(), -7e-5);  // (1 − 0.18) N over 0.1 mm: not all absorbed, carried on
  // The deficit stays until the damping has paid it back, tick after tick, the request zero.
  int ticks = 0;
  while (pc.energy() < 0 && ticks < 20) t.tick(Vec3::Zero(), v), ++ticks;
  EXPECT_GE(pc.energy(), -1e-15);
  EXPECT_GT(ticks, 2);
}

TEST(Passivity, TheDampingRisesAndFallsOverItsRiseTimeNeverSteppingTheForce) {
  PassivitySettings p;
  p.damping_rise = 0.01;
  PassivityController pc(limits_with_damping(2.0), p);  // cap 1.8 N·s/m, reached over 10 ms
  Ticker t{pc};
  const Vec3 v(0.1, 0, 0), f(1, 0, 0);
  Vec3 last = f;
  for (int i = 1; i <= 12; ++i) {
    const Vec3 out = t.tick(f, v);
    EXPECT_NEAR(pc.damping(), std::min(1.8, 0.18 * i), 1e-12) << "tick " << i;
    EXPECT_LE((out - last).norm(), 0.18 * 0.1 + 1e-12) << "tick " << i;  // α·v changes by 0.018 N a tick at most
    last = out;
  }
  // The hand turned back against the force (passive): once the deficit is paid back the damping
  // goes as it came, 0.18 N·s/m a tick: the force changes by α's step times |v| a tick, no more.
  int ticks = 0, falling = 0;
  Vec3 prev = t.tick(f, -v);
  double alpha = pc.damping();
  while (pc.damping() > 0 && ticks < 200) {
    const Vec3 out = t.tick(f, -v);
    EXPECT_LE((out - prev).norm(), 0.18 * 0.1 + 1e-12) << "tick " << ticks;
    falling += pc.damping() < alpha;
    alpha = pc.damping(), prev = out, ++ticks;
  }
  EXPECT_EQ(pc.damping(), 0.0);
  EXPECT_GE(falling, 9);
}

TEST(Passivity, SlowMotionIsDampedAsIfAtTheVelocityFloor) {
  PassivityController pc(limits_with_damping(1e6), instant());  // no cap in the way
  Ticker t{pc};
  t.tick(Vec3(1, 0, 0), Vec3(1e-4, 0, 0));
  // |v|² = 1e-8 is floored at 1e-4: α = f·v·dt / (dt · 1e-4) = 1 N·s/m, not 1e4.
  EXPECT_NEAR(pc.damping(), 1.0, 1e-9);
}

TEST(Passivity, StoredEnergyIsKeptWhileTheToolIsLoadedAndForgottenOnceFree) {
  PassivityController pc(limits_with_damping(2.0), {});
  Ticker t{pc};
  const Vec3 up(0, 2, 0), in(0, -0.1, 0), out(0, 0.1, 0);
  t.tick(up, Vec3::Zero());  // the tissue pushing back before the hand moves
  // Press in 5 mm against 2 N: the tissue stores 0.01 J (the hand's work).
  for (int i = 0; i < 50; ++i) t.tick(up, in);
  const double stored = pc.energy();
  EXPECT_NEAR(stored, 0.01, 1e-12);
  // Held still, loaded, for a second: the energy may come back, so nothing is forgotten.
  for (int i = 0; i < 1000; ++i) t.tick(up, Vec3::Zero());
  EXPECT_DOUBLE_EQ(pc.energy(), stored);
  // It comes back as the hand lets the tissue push it out: no damping is added on the way (the
  // tissue's force gone as the hand reaches where it touched first).
  for (int i = 0; i < 49; ++i) {
    t.tick(up, out);
    EXPECT_EQ(pc.damping(), 0.0) << "tick " << i;
  }
  t.tick(Vec3::Zero(), out);
  EXPECT_EQ(pc.damping(), 0.0);
  EXPECT_NEAR(pc.energy(), 0.0, 1e-12);
  // A credit (dissipated energy: pressed in, then the force gone) is forgotten after one window
  // free of force, not before.
  t.tick(up, Vec3::Zero());
  for (int i = 0; i < 50; ++i) t.tick(up, in);
  EXPECT_NEAR(pc.energy(), 0.01, 1e-12);
  for (int i = 0; i < 29; ++i) t.tick(Vec3::Zero(), out);
  EXPECT_NEAR(pc.energy(), 0.01 - 2e-4, 1e-12);  // the first of them moved under the held 2 N
  t.tick(Vec3::Zero(), out);
  EXPECT_EQ(pc.energy(), 0.0);
}

TEST(Passivity, ADeficitIsNeverForgotten) {
  PassivitySettings off;
  off.enabled = false;  // the observer alone
  PassivityController pc(limits_with_damping(2.0), off);
  Ticker t{pc};
  EXPECT_EQ(t.tick(Vec3(1, 0, 0), Vec3(0.1, 0, 0)), Vec3(1, 0, 0));  // disabled: the request as it is
  EXPECT_EQ(pc.damping(), 0.0);
  t.tick(Vec3::Zero(), Vec3(0.1, 0, 0));
  EXPECT_NEAR(pc.energy(), -1e-4, 1e-15);
  for (int i = 0; i < 200; ++i) t.tick(Vec3::Zero(), Vec3(0.1, 0, 0));
  EXPECT_NEAR(pc.energy(), -1e-4, 1e-15);
  EXPECT_NEAR(pc.counters().min_energy, -1e-4, 1e-15);
}

TEST(Passivity, NonFiniteInputsPassThroughToTheSafetyFilterAndCountNoEnergy) {
  PassivityController pc(limits_with_damping(2.0), {});
  const Vec3 nan = Vec3::Constant(std::nan(""));
  EXPECT_FALSE(pc.control(nan, Vec3::Zero(), Vec3(0.1, 0, 0), 1e-3).allFinite());
  EXPECT_EQ(pc.damping(), 0.0);
  pc.sent(nan, 1e-3);  // held as zero
  EXPECT_EQ(pc.control(Vec3(1, 0, 0), Vec3(0.001, 0, 0), nan, 1e-3), Vec3(1, 0, 0));
  pc.sent(Vec3(1, 0, 0), 1e-3);
  pc.control(Vec3::Zero(), nan, Vec3::Zero(), 1e-3);  // no position: no motion measured
  EXPECT_EQ(pc.energy(), 0.0);
}

// --- Unstable settings, held by a hand.

// A stylus in a light grip: the device's and the hand's mass on the hand's spring (holding it
// `press` past the wall at y = 0, so it leans on the wall) with the hand's own light damping, moved
// by the force the loop last wrote; integrated at 10 kHz between the loop's reads (semi-implicit
// Euler). Its velocity is the device's own estimate: the true one. Its mechanical energy (kinetic,
// and the hand spring's) is kept at every read: the loop may only ever give back what the hand put in.
class HandDevice final : public palpate::Device {
 public:
  HandDevice(DeviceLimits limits, double mass, double hand_stiffness, double hand_damping, double press, double start_y)
      : limits_(limits), m_(mass), kh_(hand_stiffness), bh_(hand_damping), rest_(0, -press, 0) {
    x_ = Vec3(0, start_y, 0);
    trace.reserve(20000);
    energy.reserve(20000);
  }
  double hand_energy() const { return 0.5 * m_ * v_.squaredNorm() + 0.5 * kh_ * (x_ - rest_).squaredNorm(); }
  const DeviceLimits& limits() const override { return limits_; }
  bool read(double t, DeviceState& out) noexcept override {
    constexpr double h = 1e-4;
    while (time_ + h <= t + 1e-12) {
      const Vec3 a = (f_ - kh_ * (x_ - rest_) - bh_ * v_) / m_;
      v_ += h * a;
      x_ += h * v_;
      time_ += h;
    }
    out.time = t;
    out.position = x_;
    out.velocity = v_;
    out.orientation = Quat::Identity();
    if (trace.size() < trace.capacity()) trace.push_back(x_.y());
    if (energy.size() < energy.capacity()) energy.push_back(hand_energy());
    return true;
  }
  void write(const Vec3& force, const Vec3&) noexcept override { f_ = force; }
  std::vector<double> trace;   // y per read (m)
  std::vector<double> energy;  // J per read

 private:
  DeviceLimits limits_;
  double m_, kh_, bh_;
  Vec3 rest_;
  Vec3 x_ = Vec3::Zero(), v_ = Vec3::Zero(), f_ = Vec3::Zero();
  double time_ = 0;
};

// A stiff wall under y = 0 the way an unstable simulation renders it: its force from the position
// `delay` ticks ago (a transport delay), and recomputed only every `hold` ticks (a physics rate of
// 1/(hold · dt), the force held in between).
class LaggingWall final : public palpate::ToolForceModel {
 public:
  LaggingWall(double stiffness, int delay, int hold) : k_(stiffness), delay_(delay), hold_(hold) {}
  Vec3 force(const Vec3& position, const Quat&, double) noexcept override {
    history_[n_ % history_.size()] = position.y();
    const double y = history_[(n_ + history_.size() - size_t(std::min<int>(delay_, int(n_)))) % history_.size()];
    if (n_ % size_t(hold_) == 0) held_ = Vec3(0, k_ * std::max(0.0, -y), 0);
    ++n_;
    return held_;
  }

 private:
  double k_;
  int delay_, hold_;
  std::array<double, 64> history_{};
  size_t n_ = 0;
  Vec3 held_ = Vec3::Zero();
};

struct WallRun {
  double start = 0;         // J, the hand's energy at the start (its spring, leaning on the wall)
  double peak = 0;          // J, its largest energy over the run
  double growth_per_s = 0;  // 1/s, ln(peak of 0.5–1 s / peak of 0–0.5 s) / 0.5 s: the instability's growth rate
  double min_energy = 0;    // J, the observer's lowest E
  palpate::PassivityCounters pc;
};

WallRun measure(const HandDevice& hand, const palpate::PassivityCounters& pc, double start) {
  WallRun r;
  r.start = start;
  r.pc = pc;
  r.min_energy = pc.min_energy;
  r.peak = *std::max_element(hand.energy.begin(), hand.energy.end());
  const double a = *std::max_element(hand.energy.begin(), hand.energy.begin() + 500);
  const double b = *std::max_element(hand.energy.begin() + 500, hand.energy.begin() + 1000);
  r.growth_per_s = std::log(b / a) / 0.5;
  return r;
}

// 4 s of the hand leaning on a lagging wall through the loop's second tool (tool 0 idle).
WallRun lean_on_wall(int delay, int hold, double k, bool passivity) {
  DeviceLimits lim;
  lim.max_force = 20.0;        // an omega-class device: the oscillation grows before any clamp
  lim.max_force_rate = 1e4;    // N/s: no rate limit in the way either
  lim.damping = 10.0;          // N·s/m, the device's damping limit (the controller's cap: 9)
  HandDevice hand(lim, 0.1, 100.0, 0.3, 0.005, 0.0);
  LaggingWall wall(k, delay, hold);
  palpate::test::FunctionDevice idle([](long) { return Vec3(0, 1, 0); }, 1e-3, 5000);
  palpate::LoopSettings s;
  s.realtime = false;
  s.ramp_in = 0;
  palpate::LoopTool t{"hand", &hand, &wall, 0.0, std::nullopt, {}};
  t.passivity.enabled = passivity;
  auto loop = palpate::HapticLoop::create(idle, {}, s, {t});
  EXPECT_TRUE(loop) << (loop ? "" : loop.error().message);
  WallRun r;
  if (!loop) return r;
  const double start = hand.hand_energy();
  (*loop)->run_headless(4000);
  return measure(hand, (*loop)->stats().tools.at(0).passivity, start);
}

// Without the controller the hand ends with many times the energy it started with (the loop gave it
// energy, the observer sees E < 0 by far more than ε); with it the hand never has more than it
// started with (plus 10 %: the observer samples f·v once a tick, the hand moves in between), and the
// observed energy never goes below −ε = 0.1 mJ (the cap on α can leave a few ticks' deficit).
void expect_unstable_then_held(const char* what, const WallRun& off, const WallRun& on) {
  std::printf("%s: hand energy %.3g J at the start; without the controller peak %.3g J (growth %.1f /s), "
              "lowest E %.3g J; with it peak %.3g J (growth %.1f /s), lowest E %.3g J, damping on %llu ticks "
              "(capped %llu), %.3g J absorbed\n",
              what, off.start, off.peak, off.growth_per_s, off.min_energy, on.peak, on.growth_per_s, on.min_energy,
              (unsigned long long)on.pc.active_ticks, (unsigned long long)on.pc.capped_ticks, on.pc.dissipated);
  EXPECT_GT(off.peak, 3.0 * off.start) << what;
  EXPECT_GT(off.growth_per_s, 0.5) << what;
  EXPECT_LT(off.min_energy, -1e-2) << what;
  EXPECT_LE(on.peak, 1.1 * on.start) << what;
  EXPECT_GT(on.pc.active_ticks, 0u) << what;
  EXPECT_GT(on.min_energy, -1e-4) << what;
}

TEST(Passivity, AStiffWallSampledAtALowPhysicsRateIsHeld) {
  expect_unstable_then_held("wall at 100 Hz", lean_on_wall(0, 10, 600.0, false), lean_on_wall(0, 10, 600.0, true));
}

TEST(Passivity, AWallSeenThroughADelayOfSeveralTicksIsHeld) {
  expect_unstable_then_held("wall 5 ticks late", lean_on_wall(5, 1, 600.0, false), lean_on_wall(5, 1, 600.0, true));
}

// A virtual coupling tuned too stiff (the device's stiffness limit set to 30 kN/m, past what a
// 1 kHz loop renders on this hand: Colgate's b > K·T/2) between the hand and a proxy on a
// bone-stiff floor (100 kN/m).
WallRun lean_through_coupling(bool passivity) {
  DeviceLimits lim;
  lim.max_force = 20.0;
  lim.max_force_rate = 1e4;
  lim.stiffness = 30000.0;
  lim.damping = 20.0;  // a stiffer device than the walls' (the controller's cap: 18 N·s/m)
  palpate::LoopSettings s;
  s.realtime = false;
  s.ramp_in = 0;
  s.coupling = palpate::Coupling::virtual_;
  s.proxy_mass = 1e-5;  // its coupling damping 2·sqrt(k·m) = 1.1 N·s/m
  s.tool.radius = 0.002;
  s.passivity.enabled = passivity;
  HandDevice hand(lim, 0.1, 100.0, 0.3, 0.005 - s.tool.radius, s.tool.radius);
  palpate::test::FloorWithJacobian floor(1e5);
  auto loop = palpate::HapticLoop::create(hand, {{&floor, 0.0}}, s);
  EXPECT_TRUE(loop) << (loop ? "" : loop.error().message);
  WallRun r;
  if (!loop) return r;
  const double start = hand.hand_energy();
  (*loop)->run_headless(4000);
  return measure(hand, (*loop)->stats().passivity, start);
}

TEST(Passivity, AVirtualCouplingTunedTooStiffIsHeld) {
  expect_unstable_then_held("coupling too stiff", lean_through_coupling(false), lean_through_coupling(true));
}

// The charged model's puncture is a step-wise drop of the force while the needle goes on in: the
// tissue lets go of energy the hand put in, never gives any. Through the three layers of the
// default scene (three punctures, three drops) the observer never sees the hand receive energy it
// did not put in, and the controller never acts.
TEST(Passivity, ThePunctureReleaseOfTheChargedModelIsPassive) {
  auto scene = palpate::load_scene(std::filesystem::path(PALPATE_DATA_DIR) / "scenes/default.yaml");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  palpate::RunOptions o;
  o.out = std::filesystem::temp_directory_path() / "palpate_test_passivity_puncture";
  o.plots = false;
  auto r = palpate::run_scene(*scene, o);
  ASSERT_TRUE(r.ok()) << r.error().message;
  int punctures = 0;
  for (const auto& e : r->events) punctures += e.kind == "puncture";
  EXPECT_EQ(punctures, 3);
  EXPECT_TRUE(scene->device.passivity);
  EXPECT_EQ(r->passivity.active_ticks, 0u);
  EXPECT_GE(r->passivity.min_energy, -1e-9);
  std::error_code ec;
  std::filesystem::remove_all(o.out, ec);
}

}  // namespace
