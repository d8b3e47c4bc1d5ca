// neck_compression.cpp — the neck under the ultrasound probe (docs/ultrasound.md): the footprint's
// indentation of the skin gives the probe's force (a flat punch on an elastic half-space); the load,
// spread over the footprint as point loads, deforms the tissue (Boussinesq) and presses on the
// vessels, which answer with their tube laws: the vein collapses (Shapiro 1977), the artery keeps its
// round lumen and pulses (Hayashi's β law).
#include <palpate/anatomy.h>
#include <palpate/ultrasound.h>

#include <algorithm>
#include <cmath>

namespace palpate {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kOnset = 0.0005;  // m, the indentation over which the contact stiffens (C¹ start)
constexpr int kLoadsAlong = 9, kLoadsAcross = 3;
constexpr double kMinArea = 0.02;  // a collapsed vein keeps a slit: 2 % of its rest area

// Indentation with a smooth (C¹) start: δ²/(2e) up to e, then δ − e/2.
double smooth_indentation(double d) {
  if (d <= 0) return 0;
  return d < kOnset ? d * d / (2 * kOnset) : d - kOnset / 2;
}

// The probe's pressure pulse shape over one beat, 0 at the start of systole, 1 at its peak.
double pulse_shape(double phase) {
  constexpr double rise = 0.12, decay = 0.25;
  if (phase < rise) {
    const double s = std::sin(kPi * phase / (2 * rise));
    return s * s;
  }
  const double e1 = std::exp(-(1 - rise) / decay);
  return (std::exp(-(phase - rise) / decay) - e1) / (1 - e1);
}

double pulse_mean() {
  constexpr int n = 2000;
  double sum = 0;
  for (int i = 0; i < n; ++i) sum += pulse_shape((i + 0.5) / n);
  return sum / n;
}

// Shapiro's tube law: transmural pressure over K_p as a function of the area over the unloaded area.
double tube_law(double alpha) { return std::pow(alpha, 10.0) - std::pow(alpha, -1.5); }

// The area ratio α with tube_law(α) = p_over_k: Newton's method in ln α (tube_law is increasing
// and convex in it), safeguarded by the bracket [1e-4, 4]; to 1e-12 in a handful of steps.
double tube_area(double p_over_k) {
  double lo = std::log(1e-4), hi = std::log(4.0);
  if (tube_law(std::exp(lo)) >= p_over_k) return 1e-4;
  if (tube_law(std::exp(hi)) <= p_over_k) return 4.0;
  double y = p_over_k > 0 ? std::log(std::pow(p_over_k + 1, 0.1)) : -std::log(1 - p_over_k) / 1.5;
  y = std::clamp(y, lo, hi);
  for (int i = 0; i < 60; ++i) {
    const double a10 = std::exp(10 * y), am = std::exp(-1.5 * y);
    const double f = a10 - am - p_over_k, df = 10 * a10 + 1.5 * am;  // d/d(ln α)
    (f < 0 ? lo : hi) = y;
    double next = y - f / df;
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (std::abs(next - y) < 1e-13) return std::exp(next);
    y = next;
  }
  return std::exp(y);
}

// Ramanujan's perimeter of an ellipse with semi-axes a and a·k.
double ellipse_perimeter(double a, double k) {
  const double b = a * k, h = (a - b) * (a - b) / ((a + b) * (a + b));
  return kPi * (a + b) * (1 + 3 * h / (10 + std::sqrt(4 - 3 * h)));
}

// The ellipse with the rest circle's perimeter (the wall does not stretch as it flattens) and the
// given area ratio (< 1): its semi-axes a ≥ b. The tissue around the vessel keeps it from spreading
// sideways past kMaxSpread radii: flatter than that, the wall folds and only b shrinks.
constexpr double kMaxSpread = 1.3;
void flattened(double radius, double area_ratio, double& a, double& b) {
  const double perimeter = 2 * kPi * radius, area = area_ratio * kPi * radius * radius;
  double lo = 1e-4, hi = 1;  // k = b/a; the area grows with k at a fixed perimeter
  for (int i = 0; i < 50; ++i) {
    const double k = 0.5 * (lo + hi), ak = perimeter / ellipse_perimeter(1, k);
    (kPi * ak * ak * k < area ? lo : hi) = k;
  }
  const double k = 0.5 * (lo + hi);
  a = std::min(perimeter / ellipse_perimeter(1, k), kMaxSpread * radius);
  b = area / (kPi * a);
}

// The point of the ellipse x²/a² + y²/b² = 1 nearest (x0, y0), a point outside it (Eberly's
// parametrisation: x = a²x0/(t + a²), y = b²y0/(t + b²), t > 0 the root of a decreasing function,
// bisected).
Eigen::Vector2d nearest_on_ellipse(double a, double b, double x0, double y0) noexcept {
  const double ax = std::abs(x0), ay = std::abs(y0);
  auto g = [&](double t) {
    const double u = a * ax / (t + a * a), v = b * ay / (t + b * b);
    return u * u + v * v - 1;
  };
  double lo = 0, hi = std::max(a * ax, b * ay) + 1e-12;  // g(0) ≥ 0 outside, g(hi) < 0
  while (g(hi) > 0) hi *= 2;
  for (int k = 0; k < 64; ++k) {
    const double mid = 0.5 * (lo + hi);
    (g(mid) > 0 ? lo : hi) = mid;
  }
  const double t = 0.5 * (lo + hi);
  return Eigen::Vector2d(std::copysign(a * a * ax / (t + a * a), x0), std::copysign(b * b * ay / (t + b * b), y0));
}

}  // namespace

