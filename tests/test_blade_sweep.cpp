// test_blade_sweep.cpp — the swept surface of a blade's edge and the segments that cross it
// (src/core/blade_sweep.h): the one geometric test both tissue models cut with.
#include "core/blade_sweep.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace palpate {
namespace {

// A blade held upright (edge along y, 5 mm long, tip at y = 0) drawn 10 mm along +x.
BladeSweep drawn_along_x() { return blade_sweep(Vec3(0, 0, 0), Vec3(0, -1, 0), Vec3(0.01, 0, 0), Vec3(0, -1, 0), 0.005); }

TEST(BladeSweep, TheEdgeRunsFromTheHeelToTheTip) {
  const BladeSweep s = drawn_along_x();
  EXPECT_TRUE(s.b0.isApprox(Vec3(0, 0, 0)));
  EXPECT_TRUE(s.a0.isApprox(Vec3(0, 0.005, 0)));  // heel = tip − length·axis, axis points down
  EXPECT_TRUE(s.b1.isApprox(Vec3(0.01, 0, 0)));
}

TEST(BladeSweep, ASegmentAcrossTheSweptStripIsCutAtItsCrossing) {
  const BladeSweep s = drawn_along_x();
  // A spring along z through the strip at x = 4 mm, y = 2 mm: crossed halfway along it.
  double t = -1;
  EXPECT_TRUE(segment_crosses_sweep(Vec3(0.004, 0.002, -0.001), Vec3(0.004, 0.002, 0.001), s, &t));
  EXPECT_NEAR(t, 0.5, 1e-12);
  // Both triangles of the strip cut: near the start's heel and near the end's tip.
  EXPECT_TRUE(segment_crosses_sweep(Vec3(0.0005, 0.0045, -0.001), Vec3(0.0005, 0.0045, 0.001), s));
  EXPECT_TRUE(segment_crosses_sweep(Vec3(0.0095, 0.0005, -0.001), Vec3(0.0095, 0.0005, 0.001), s));
}

TEST(BladeSweep, SegmentsBesideBelowOrBeyondTheStripAreNotCut) {
  const BladeSweep s = drawn_along_x();
  // Deeper than the tip went (y < 0), past the end (x > 10 mm), above the heel (y > 5 mm).
  EXPECT_FALSE(segment_crosses_sweep(Vec3(0.004, -0.0005, -0.001), Vec3(0.004, -0.0005, 0.001), s));
  EXPECT_FALSE(segment_crosses_sweep(Vec3(0.0105, 0.002, -0.001), Vec3(0.0105, 0.002, 0.001), s));
  EXPECT_FALSE(segment_crosses_sweep(Vec3(0.004, 0.0055, -0.001), Vec3(0.004, 0.0055, 0.001), s));
  // A segment that stops short of the strip's plane (z = 0).
  EXPECT_FALSE(segment_crosses_sweep(Vec3(0.004, 0.002, -0.002), Vec3(0.004, 0.002, -0.0001), s));
  // A segment lying in the strip's plane does not cross it.
  EXPECT_FALSE(segment_crosses_sweep(Vec3(0.001, 0.002, 0), Vec3(0.008, 0.002, 0), s));
}

TEST(BladeSweep, ABladeThatDidNotMoveOrHasNoLengthOrIsNotFiniteCutsNothing) {
  const Vec3 p(0, 0.002, -0.001), q(0, 0.002, 0.001);
  EXPECT_FALSE(segment_crosses_sweep(p, q, blade_sweep(Vec3::Zero(), Vec3(0, -1, 0), Vec3::Zero(), Vec3(0, -1, 0), 0.005)));
  EXPECT_FALSE(segment_crosses_sweep(p, q, blade_sweep(Vec3::Zero(), Vec3(0, -1, 0), Vec3(0.01, 0, 0), Vec3(0, -1, 0), 0.0)));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(segment_crosses_sweep(p, q, blade_sweep(Vec3::Zero(), Vec3(0, -1, 0), Vec3(nan, 0, 0), Vec3(0, -1, 0), 0.005)));
}

TEST(BladeSweep, ATurningBladeSweepsAFan) {
  // Tip fixed at the origin, the edge turned 90° from up (+y heel) to +x heel: it sweeps the
  // quarter between them, so a segment along z through (2 mm, 2 mm) — inside both triangles'
  // fan, within 5 mm of the tip — is cut, one at (4.5 mm, 4.5 mm) (beyond the chord) is not.
  const BladeSweep s = blade_sweep(Vec3::Zero(), Vec3(0, -1, 0), Vec3::Zero(), Vec3(-1, 0, 0), 0.005);
  EXPECT_TRUE(segment_crosses_sweep(Vec3(0.001, 0.001, -0.001), Vec3(0.001, 0.001, 0.001), s));
  EXPECT_FALSE(segment_crosses_sweep(Vec3(0.0045, 0.0045, -0.001), Vec3(0.0045, 0.0045, 0.001), s));
}

TEST(BladeSweep, TheBoundsHoldTheFourCornersAndTheMargin) {
  Vec3 lo, hi;
  sweep_bounds(drawn_along_x(), 0.001, lo, hi);
  EXPECT_TRUE(lo.isApprox(Vec3(-0.001, -0.001, -0.001)));
  EXPECT_TRUE(hi.isApprox(Vec3(0.011, 0.006, 0.001)));
}

}  // namespace
}  // namespace palpate
