// test_coupling.cpp — virtual coupling: device limits respected, critical damping, a stiff tissue
// felt through the coupling spring in series; the secant stiffness estimate and its passivity.
#include <palpate/haptics.h>

#include "haptics/contact.h"
#include "haptics/doubles.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

using palpate::Mat3;
using palpate::Vec3;
using namespace palpate::test;

TEST(HapticCoupling, StiffnessWithinDeviceLimitDampingCritical) {
  palpate::DeviceLimits l;
  l.stiffness = 1000.0;
  l.damping = 2.0;
  auto c = palpate::make_coupling(l, 0.001);
  EXPECT_EQ(c.stiffness, 1000.0);
  EXPECT_NEAR(c.damping, 2.0 * std::sqrt(1000.0 * 0.001), 1e-12);  // critical: exactly the limit
  c = palpate::make_coupling(l, 0.0001);
  EXPECT_NEAR(c.damping, 2.0 * std::sqrt(0.1), 1e-12);
  c = palpate::make_coupling(l, 0.01);  // critical would be 6.3 N·s/m: clamped to the device's 2
  EXPECT_EQ(c.damping, 2.0);
  EXPECT_EQ(palpate::make_coupling(l, 0.001, 5000.0).stiffness, 1000.0);
  EXPECT_EQ(palpate::make_coupling(l, 0.001, 400.0).stiffness, 400.0);
}

namespace {
// Approach a floor slowly, then hold the device 2 mm below its contact height.
Vec3 approach_and_hold(long k) {
  const double y = k < 500 ? 0.003 - 0.004 * double(k) / 500.0 : -0.001;
  return Vec3(0, y, 0);
}
}  // namespace

TEST(HapticCoupling, StiffFloorSettlesToSeriesSpringForce) {
  // A 1e5 N/m floor is far stiffer than a Touch can render: directly it only saturates at 3.3 N.
  // Through the coupling (k_c = 1000 N/m) the hand feels the two springs in series:
  //   F = k_c·k_t / (k_c + k_t) · d, with d = 2 mm the device's depth.
  const double kt = 1e5, kc = 1000.0, depth = 0.002;
  LinearFloor floor(kt);
  FunctionDevice dev(&approach_and_hold, 0.001, 2000);
  palpate::LoopSettings s;
  s.realtime = false;
  s.ramp_in = 0;
  s.coupling = palpate::Coupling::virtual_;
  s.proxy_mass = 0.001;
  auto loop = palpate::HapticLoop::create(dev, {{&floor, 0.0}}, s);
  ASSERT_TRUE(loop.ok()) << loop.error().message;
  (*loop)->run_headless(2000);
  const double expected = kc * kt / (kc + kt) * depth;
  EXPECT_NEAR(dev.written.back().y(), expected, 1e-6);
  // Stable: no growing oscillation while held.
  double lo = 1e9, hi = -1e9;
  for (size_t k = 1500; k < 2000; ++k) {
    lo = std::min(lo, dev.written[k].y());
    hi = std::max(hi, dev.written[k].y());
    ASSERT_LE(dev.written[k].norm(), 3.3 + 1e-12);
  }
  EXPECT_LT(hi - lo, 1e-6);

  // The same floor rendered directly saturates at the device's maximum.
  LinearFloor floor2(kt);
  FunctionDevice dev2(&approach_and_hold, 0.001, 2000);
  s.coupling = palpate::Coupling::direct;
  auto direct = palpate::HapticLoop::create(dev2, {{&floor2, 0.0}}, s);
  ASSERT_TRUE(direct.ok());
  (*direct)->run_headless(2000);
  EXPECT_NEAR(dev2.written.back().y(), 3.3, 1e-9);
}

TEST(HapticCoupling, BroydenRecoversLinearJacobianFromOrthogonalSteps) {
  const Mat3 r = Eigen::AngleAxisd(0.3, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  const Mat3 truth = -(r * Vec3(100, 200, 300).asDiagonal() * r.transpose());
  Mat3 j = Mat3::Zero();
  for (int i = 0; i < 3; ++i) {
    const Vec3 dx = 1e-4 * Vec3::Unit(i);
    palpate::broyden_update(j, dx, truth * dx);
  }
  EXPECT_LT((j - truth).norm(), 1e-9);
  // A step too small to carry information changes nothing.
  const Mat3 before = j;
  palpate::broyden_update(j, Vec3(1e-9, 0, 0), Vec3(1, 1, 1));
  EXPECT_EQ(j, before);
}

TEST(HapticCoupling, PassiveProjectionIsSymmetricAndWithinLimits) {
  Mat3 j;
  j << -5000, 10, 0,  //
      30, 50, 0,      // a positive (active) direction, and asymmetry
      0, 0, -200;
  const Mat3 p = palpate::make_passive(j, 1000.0);
  EXPECT_LT((p - p.transpose()).norm(), 1e-12);
  Eigen::SelfAdjointEigenSolver<Mat3> es(p);
  for (int i = 0; i < 3; ++i) {
    EXPECT_LE(es.eigenvalues()[i], 1e-9);
    EXPECT_GE(es.eigenvalues()[i], -1000.0 - 1e-9);
  }
  EXPECT_NEAR(p(2, 2), -200.0, 1e-9);  // an already passive, decoupled direction is kept
  Mat3 nan = Mat3::Zero();
  nan(0, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(palpate::make_passive(nan, 1000.0), Mat3::Zero());
}

TEST(HapticCoupling, ALinearisedContactOnlyPushes) {
  // A contact linearised at a physics step (multi-rate): F0 + J·(x − x0) while it pushes along F0;
  // nothing where the step had no contact, whatever J was learnt before (the tool free above a
  // slow organ, moved sideways, was sent 2.8 N), and nothing once the tool leaves.
  palpate::ContactLinearisation c;
  c.x0 = Vec3(0.008, 0.005, 0);
  c.jacobian << -355, 0, 0, 0, -500, 0, 0, 0, -100;
  EXPECT_EQ(c.force_at(Vec3(0, 0.005, 0)), Vec3::Zero()) << "free at the step: free between steps";
  c.f0 = Vec3(0, 1.0, 0);
  EXPECT_TRUE(c.force_at(Vec3(0.008, 0.004, 0)).isApprox(Vec3(0, 1.5, 0)));  // 1 mm further in
  EXPECT_TRUE(c.force_at(Vec3(0.007, 0.005, 0)).isApprox(Vec3(0.355, 1.0, 0)));
  EXPECT_EQ(c.force_at(Vec3(0.008, 0.0071, 0)), Vec3::Zero()) << "2.1 mm out: the linear force would pull";
  EXPECT_NEAR(c.force_at(Vec3(0.008, 0.0069, 0)).y(), 0.05, 1e-9) << "1.9 mm out: still pushing, continuous";
}