bool VesselSection::contains(const Vec3& p) const noexcept {
  Vec3 d = p - centre;
  d -= d.dot(axis) * axis;
  const double u = d.dot(minor_dir), v = d.dot(axis.cross(minor_dir));
  return (v * v) / (a * a) + (u * u) / (b * b) < 1;
}

NeckCompression::NeckCompression(const NeckDef& neck, const ProbeDef& probe) : neck_(neck), probe_(probe) {
  // A rigid flat punch on an elastic half-space: K = 2 E* √(A/π) (the circle of equal area; a
  // rectangle of aspect ≤ 4 is within a few per cent of it), E* = E/(1 − ν²).
  const double e_star = neck.tissue_modulus / (1 - neck.poisson * neck.poisson);
  stiffness_ = 2 * e_star * std::sqrt(probe.width * probe.thickness / kPi);
  pulse_mean_ = pulse_mean();
  vein_geometry_ = neck_vein(neck);
  artery_geometry_ = neck_artery(neck);
}

NeckCompression::Frame NeckCompression::frame(const ProbePose& pose) const noexcept {
  Frame f;
  const Quat q = pose.orientation.normalized();
  f.origin = pose.position;
  f.beam = (q * probe_.axis).normalized();
  f.lateral = (q * probe_.lateral).normalized();
  f.elevation = f.beam.cross(f.lateral).normalized();
  return f;
}

NeckCompression::State NeckCompression::posed(const ProbePose& pose, double t) const noexcept {
  State s = loads(pose);
  s.time = t;
  if (s.force > 0) {
    // The half-space's displacement is normalised so that the skin under the load's centroid sinks
    // by the mean indentation: the tissue under the probe goes where the probe's face pushes it.
    s.displacement_scale = 1;
    const double u0 = displacement(s, s.load_point).dot(s.load_dir);
    s.displacement_scale = u0 > 0 ? s.indentation / u0 : 0;
  }
  return s;
}

NeckCompression::State NeckCompression::state(const ProbePose& pose, double t) const noexcept {
  State s = posed(pose, t);
  const Vec3 mid = frame(pose).origin;  // the cross-section through the footprint's centre
  s.vein = vein_at(s, mid);
  s.artery = artery_at(s, mid);
  return s;
}

