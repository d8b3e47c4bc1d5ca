// test_safety.cpp — the force safety filter: finite, clamped, ramped, rate-limited, always.
#include <palpate/safety.h>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

using palpate::DeviceLimits;
using palpate::ForceSafety;
using palpate::Vec3;

namespace {
DeviceLimits touch() {
  DeviceLimits l;
  l.max_force = 3.3;
  l.max_force_rate = 200.0;
  return l;
}
constexpr double kDt = 0.001;
}  // namespace

TEST(Safety, ClampsToDeviceMaximumKeepingDirection) {
  ForceSafety s(touch(), 0.0);
  Vec3 f = Vec3::Zero();
  for (int i = 0; i < 1000; ++i) f = s.filter(Vec3(30, 40, 0), kDt, true);
  EXPECT_NEAR(f.norm(), 3.3, 1e-12);
  EXPECT_NEAR(f.x() / f.y(), 0.75, 1e-12);
  EXPECT_GT(s.counters().clamped, 0u);
}

TEST(Safety, NonFiniteForceGivesZeroAndIsCounted) {
  ForceSafety s(touch(), 0.0);
  for (int i = 0; i < 100; ++i) s.filter(Vec3(0, 1, 0), kDt, true);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  Vec3 f = s.filter(Vec3(nan, 0, 0), kDt, true);
  EXPECT_TRUE(f.allFinite());
  // Going to zero is itself rate-limited: no kick, even when dropping the force.
  EXPECT_LE((f - Vec3(0, 1, 0)).norm(), 200.0 * kDt + 1e-12);
  for (int i = 0; i < 100; ++i) f = s.filter(Vec3(std::numeric_limits<double>::infinity(), 0, 0), kDt, true);
  EXPECT_EQ(f, Vec3::Zero());
  EXPECT_EQ(s.counters().non_finite, 101u);
}

TEST(Safety, FailedStepGivesZeroForce) {
  ForceSafety s(touch(), 0.0);
  Vec3 f;
  for (int i = 0; i < 100; ++i) f = s.filter(Vec3(0, 2, 0), kDt, true);
  ASSERT_NEAR(f.y(), 2.0, 1e-12);
  for (int i = 0; i < 20; ++i) f = s.filter(Vec3(0, 2, 0), kDt, false);
  EXPECT_EQ(f, Vec3::Zero());
  EXPECT_EQ(s.counters().step_failed, 20u);
}

TEST(Safety, RampsInFromZeroOverRampTime) {
  DeviceLimits fast = touch();
  fast.max_force_rate = 1e9;  // isolate the ramp from the rate limit
  ForceSafety r(fast, 0.1);
  double prev = -1;
  for (int i = 0; i < 100; ++i) {
    const Vec3 f = r.filter(Vec3(0, 1, 0), kDt, true);
    EXPECT_NEAR(f.y(), i * kDt / 0.1, 1e-9) << "tick " << i;
    EXPECT_GT(f.y(), prev);
    prev = f.y();
  }
  EXPECT_NEAR(r.filter(Vec3(0, 1, 0), kDt, true).y(), 1.0, 1e-12);
}

TEST(Safety, AdversarialInputNeverLeavesLimits) {
  // Random forces of any size, NaNs, infinities, sign flips every tick (500 Hz oscillation):
  // what leaves is finite, within the maximum, and changes by at most the rate limit per tick.
  ForceSafety s(touch(), 0.05);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1e6, 1e6);
  Vec3 last = Vec3::Zero();
  for (int i = 0; i < 20000; ++i) {
    Vec3 in(u(rng), u(rng), u(rng));
    if (i % 97 == 0) in.x() = std::numeric_limits<double>::quiet_NaN();
    if (i % 101 == 0) in.y() = -std::numeric_limits<double>::infinity();
    if (i > 10000) in = Vec3(0, (i % 2) ? 1e3 : -1e3, 0);
    const Vec3 f = s.filter(in, kDt, i % 333 != 0);
    ASSERT_TRUE(f.allFinite());
    ASSERT_LE(f.norm(), 3.3 + 1e-12);
    ASSERT_LE((f - last).norm(), 200.0 * kDt + 1e-9) << "tick " << i;
    last = f;
  }
}
