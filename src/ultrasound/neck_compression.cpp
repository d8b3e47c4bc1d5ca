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

double tube_area(double p_over_k) {
  double lo = 1e-4, hi = 4;  // tube_law is increasing in alpha
  for (int i = 0; i < 60; ++i) {
    const double mid = std::sqrt(lo * hi);
    (tube_law(mid) < p_over_k ? lo : hi) = mid;
  }
  return std::sqrt(lo * hi);
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

NeckCompression::State NeckCompression::state(const ProbePose& pose, double t) const noexcept {
  State s = loads(pose);
  s.time = t;
  if (s.force > 0) {
    // The half-space's displacement is normalised so that the skin under the load's centroid sinks
    // by the mean indentation: the tissue under the probe goes where the probe's face pushes it.
    s.displacement_scale = 1;
    const double u0 = displacement(s, s.load_point).dot(s.load_dir);
    s.displacement_scale = u0 > 0 ? s.indentation / u0 : 0;
  }
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
    const double rr = std::sqrt(r2 + z * z + reg * reg);
    sz += 3 * s.load[k] * z * z * z / (2 * kPi * std::pow(rr, 5));
  }
  return sz;
}

VesselSection NeckCompression::section(const State& s, const Vec3& axis_point, const Vec3& along, double radius,
                                       bool vein, double t) const noexcept {
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
  if (v.area_ratio >= 1) {
    v.a = v.b = radius * std::sqrt(v.area_ratio);
  } else {
    flattened(radius, v.area_ratio, v.a, v.b);
  }
  return v;
}

VesselSection NeckCompression::vein_at(const State& s, const Vec3& along) const noexcept {
  const VesselGeometry g = neck_vein(neck_);
  return section(s, g.axis_point, along, g.radius, true, 0);
}

VesselSection NeckCompression::artery_at(const State& s, const Vec3& along) const noexcept {
  const VesselGeometry g = neck_artery(neck_);
  return section(s, g.axis_point, along, g.radius, false, s.time);
}

Vec3 NeckCompression::probe_force(const ProbePose& pose) const noexcept {
  const State s = loads(pose);
  const Vec3 f = -s.force * s.load_dir;
  return f.allFinite() ? f : Vec3(Vec3::Zero());
}

Vec3 NeckCompression::force(const Vec3& position, const Quat& orientation, double /*t*/) noexcept {
  return probe_force({position, orientation});
}

}  // namespace palpate