NeckCompression::State NeckCompression::loads(const ProbePose& pose) const noexcept {
  State s;
  const Frame f = frame(pose);
  const double rn = neck_.neck_radius;
  const Vec3 axis_origin(0, -rn, 0);  // the neck's axis (along z) under the skin's top
  double sum = 0;
  Vec3 centroid = Vec3::Zero(), normal = Vec3::Zero();
  int k = 0;
  for (int i = 0; i < kLoadsAlong; ++i) {
    for (int j = 0; j < kLoadsAcross; ++j, ++k) {
      const double su = -1 + 2.0 * i / (kLoadsAlong - 1), sv = -1 + 2.0 * j / (kLoadsAcross - 1);
      const Vec3 q = f.origin + su * 0.5 * probe_.width * f.lateral + sv * 0.5 * probe_.thickness * f.elevation;
      Vec3 radial = q - axis_origin;
      radial.z() = 0;
      const double r = radial.norm();
      const Vec3 out = r > 0 ? Vec3(radial / r) : Vec3(Vec3::UnitY());
      const double depth = rn - r;                  // below the rest skin (> 0 inside)
      const double p = stiffness_ * smooth_indentation(depth) / State::kLoads;
      s.load_at[k] = axis_origin + radial.normalized() * rn + Vec3(0, 0, q.z());  // on the skin
      if (r <= 0) s.load_at[k] = q;
      s.load[k] = p;
      sum += p;
      centroid += p * s.load_at[k];
      normal += p * out;
    }
  }
  s.force = sum;
  s.indentation = sum / stiffness_;
  if (sum > 0) {
    s.load_point = centroid / sum;
    s.load_dir = -normal.normalized();
  } else {
    s.load_point = f.origin;
    s.load_dir = f.beam;
  }
  return s;
}

Vec3 NeckCompression::displacement(const State& s, const Vec3& X) const noexcept {
  if (s.force <= 0 || s.displacement_scale <= 0) return Vec3::Zero();
  const double nu = neck_.poisson, g = neck_.tissue_modulus / (2 * (1 + nu));
  // Regularised over the load spacing: the footprint is a distributed load, not 27 needles.
  const double reg = std::max(probe_.width / (kLoadsAlong - 1), probe_.thickness / (kLoadsAcross - 1));
  Vec3 u = Vec3::Zero();
  for (int k = 0; k < State::kLoads; ++k) {
    if (s.load[k] <= 0) continue;
    const Vec3 d = X - s.load_at[k];
    const double z = std::max(0.0, d.dot(s.load_dir));
    const Vec3 rv = d - d.dot(s.load_dir) * s.load_dir;
    const double r = rv.norm(), rr = std::sqrt(r * r + z * z + reg * reg);
    const double c = s.load[k] / (4 * kPi * g * rr);
    const double uz = c * (2 * (1 - nu) + z * z / (rr * rr));
    const double ur = c * (r * z / (rr * rr) - (1 - 2 * nu) * r / (rr + z));
    u += uz * s.load_dir;
    if (r > 1e-12) u += ur * (rv / r);
  }
  return s.displacement_scale * u;
}

double NeckCompression::stress(const State& s, const Vec3& X) const noexcept {
  constexpr double reg = 0.001;  // m: the stress a millimetre under a point load stays finite
  double sz = 0;
  for (int k = 0; k < State::kLoads; ++k) {
    if (s.load[k] <= 0) continue;
    const Vec3 d = X - s.load_at[k];
    const double z = std::max(0.0, d.dot(s.load_dir));
    const double r2 = (d - d.dot(s.load_dir) * s.load_dir).squaredNorm();
    const double rr2 = r2 + z * z + reg * reg, rr = std::sqrt(rr2);
    sz += 3 * s.load[k] * z * z * z / (2 * kPi * rr2 * rr2 * rr);
  }
  return sz;
}

VesselSection NeckCompression::section_geometry(const State& s, const Vec3& axis_point, const Vec3& along,
                                                double radius) const noexcept {
  VesselSection v;
  v.axis = Vec3::UnitZ();
  const Vec3 c0 = axis_point + (along - axis_point).dot(v.axis) * v.axis;
  v.centre = c0 + displacement(s, c0);
  v.rest_radius = radius;
  Vec3 minor = s.load_dir - s.load_dir.dot(v.axis) * v.axis;
  v.minor_dir = minor.norm() > 1e-9 ? Vec3(minor.normalized()) : Vec3(Vec3::UnitY());
  const Vec3 across = v.axis.cross(v.minor_dir);
  // The probe's stress on the vessel: the mean over its centre and four points of its wall.
  double p = stress(s, c0);
  p += stress(s, c0 + radius * v.minor_dir) + stress(s, c0 - radius * v.minor_dir);
  p += stress(s, c0 + radius * across) + stress(s, c0 - radius * across);
  v.external_pressure = p / 5;
  return v;
}

