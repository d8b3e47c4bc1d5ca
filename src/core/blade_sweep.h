// blade_sweep.h — the surface a blade's cutting edge sweeps over one tick, and which segments
// (springs, neighbour links) cross it: the one test both tissue models cut with.
#pragma once

#include <palpate/core.h>

#include <algorithm>
#include <cmath>

namespace palpate {

// The edge at the last tick (a0 → b0) and now (a1 → b1); a = the heel (tip − length·axis), b = the
// tip. The swept surface is the bilinear patch between them, taken as the two triangles
// (a0, b0, b1) and (a0, b1, a1). A blade that did not move sweeps nothing (zero area).
struct BladeSweep {
  Vec3 a0 = Vec3::Zero(), b0 = Vec3::Zero(), a1 = Vec3::Zero(), b1 = Vec3::Zero();
};

// The edge of a blade tool: heel = tip − length·axis, tip.
inline BladeSweep blade_sweep(const Vec3& tip_before, const Vec3& axis_before, const Vec3& tip_now,
                              const Vec3& axis_now, double length) noexcept {
  return {tip_before - length * axis_before, tip_before, tip_now - length * axis_now, tip_now};
}

// Whether segment p → q crosses triangle (a, b, c), and where along p → q (t in [0, 1]):
// Möller & Trumbore 1997 on the segment. A segment in the triangle's plane does not cross it.
inline bool segment_crosses_triangle(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c,
                                     double* at = nullptr) noexcept {
  const Vec3 d = q - p, e1 = b - a, e2 = c - a;
  const Vec3 h = d.cross(e2);
  const double det = e1.dot(h);
  const double scale = d.norm() * e1.norm() * e2.norm();
  if (!(std::abs(det) > 1e-12 * scale)) return false;  // parallel, degenerate or not finite
  const double inv = 1.0 / det;
  const Vec3 s = p - a;
  const double u = inv * s.dot(h);
  if (u < 0 || u > 1) return false;
  const Vec3 g = s.cross(e1);
  const double v = inv * d.dot(g);
  if (v < 0 || u + v > 1) return false;
  const double t = inv * e2.dot(g);
  if (t < 0 || t > 1) return false;
  if (at) *at = t;
  return true;
}

// Whether segment p → q crosses the swept surface of `s` (either triangle).
inline bool segment_crosses_sweep(const Vec3& p, const Vec3& q, const BladeSweep& s, double* at = nullptr) noexcept {
  return segment_crosses_triangle(p, q, s.a0, s.b0, s.b1, at) || segment_crosses_triangle(p, q, s.a0, s.b1, s.a1, at);
}

// The axis-aligned box around the sweep, grown by `margin` (m): a cheap cull before the test.
inline void sweep_bounds(const BladeSweep& s, double margin, Vec3& lo, Vec3& hi) noexcept {
  lo = s.a0.cwiseMin(s.b0).cwiseMin(s.a1).cwiseMin(s.b1) - Vec3::Constant(margin);
  hi = s.a0.cwiseMax(s.b0).cwiseMax(s.a1).cwiseMax(s.b1) + Vec3::Constant(margin);
}

}  // namespace palpate
