// triangle.h — the point of a triangle closest to a point: one routine for the mass-spring model's
// surface contact and the haptic thread's contact against a compliant patch.
#pragma once

#include <palpate/core.h>

namespace palpate {

// The point of triangle (a, b, c) closest to p, and its barycentric weights (Ericson 2005, "Real-Time
// Collision Detection", §5.1.5).
inline Vec3 closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, Vec3& w) noexcept {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) { w = Vec3(1, 0, 0); return a; }
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) { w = Vec3(0, 1, 0); return b; }
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double t = d1 / (d1 - d3);
    w = Vec3(1 - t, t, 0);
    return a + t * ab;
  }
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) { w = Vec3(0, 0, 1); return c; }
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double t = d2 / (d2 - d6);
    w = Vec3(1 - t, 0, t);
    return a + t * ac;
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    w = Vec3(0, 1 - t, t);
    return b + t * (c - b);
  }
  const double denom = 1.0 / (va + vb + vc);
  const double v = vb * denom, u = vc * denom;
  w = Vec3(1 - v - u, v, u);
  return a + v * ab + u * ac;
}

}  // namespace palpate