void NeckCompression::section_law(VesselSection& v, bool vein, double t) const noexcept {
  const double radius = v.rest_radius;
  double ratio = 1;
  if (vein) {
    const double k = neck_.vein_wall_stiffness, p_in = neck_.venous_pressure;
    v.transmural_pressure = p_in - v.external_pressure;
    ratio = tube_area(v.transmural_pressure / k) / tube_area(p_in / k);
  } else {
    const double mean_shape = pulse_mean_;
    const double beat = neck_.heart_rate > 0 ? t * neck_.heart_rate - std::floor(t * neck_.heart_rate) : 0;
    const double shape = neck_.heart_rate > 0 ? pulse_shape(beat) : mean_shape;
    const double p_in = neck_.arterial_pressure + neck_.pulse_pressure * (shape - mean_shape);
    v.transmural_pressure = p_in - v.external_pressure;
    const double rel = std::max(v.transmural_pressure / neck_.arterial_pressure, 0.05);
    const double d = 1 + std::log(rel) / neck_.artery_stiffness;
    ratio = d * d;
  }
  v.area_ratio = std::max(ratio, kMinArea);
  // An artery under its positive transmural pressure stays round, only smaller (Hayashi's law); a
  // vein below its unloaded area, or any vessel pressed past its pressure, flattens.
  if (v.area_ratio >= 1 || (!vein && v.transmural_pressure > 0)) {
    v.a = v.b = radius * std::sqrt(v.area_ratio);
  } else {
    flattened(radius, v.area_ratio, v.a, v.b);
  }
}

VesselSection NeckCompression::section(const State& s, const Vec3& axis_point, const Vec3& along, double radius,
                                       bool vein, double t) const noexcept {
  VesselSection v = section_geometry(s, axis_point, along, radius);
  section_law(v, vein, t);
  return v;
}

VesselSection NeckCompression::vein_at(const State& s, const Vec3& along) const noexcept {
  return section(s, vein_geometry_.axis_point, along, vein_geometry_.radius, true, 0);
}

VesselSection NeckCompression::artery_at(const State& s, const Vec3& along) const noexcept {
  return section(s, artery_geometry_.axis_point, along, artery_geometry_.radius, false, s.time);
}

Vec3 NeckCompression::rest_point(const State& s, const Vec3& x) const noexcept {
  return rest_point(s, x, nullptr);
}

