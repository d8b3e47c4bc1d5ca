// patch_contact.cpp — the haptic thread's penalty contact against a compliant patch (issue 24).
#include "haptics/patch_contact.h"

#include "core/triangle.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace palpate {

namespace {

struct Geometry {
  double depth = 0;             // Φ, m
  Vec3 direction = Vec3::Zero();  // Σ ω_t n_t (unit when in contact)
  int loaded = 0;               // points with g ≠ 0
  bool behind = false;          // no triangle within r and the centre is behind the nearest one
};

// Φ, the unit direction and g at positions y (scratch.position); g into scratch.g for the loaded
// points (zeroed first).
Geometry contact_geometry(const ContactPatch& patch, const Vec3& c, double r, PatchScratch& s) noexcept {
  Geometry out;
  for (int i = 0; i < patch.point_count; ++i) s.g[static_cast<size_t>(i)].setZero();
  Vec3 resultant = Vec3::Zero();
  double nearest_d2 = std::numeric_limits<double>::infinity(), nearest_cos = 0;
  struct Hit { int tri; double dist; Vec3 w, n; };
  std::array<Hit, ContactPatch::kMaxTriangles> hits;
  int nhits = 0;
  for (int t = 0; t < patch.triangle_count; ++t) {
    const auto& T = patch.triangle[static_cast<size_t>(t)];
    const Vec3& a = s.position[static_cast<size_t>(T[0])];
    const Vec3& b = s.position[static_cast<size_t>(T[1])];
    const Vec3& q = s.position[static_cast<size_t>(T[2])];
    Vec3 w;
    const Vec3 p = closest_on_triangle(c, a, b, q, w);
    const double d2 = (c - p).squaredNorm();
    const Vec3 nf = (b - a).cross(q - a);
    const double side = (c - p).dot(nf);
    if (d2 < nearest_d2) {
      nearest_d2 = d2;
      const double len = nf.norm() * std::sqrt(d2);
      nearest_cos = len > 0 ? side / len : 0.0;
    }
    if (d2 >= r * r || side < 0) continue;  // out of reach, or the back of the surface
    const double d = std::sqrt(d2);
    if (!(d > 1e-12 * r)) continue;  // the centre on the surface: no direction
    hits[static_cast<size_t>(nhits++)] = Hit{t, d, w, (c - p) / d};
    out.depth = std::max(out.depth, r - d);
    resultant += (r - d) * hits[static_cast<size_t>(nhits - 1)].n;
  }
  if (nhits == 0) {
    out.behind = nearest_d2 < std::numeric_limits<double>::infinity() && nearest_cos < 0;
    return out;
  }
  const double sum = resultant.norm();
  if (!(sum > 0)) return out;
  out.direction = resultant / sum;
  for (int k = 0; k < nhits; ++k) {
    const Hit& h = hits[static_cast<size_t>(k)];
    const double weight = (r - h.dist) / sum;
    const auto& T = patch.triangle[static_cast<size_t>(h.tri)];
    for (int q = 0; q < 3; ++q)
      if (h.w[q] > 0) s.g[static_cast<size_t>(T[static_cast<size_t>(q)])] += weight * h.w[q] * h.n;
  }
  for (int i = 0; i < patch.point_count; ++i)
    if (!s.g[static_cast<size_t>(i)].isZero(0)) s.loaded[static_cast<size_t>(out.loaded++)] = i;
  return out;
}

}  // namespace

PatchContact solve_patch(const ContactPatch& patch, const Vec3& centre, double radius, double max_stiffness,
                         PatchScratch& s, double elapsed, int max_iterations) noexcept {
  PatchContact out;
  const int m = patch.point_count;
  if (m <= 0 || m > ContactPatch::kMaxPoints || patch.triangle_count > ContactPatch::kMaxTriangles ||
      !centre.allFinite() || !(radius > 0) || !((centre - patch.centre).norm() <= patch.reach))
    return out;
  const double k = std::min(patch.stiffness, std::max(0.0, max_stiffness));
  const size_t M = static_cast<size_t>(m);
  // The free positions now: moved on with the points' velocity since the step.
  const double tau = std::isfinite(elapsed) ? std::max(0.0, elapsed) : 0.0;
  std::array<Vec3, ContactPatch::kMaxPoints>& free = s.free;
  for (size_t i = 0; i < M; ++i) {
    free[i] = patch.free_position[i] + tau * patch.free_velocity[i];
    s.position[i] = free[i];
  }
  double f = 0, w_last = 0;
  Geometry geo;
  for (int it = 0; it < max_iterations; ++it) {
    geo = contact_geometry(patch, centre, radius, s);
    out.iterations = it + 1;
    if (geo.behind) return out;  // inside the organ past the radius: not this solve's case
    if (geo.loaded == 0) { f = 0; break; }
    // w = gᵀ W g over the loaded points.
    double w = 0;
    for (int a = 0; a < geo.loaded; ++a) {
      const size_t i = static_cast<size_t>(s.loaded[static_cast<size_t>(a)]);
      for (int b = 0; b < geo.loaded; ++b) {
        const size_t j = static_cast<size_t>(s.loaded[static_cast<size_t>(b)]);
        w += patch.compliance[i * M + j] * s.g[i].dot(s.g[j]);
      }
    }
    w = std::max(0.0, w);
    w_last = w;
    double f_new = std::max(0.0, k * (geo.depth + w * f) / (1 + k * w));
    // The geometry moves with the load (which triangles press, their weights): past the first
    // iterations, half steps keep the iteration from cycling between two contact sets.
    if (it >= 2) f_new = 0.5 * (f_new + f);
    const bool converged = std::abs(f_new - f) <= 1e-9 * (1 + f_new);
    f = f_new;
    // The points under the load −F g: y_i = x_free,i − F Σ_j W_ij g_j.
    for (size_t i = 0; i < M; ++i) {
      Vec3 d = Vec3::Zero();
      for (int b = 0; b < geo.loaded; ++b) {
        const size_t j = static_cast<size_t>(s.loaded[static_cast<size_t>(b)]);
        d += patch.compliance[i * M + j] * s.g[j];
      }
      s.position[i] = free[i] - f * d;
    }
    if (converged) break;
  }
  out.force = f * geo.direction;
  out.depth = f > 0 && k > 0 ? f / k : 0.0;
  out.stiffness = f > 0 ? k / (1 + k * w_last) : 0.0;
  out.valid = out.force.allFinite();
  if (!out.valid) out.force.setZero();
  return out;
}

}  // namespace palpate