Vec3 NeckCompression::rest_point(const State& s, const Vec3& x, SectionCache* cache) const noexcept {
  if (!(s.force > 0) || !(s.displacement_scale > 0)) return x;
  // The half-space: x = X + u(X). u varies over centimetres and by millimetres: a contraction, so
  // a few fixed-point steps converge to well under a micrometre.
  // Warm-started from the last point asked for (the tip moves micrometres a tick), to 1 nm.
  Vec3 X = cache && cache->last_x.allFinite() ? Vec3(cache->last_X + (x - cache->last_x)) : x;
  for (int k = 0; k < 12; ++k) {
    const Vec3 next = x - displacement(s, X);
    const double step = (next - X).squaredNorm();
    X = next;
    if (step < 1e-18) break;
  }
  if (cache) cache->last_x = x, cache->last_X = X;
  // Each vessel near x: its deformed section back onto its rest circle (Xv), with a weight w that is
  // 1 inside it and on its wall and falls to 0 two rest radii outside, and x's distance outside its
  // wall. Where both vessels reach (the gap between the vein and the carotid), the nearer wall
  // counts more: on a wall its own vessel's map alone, so each lumen is its vessel's exactly.
  Vec3 Xv[2] = {X, X};
  double w[2] = {0, 0}, out[2] = {1e9, 1e9};
  for (int i = 0; i < 2; ++i) {
    const bool vein = i == 0;
    const VesselGeometry& g = vein ? vein_geometry_ : artery_geometry_;
    const double R = g.radius;
    Vec3 r0 = X - g.axis_point;
    r0 -= r0.dot(g.axis) * g.axis;
    if (r0.norm() > 5 * R) continue;  // far from it (whatever the press): the half-space alone
    // The section's place and the probe's stress on it depend on the pose and on where along the
    // vessel (reused from the cache for the same pose within 0.1 mm); its tube law on the time.
    const double along = (X - g.axis_point).dot(g.axis);
    VesselSection v;
    SectionCache::Slot* hit = nullptr;
    if (cache)
      for (SectionCache::Slot& slot : cache->slots[i])
        if (slot.pose == cache->pose && std::abs(slot.along - along) < 1e-4) hit = &slot;
    if (hit) {
      v = hit->geometry;
    } else {
      v = section_geometry(s, g.axis_point, X, R);
      if (cache) {
        SectionCache::Slot& slot = cache->slots[i][cache->next[i]];
        cache->next[i] ^= 1;
        slot.pose = cache->pose, slot.along = along, slot.geometry = v;
      }
    }
    // Two rest radii past the widest the wall can spread (1.3 R): the half-space alone.
    Vec3 off = x - v.centre;
    off -= off.dot(v.axis) * v.axis;
    if (off.norm() > 3.3 * R) continue;
    section_law(v, vein, s.time);
    const Vec3 across = v.axis.cross(v.minor_dir);
    Vec3 d = x - v.centre;
    const double axial = d.dot(v.axis);
    d -= axial * v.axis;
    // The rest circle's point at angle θ is the wall's point (a cos θ, b sin θ): inside, elliptical
    // coordinates map onto the rest disc; outside, the nearest wall point gives θ, and the distance
    // to it is kept outside the rest wall.
    const double px = d.dot(across), py = d.dot(v.minor_dir);
    const double ea = px / v.a, eb = py / v.b;
    const double rho = std::sqrt(ea * ea + eb * eb);  // 1 on the deformed wall
    double ct = rho > 0 ? ea / rho : 1, st = rho > 0 ? eb / rho : 0;
    double rest_r = R * rho;
    w[i] = 1, out[i] = 0;
    if (rho > 1) {
      const Eigen::Vector2d near = nearest_on_ellipse(v.a, v.b, px, py);
      out[i] = std::hypot(px - near.x(), py - near.y());
      const double th = std::atan2(near.y() / v.b, near.x() / v.a);
      ct = std::cos(th), st = std::sin(th);
      rest_r = R + out[i];
      const double q = std::min(1.0, out[i] / (2 * R));
      w[i] = 1 - q * q * (3 - 2 * q);
    }
    const Vec3 c0 = g.axis_point + (X - g.axis_point).dot(g.axis) * g.axis;
    Xv[i] = c0 + rest_r * (ct * across + st * v.minor_dir) + axial * v.axis;
  }
  const double sum = out[0] + out[1];
  const double e0 = sum > 0 ? w[0] * out[1] / sum : w[0], e1 = sum > 0 ? w[1] * out[0] / sum : 0;
  X = e0 * Xv[0] + e1 * Xv[1] + (1 - e0 - e1) * X;
  // Outside a vessel's wall in the image is outside it at rest too (the blend near the other
  // vessel could pull a point just outside one wall a hair inside): onto the rest wall, at least.
  for (int i = 0; i < 2; ++i) {
    if (!(out[i] > 0) || out[i] >= 1e9) continue;
    const VesselGeometry& g = i == 0 ? vein_geometry_ : artery_geometry_;
    Vec3 r = X - g.axis_point;
    const double along = r.dot(g.axis);
    r -= along * g.axis;
    const double rn = r.norm();
    if (rn < g.radius && rn > 0) X = g.axis_point + along * g.axis + r * (g.radius * (1 + 1e-9) / rn);
  }
  return X.allFinite() ? X : x;
}

bool NeckCompression::to_rest(const Vec3& x, Vec3& X) const noexcept {
  if (!(posed_.force > 0)) return false;
  cache_.pose = posed_generation_;
  X = rest_point(posed_, x, &cache_);
  return true;
}

Vec3 NeckCompression::probe_force(const ProbePose& pose) const noexcept {
  const State s = loads(pose);
  const Vec3 f = -s.force * s.load_dir;
  return f.allFinite() ? f : Vec3(Vec3::Zero());
}

Vec3 NeckCompression::force(const Vec3& position, const Quat& orientation, double t) noexcept {
  // A new pose (not a new time: the pulse changes only the artery's tube law) renews the cache.
  if (position != posed_pose_.position || orientation.coeffs() != posed_pose_.orientation.coeffs() || posed_generation_ == 0)
    ++posed_generation_, posed_pose_ = {position, orientation};
  posed_ = posed({position, orientation}, t);
  const Vec3 f = -posed_.force * posed_.load_dir;
  if (!f.allFinite()) {
    posed_ = State{};
    return Vec3::Zero();
  }
  return f;
}

}  // namespace palpate
