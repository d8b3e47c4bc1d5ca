// imager.cpp — B-mode images of the neck under the probe (docs/ultrasound.md). Per pixel of the plane
// under the probe: where that tissue was at rest (the probe's displacement field inverted), its
// echogenicity and a complex scatterer amplitude drawn from a fixed random field in rest coordinates
// (so speckle moves with the tissue and is never regenerated), specular echoes at interfaces and off
// the needle, attenuation along the beam and time-gain compensation; then the convolution with the
// probe's point-spread function (axial × lateral, the lateral width growing away from the focus:
// Gao et al. 2009's separable convolution), envelope detection and log compression.
#include <palpate/anatomy.h>
#include <palpate/image.h>
#include <palpate/ultrasound.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>

namespace palpate {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kGrid = 16;           // coarse grid (per side) of the inverse displacement map
constexpr int kElevation = 3;       // scatterer samples across the slice
constexpr double kCell = 0.00012;   // m, scatterer cell in rest coordinates (below the resolution)
constexpr double kGelFilm = 0.001;  // m, coupling gel between the face and the skin that still images
constexpr size_t kTable = 1 << 12;  // complex Gaussian table (32 KiB: stays in L1)

enum Medium : std::uint8_t { kGel, kSkin, kFat, kMuscle, kDeep, kWall, kBlood, kCount };

// Acoustic figures per tissue (docs/ultrasound.md cites them): echogenicity (relative scatter
// amplitude), attenuation (dB/(cm·MHz), one way) and acoustic impedance (MRayl).
struct Acoustic {
  double echo, attenuation, impedance;
};
constexpr Acoustic kAcoustic[kCount] = {
    {0.0, 0.0, 1.50},    // coupling gel
    {1.1, 0.35, 1.99},   // skin (dermis: hyperechoic)
    {0.22, 0.63, 1.39},  // subcutaneous fat (hypoechoic, bright septa added)
    {0.45, 1.10, 1.68},  // muscle
    {0.55, 0.90, 1.63},  // deep connective tissue
    {1.4, 1.57, 1.70},   // vessel wall (collagen: bright)
    {0.006, 0.15, 1.61}, // blood (≈ 45 dB below tissue: anechoic)
};

// floor() without the libm call (x86-64 without SSE4.1 has no rounding instruction).
inline std::int64_t fast_floor(double v) {
  const auto i = static_cast<std::int64_t>(v);
  return i - static_cast<std::int64_t>(v < static_cast<double>(i));
}

std::uint64_t mix(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

std::uint64_t cell_hash(std::int64_t i, std::int64_t j, std::int64_t k, std::uint64_t seed) {
  return mix(seed ^ (std::uint64_t(i) * 0x8CB92BA72F3D8DD7ull) ^ (std::uint64_t(j) * 0xD6E8FEB86659FD93ull) ^
             (std::uint64_t(k) * 0xA0761D6478BD642Full));
}

const std::vector<std::complex<float>>& gaussian_table() {
  static const std::vector<std::complex<float>> table = [] {
    std::vector<std::complex<float>> t(kTable);
    std::mt19937_64 rng(20261125);
    std::normal_distribution<float> n(0.f, std::sqrt(0.5f));  // E|z|² = 1
    for (auto& z : t) z = {n(rng), n(rng)};
    return t;
  }();
  return table;
}

std::vector<float> gaussian_kernel(double sigma_px) {
  const int half = std::max(1, int(std::ceil(3 * sigma_px)));
  std::vector<double> k(2 * half + 1);
  double sum = 0;
  for (int i = -half; i <= half; ++i) sum += k[i + half] = std::exp(-0.5 * i * i / (sigma_px * sigma_px));
  std::vector<float> out(k.size());
  for (size_t i = 0; i < k.size(); ++i) out[i] = float(k[i] / sum);  // unit gain for a constant input
  return out;
}

// Distance (m) outside a vessel's section (negative inside), approximately: the normalised radius's
// excess times the section's radius in that direction. `near` is false (and the distance 1 m) where
// the point is plainly outside (more than 2 mm beyond the major semi-axis).
double section_distance(const VesselSection& v, const Vec3& p, bool& near) {
  Vec3 d = p - v.centre;
  d -= d.dot(v.axis) * v.axis;
  const double far = v.a + 0.002;  // a ≥ b: beyond this the tissue is plainly outside
  near = d.squaredNorm() <= far * far;
  if (!near) return 1.0;
  const Vec3 across = v.axis.cross(v.minor_dir);
  const double x = d.dot(across), y = d.dot(v.minor_dir);
  const double rho = std::sqrt(x * x / (v.a * v.a) + y * y / (v.b * v.b));
  const double r = d.norm();
  if (rho <= 1e-12) return -std::min(v.a, v.b);
  return (rho - 1) * (r / rho);
}

// The section's outward normal at p (the gradient of the normalised radius); asked for only where
// an echo needs it (walls and interfaces), so the distance above stays cheap.
Vec3 section_normal(const VesselSection& v, const Vec3& p) {
  Vec3 d = p - v.centre;
  d -= d.dot(v.axis) * v.axis;
  const Vec3 across = v.axis.cross(v.minor_dir);
  const double x = d.dot(across), y = d.dot(v.minor_dir);
  const Vec3 n = (x / (v.a * v.a)) * across + (y / (v.b * v.b)) * v.minor_dir;
  return n.norm() > 0 ? Vec3(n.normalized()) : Vec3(v.minor_dir);
}

// A vessel's section between two computed ones (w in [0, 1] from s0 to s1): centre, semi-axes and
// pressures linearly, the directions renormalised. A longitudinal view cuts the vessel along its
// length, and the nearest of a few sections drew a compressed vein as a staircase.
VesselSection section_between(const VesselSection& s0, const VesselSection& s1, double w) {
  if (!(w > 0)) return s0;
  if (!(w < 1)) return s1;
  VesselSection v = s0;
  v.centre = (1 - w) * s0.centre + w * s1.centre;
  v.a = (1 - w) * s0.a + w * s1.a;
  v.b = (1 - w) * s0.b + w * s1.b;
  v.external_pressure = (1 - w) * s0.external_pressure + w * s1.external_pressure;
  v.transmural_pressure = (1 - w) * s0.transmural_pressure + w * s1.transmural_pressure;
  v.area_ratio = (1 - w) * s0.area_ratio + w * s1.area_ratio;
  // The directions are the same in every section today (the vessels run along z, the load's
  // direction is the probe's); renormalise only when they differ.
  if (s0.axis != s1.axis || s0.minor_dir != s1.minor_dir) {
    const Vec3 axis = (1 - w) * s0.axis + w * s1.axis;
    if (axis.norm() > 1e-9) v.axis = axis.normalized();
    Vec3 minor = (1 - w) * s0.minor_dir + w * s1.minor_dir;
    minor -= minor.dot(v.axis) * v.axis;
    if (minor.norm() > 1e-9) v.minor_dir = minor.normalized();
  }
  return v;
}

// Zero-padded 1-D convolution of interleaved complex samples with a real kernel: out[i] = Σ_k
// in[i + k − half] · kernel[k] over n complex samples, `in` holding `half` zero samples before and
// after them (2(n + 2·half) floats). Each output's sum runs over k in order, as a plain loop over
// the taps would (the zero taps add nothing); with the taps' loop outside, the compiler vectorises
// across samples, re and im alike (faster here than summing blocks of outputs in registers).
void convolve_padded(const float* __restrict in, const std::vector<float>& kernel, int n, float* __restrict out) {
  const int m = 2 * n;
  for (int i = 0; i < m; ++i) out[i] = 0.0f;
  for (size_t k = 0; k < kernel.size(); ++k) {
    const float g = kernel[k];
    const float* src = in + 2 * k;
    for (int i = 0; i < m; ++i) out[i] += src[i] * g;
  }
}

}  // namespace

UltrasoundImager::UltrasoundImager(const NeckDef& neck, const ProbeDef& probe) : model_(neck, probe) {
  const int w = probe.image_width, h = probe.image_height;
  const double px_w = probe.width / w, px_d = probe.depth / h;
  const double c = 1540.0, lambda = c / probe.frequency;
  // Axial resolution: a 2-cycle pulse, FWHM = cycles·λ/2 (Kremkau's rule, 0.77·cycles/f mm).
  // A 3-cycle pulse, widened by the attenuation's downshift of the centre frequency: 0.3 mm at 10 MHz.
  const double axial_fwhm = 3 * lambda / 2 * 1.3;
  axial_kernel_ = gaussian_kernel(std::max(0.6, axial_fwhm / 2.355 / px_d));
  // Lateral: λ·F# at the focus (F# ≈ 2 for a linear array), focus at 40 % of the depth, widening
  // off focus like a Gaussian beam (Rayleigh range z_R = π w0² / λ).
  const double w0 = 2 * lambda * 2 / 2.355;  // σ at the focus
  // Dynamic receive focusing keeps the width nearly constant in depth: the beam widens as a Gaussian
  // beam would with three times its Rayleigh range.
  const double focus = 0.4 * probe.depth, zr = 3 * kPi * (2 * w0) * (2 * w0) / lambda;
  lateral_kernel_.resize(h);
  for (int r = 0; r < h; ++r) {
    const double z = (r + 0.5) * px_d;
    const double sigma = w0 * std::sqrt(1 + std::pow((z - focus) / zr, 2));
    lateral_kernel_[r] = gaussian_kernel(std::max(0.6, sigma / px_w));
  }
  (void)gaussian_table();
}

namespace {
// The centre of pixel (column, row) of the probe's image plane in the frame `f`.
Vec3 frame_pixel(const NeckCompression::Frame& f, const ProbeDef& p, double column, double row) noexcept {
  const double pixel_width = p.width / p.image_width, pixel_depth = p.depth / p.image_height;
  return f.origin + (-0.5 * p.width + (column + 0.5) * pixel_width) * f.lateral +
         ((row + 0.5) * pixel_depth) * f.beam;
}
}  // namespace

Vec3 UltrasoundImager::pixel_position(const ProbePose& probe, double column, double row) const noexcept {
  return frame_pixel(model_.frame(probe), model_.probe(), column, row);
}

void UltrasoundImager::set_vein_wall(std::span<const Vec3f> rest, std::span<const Vec3f> now) {
  const size_t n = rest.size() == now.size() ? rest.size() : 0;
  wall_rest_.assign(rest.begin(), rest.begin() + std::ptrdiff_t(n));
  wall_now_.assign(now.begin(), now.begin() + std::ptrdiff_t(n));
}

void UltrasoundImager::render(const ProbePose& probe, const NeedlePose& needle, double t, UltrasoundImage& out) {
  const ProbeDef& p = model_.probe();
  const NeckDef& n = model_.neck();
  const int W = p.image_width, H = p.image_height;
  const size_t N = size_t(W) * size_t(H);
  out.width = W, out.height = H;
  out.pixel_width = p.width / W, out.pixel_depth = p.depth / H;
  out.grey.resize(N);
  out.envelope.resize(N);
  field_.resize(N);
  tmp_.resize(N);

  const NeckCompression::State s = model_.state(probe, t);
  const NeckCompression::Frame f = model_.frame(probe);
  const auto pixel = [&](double col, double row) { return frame_pixel(f, p, col, row); };

  // The inverse displacement map on a coarse grid: rest position X of the tissue now at x solves
  // X + u(X) = x (fixed point; u is smooth and small against its length scale).
  std::vector<Vec3>& rest = rest_;
  rest.resize((kGrid + 1) * (kGrid + 1));
  for (int gy = 0; gy <= kGrid; ++gy) {
    for (int gx = 0; gx <= kGrid; ++gx) {
      const Vec3 x = pixel(-0.5 + double(gx) * W / kGrid, -0.5 + double(gy) * H / kGrid);
      Vec3 X = x;
      for (int it = 0; it < 4; ++it) X = x - model_.displacement(s, X);
      rest[gy * (kGrid + 1) + gx] = X;
    }
  }

  // The vessels' sections along the plane's extent (a longitudinal view cuts them unevenly).
  constexpr int kSections = 9;
  VesselSection vein[kSections], artery[kSections];
  const double z0 = std::min(pixel(0, 0).z(), pixel(W - 1, 0).z()) - 1e-9;
  const double z1 = std::max(pixel(0, 0).z(), pixel(W - 1, 0).z()) + 1e-9;
  for (int k = 0; k < kSections; ++k) {
    const Vec3 along(0, 0, z0 + (z1 - z0) * k / (kSections - 1));
    vein[k] = model_.vein_at(s, along);
    artery[k] = model_.artery_at(s, along);
  }
  // The sections at a point z along the vessels: interpolated between the two computed ones around it.
  const auto sections_at = [&](double z, VesselSection& v, VesselSection& av) {
    const double pos = std::clamp((z - z0) / (z1 - z0) * (kSections - 1), 0.0, double(kSections - 1));
    const int k = std::min(int(pos), kSections - 2);
    const double w = pos - k;
    v = section_between(vein[k], vein[k + 1], w);
    av = section_between(artery[k], artery[k + 1], w);
  };

  // The needle's tenting of the vein's wall near the plane: the largest inward displacement of the
  // wall's particles within the slice, per sector of the vein's section (angle about its centre).
  constexpr int kSectors = 48;
  double tent[kSectors] = {};
  bool tented = false;
  const VesselGeometry vein_rest = neck_vein(n);
  const VesselSection& vein_mid = vein[kSections / 2];
  const Vec3 across_mid = vein_mid.axis.cross(vein_mid.minor_dir);
  for (size_t k = 0; k < wall_rest_.size(); ++k) {
    const Vec3 r = wall_rest_[k].cast<double>(), now = wall_now_[k].cast<double>();
    if (std::abs((r - f.origin).dot(f.elevation)) > p.slice_thickness) continue;
    Vec3 radial = r - vein_rest.axis_point;
    radial -= radial.dot(vein_rest.axis) * vein_rest.axis;
    if (radial.norm() < 1e-9) continue;
    radial.normalize();
    const double inward = -(now - r).dot(radial);
    if (!(inward > 0)) continue;
    const double angle = std::atan2(radial.dot(vein_mid.minor_dir), radial.dot(across_mid));
    const int sector = int(std::floor((angle + kPi) / (2 * kPi) * kSectors)) % kSectors;
    tent[sector] = std::max(tent[sector], inward);
    tented = true;
  }
  const auto tent_at = [&](const Vec3& x, const VesselSection& v) {
    Vec3 d = x - v.centre;
    d -= d.dot(v.axis) * v.axis;
    const double pos = (std::atan2(d.dot(v.minor_dir), d.dot(v.axis.cross(v.minor_dir))) + kPi) / (2 * kPi) * kSectors - 0.5;
    const int i0 = int(std::floor(pos));
    const double w = pos - i0;
    return (1 - w) * tent[((i0 % kSectors) + kSectors) % kSectors] + w * tent[(((i0 + 1) % kSectors) + kSectors) % kSectors];
  };

  const double rn = n.neck_radius, skin = n.skin_thickness, fat = skin + n.fat_thickness;
  const double muscle = fat + n.muscle_thickness;
  constexpr double wall = 0.0006;  // m, vessel wall thickness in the image
  const auto& table = gaussian_table();
  const std::uint64_t seed = std::uint64_t(p.seed);
  const double mhz = p.frequency * 1e-6;
  const double px_cm = out.pixel_depth * 100;
  // The needle's shaft: from the tip back along its axis.
  const Vec3 shaft_dir = needle.axis.normalized();
  const double sigma_e = p.slice_thickness / 2.355;
  // The shaft's echo comes off its near wall: a thin line (under a pixel), its width then the PSF's.
  const double needle_sigma = 0.6 * std::max(out.pixel_depth, out.pixel_width);
  const double beam_cross = needle.present ? shaft_dir.cross(f.beam).norm() : 0;
  const double needle_gain = 30.0 * (0.25 + 0.75 * std::pow(beam_cross, 4));
  const double reverb_step = 2 * needle.radius;  // ring-down between the shaft's walls
  // Beyond this distance from the shaft's line the needle's echo and its reverberation are nil.
  constexpr int kReverb = 3;  // reverberation copies under the shaft
  const double needle_reach = 5 * std::max(needle_sigma, sigma_e) + kReverb * reverb_step;
  // Attenuation per pixel of each medium and the time-gain compensation per row, as factors.
  double atten_step[kCount];
  for (int m = 0; m < kCount; ++m) atten_step[m] = std::pow(10.0, -2 * kAcoustic[m].attenuation * mhz * px_cm / 20);
  std::vector<double>& tgc = tgc_;
  tgc.resize(H);
  for (int r = 0; r < H; ++r) tgc[r] = std::pow(10.0, (2 * 0.8 * mhz * (r + 0.5) * px_cm + p.gain) / 20);

  // The rest map's bilinear weights per row (the same for every column): the grid row below and
  // the weight of the one above. Per column, the grid interpolated across first (rest_col).
  row_cell_.resize(H);
  row_weight_.resize(H);
  for (int row = 0; row < H; ++row) {
    const double fy = (row + 0.5) * kGrid / H;
    row_cell_[row] = std::min(kGrid - 1, int(fy));
    row_weight_[row] = fy - row_cell_[row];
  }
  Vec3 rest_col[kGrid + 1];
  // Scatterer samples across the slice: offsets from the pixel's rest point.
  Vec3 elevation_offset[kElevation];
  for (int e = 0; e < kElevation; ++e) elevation_offset[e] = ((e - 1) * p.slice_thickness / kElevation) * f.elevation;
  const bool uneven = std::abs(f.beam.z()) > 1e-6;  // the beam runs along the vessels: check every row

  out.in_contact = false;
  for (int col = 0; col < W; ++col) {
    std::complex<float>* column = &field_[size_t(col) * H];  // column-major: the beam's samples in a row
    // Coupled when the face touches the skin through at most a film of gel; otherwise air: no image.
    {
      const double fx = (col + 0.5) * kGrid / W;
      const int ix = std::min(kGrid - 1, int(fx));
      const double ax = fx - ix;
      for (int gy = 0; gy <= kGrid; ++gy)
        rest_col[gy] = (1 - ax) * rest[gy * (kGrid + 1) + ix] + ax * rest[gy * (kGrid + 1) + ix + 1];
    }
    const auto rest_at = [&](int row) {
      const int iy = row_cell_[row];
      const double ay = row_weight_[row];
      return Vec3((1 - ay) * rest_col[iy] + ay * rest_col[iy + 1]);
    };
    Vec3 top_rest = rest_at(0) - Vec3(0, -rn, 0);
    top_rest.z() = 0;
    const bool coupled = rn - top_rest.norm() - 0.5 * out.pixel_depth > -kGelFilm;
    if (!coupled) {
      std::fill(column, column + H, std::complex<float>(0, 0));
      continue;
    }
    out.in_contact = true;
    double atten = 1;              // two-way, accumulated down the column
    double transmit = 1;           // left after specular losses (interfaces, the needle)
    Medium above = kGel;
    const Vec3 top = pixel(col, 0), step = out.pixel_depth * f.beam;
    // The rows where this beam passes within `reach` of a line through `at` along `dir` (the
    // squared distance is quadratic in the row): only there is a vessel's distance or the needle's
    // echo worth computing. A row of margin each side; every row where the line runs along the beam.
    const auto near_rows = [&](const Vec3& at, const Vec3& dir, double reach, int& lo, int& hi) {
      Vec3 d0 = top - at, d1 = step;
      d0 -= d0.dot(dir) * dir, d1 -= d1.dot(dir) * dir;
      const double qa = d1.squaredNorm(), qb = 2 * d0.dot(d1), qc = d0.squaredNorm() - reach * reach;
      const double disc = qb * qb - 4 * qa * qc;
      if (qa <= 1e-30) {
        lo = 0, hi = qc < 0 ? H : -1;
        return;
      }
      if (disc < 0) {
        lo = 0, hi = -1;
        return;
      }
      const double r0 = (-qb - std::sqrt(disc)) / (2 * qa), r1 = (-qb + std::sqrt(disc)) / (2 * qa);
      lo = int(std::floor(std::clamp(r0, -2.0, H + 2.0))) - 1, hi = int(std::ceil(std::clamp(r1, -2.0, H + 2.0))) + 1;
    };
    // The vessels' sections for this column (the beam at one z) or, the beam running along them,
    // for each row.
    VesselSection vein_here, artery_here;
    sections_at(top.z(), vein_here, artery_here);
    int vein_lo = 0, vein_hi = H, artery_lo = 0, artery_hi = H;
    if (!uneven) {
      near_rows(vein_here.centre, vein_here.axis, vein_here.a + 0.003, vein_lo, vein_hi);
      near_rows(artery_here.centre, artery_here.axis, artery_here.a + 0.003, artery_lo, artery_hi);
    }
    // The needle's reach: its shaft's line (the per-pixel test below is the exact one).
    int needle_lo = 0, needle_hi = -1;
    if (needle.present) near_rows(needle.tip, shaft_dir, needle_reach + out.pixel_depth, needle_lo, needle_hi);

    for (int row = 0; row < H; ++row) {
      const Vec3 x = top + row * step;
      if (uneven) sections_at(x.z(), vein_here, artery_here);
      // Which tissue is here now: vessels by their current sections, the rest by rest position.
      Medium tissue;
      bool vein_near = false, artery_near = false;
      double dv = row >= vein_lo && row <= vein_hi ? section_distance(vein_here, x, vein_near) : 1.0;
      if (tented && dv < 0.003) dv += tent_at(x, vein_here);  // the wall pushed in: more of it outside
      const double da = row >= artery_lo && row <= artery_hi ? section_distance(artery_here, x, artery_near) : 1.0;
      // Whose wall faces the beam here (for the echoes below): the vein's where near it, the
      // artery's where this is the artery's wall or lumen and nearer.
      int facing_wall = vein_near ? 1 : 0;
      const Vec3 X = rest_at(row);
      Vec3 radial = X - Vec3(0, -rn, 0);
      radial.z() = 0;
      const double depth = rn - radial.norm();
      if (dv < 0 || da < 0) {
        tissue = kBlood;
        if (da < dv) facing_wall = artery_near ? 2 : 0;
      } else if (dv < wall || da < wall) {
        tissue = kWall;
        if (da < dv) facing_wall = artery_near ? 2 : 0;
      } else if (depth < -1e-4) {
        tissue = kGel;
      } else if (depth < skin) {
        tissue = kSkin;
      } else if (depth < fat) {
        tissue = kFat;
      } else if (depth < muscle) {
        tissue = kMuscle;
      } else {
        tissue = kDeep;
      }
      const auto wall_normal = [&] {
        return facing_wall == 1   ? section_normal(vein_here, x)
               : facing_wall == 2 ? section_normal(artery_here, x)
                                  : Vec3(-f.beam);
      };

      // Scatter: a fixed complex Gaussian field in rest coordinates, summed across the slice.
      std::complex<float> z(0, 0);
      double echo = kAcoustic[tissue].echo;
      if (tissue == kFat) {
        // Fibrous septa: thin bright bands roughly parallel to the skin, wavy across.
        const double u = (depth - skin) / 0.0011 + 0.25 * std::sin(X.x() / 0.0023 + 1.7 * std::sin(X.z() / 0.004));
        const double fr = u - std::floor(u);
        if (fr < 0.12) echo *= 3.2;
      } else if (tissue == kMuscle) {
        // Fibre bundles cut across: a mottled texture on a millimetre scale.
        const std::uint64_t hsh = cell_hash(fast_floor(X.x() / 0.0009), fast_floor(depth / 0.0006), 7, seed);
        echo *= 0.6 + 0.8 * double(hsh & 0xFF) / 255.0;
      }
      if (echo > 0) {
        for (int e = 0; e < kElevation; ++e) {
          const Vec3 Xe = X + elevation_offset[e];
          const std::uint64_t hsh = cell_hash(fast_floor(Xe.x() * (1 / kCell)), fast_floor(Xe.y() * (1 / kCell)),
                                              fast_floor(Xe.z() * (1 / kCell)), seed);
          z += table[hsh & (kTable - 1)];
        }
        z *= float(echo / std::sqrt(double(kElevation)));
      }
      // Specular echo where the tissue changes along the beam, strongest facing the beam.
      if (tissue != above && above != kGel && tissue != kGel) {
        const Vec3 normal = tissue != kWall && tissue != kBlood && above != kWall && above != kBlood
                                ? Vec3(radial.normalized())
                                : wall_normal();
        const double za = kAcoustic[above].impedance, zb = kAcoustic[tissue].impedance;
        const double refl = std::abs(zb - za) / (za + zb);
        const double facing = std::pow(std::abs(normal.dot(f.beam)), 4);
        z += std::complex<float>(float(14.0 * refl * facing * transmit), 0.f);
        transmit *= 1 - refl * refl;
      }
      if (tissue == kWall) z += std::complex<float>(float(0.6 * std::pow(std::abs(wall_normal().dot(f.beam)), 2)), 0.f);
      // The needle: a strong specular reflector where it meets the plane (elevation beam profile),
      // with reverberation under it (ring-down inside the shaft) and a shadow beneath.
      if (row >= needle_lo && row <= needle_hi &&
          (x - needle.tip).cross(shaft_dir).squaredNorm() < needle_reach * needle_reach) {
        // The shaft's nearest point: the slice's beam profile (elevation) is the same for the
        // reverberation's copies (they lie along the beam), and they lie only below the shaft.
        const double along0 = std::clamp((x - needle.tip).dot(-shaft_dir), 0.0, needle.length);
        const Vec3 d0 = x - (needle.tip - along0 * shaft_dir);
        const double e0 = d0.dot(f.elevation), below = d0.dot(f.beam);
        const double elev = 0.5 * e0 * e0 / (sigma_e * sigma_e);
        double hit = 0, weight = 1;
        if (elev < 12 && below > -5 * needle_sigma && below < kReverb * reverb_step + 5 * needle_sigma) {
          for (int k = 0; k <= kReverb; ++k, weight *= 0.4) {
            const Vec3 q = x - (k * reverb_step) * f.beam;
            const double along = std::clamp((q - needle.tip).dot(-shaft_dir), 0.0, needle.length);
            const Vec3 d = q - (needle.tip - along * shaft_dir);
            const double e = d.dot(f.elevation);
            const double arg = 0.5 * (d - e * f.elevation).squaredNorm() / (needle_sigma * needle_sigma) +
                               0.5 * e * e / (sigma_e * sigma_e);
            if (arg < 12) hit += weight * std::exp(-arg);
          }
        }
        if (hit > 1e-4) {
          z += std::complex<float>(float(needle_gain * hit * transmit), 0.f);
          transmit *= 1 - 0.3 * std::min(1.0, hit);
        }
      }
      // Attenuation (two-way, down to this pixel) and time-gain compensation for 0.8 dB/(cm·MHz).
      atten *= atten_step[tissue];
      const double amp = transmit * atten * tgc[row];
      column[row] = z * float(amp);
      above = tissue;
    }
  }

  // Point-spread function: along the beam (each column, zero-padded), then across with the row's
  // lateral width (eight rows at a time: a column's eight samples are one cache line).
  const int ha = int(axial_kernel_.size() / 2);
  pad_.assign(2 * size_t(H + 2 * ha), 0.0f);
  for (int col = 0; col < W; ++col) {
    std::memcpy(&pad_[2 * size_t(ha)], &field_[size_t(col) * H], sizeof(std::complex<float>) * size_t(H));
    convolve_padded(pad_.data(), axial_kernel_, H, reinterpret_cast<float*>(&tmp_[size_t(col) * H]));
  }
  int hl_max = 0;
  for (const auto& kl : lateral_kernel_) hl_max = std::max(hl_max, int(kl.size() / 2));
  constexpr int kRows = 8;
  const size_t stride = 2 * size_t(W + 2 * hl_max);  // floats per padded row
  rows_.assign(kRows * stride, 0.0f);
  lateral_out_.resize(2 * size_t(W));
  for (int row0 = 0; row0 < H; row0 += kRows) {
    const int rows = std::min(kRows, H - row0);
    for (int col = 0; col < W; ++col) {
      const std::complex<float>* in = &tmp_[size_t(col) * H + size_t(row0)];
      for (int r = 0; r < rows; ++r) {
        rows_[r * stride + 2 * size_t(hl_max + col)] = in[r].real();
        rows_[r * stride + 2 * size_t(hl_max + col) + 1] = in[r].imag();
      }
    }
    for (int r = 0; r < rows; ++r) {
      const std::vector<float>& kl = lateral_kernel_[row0 + r];
      const int hl = int(kl.size() / 2);
      convolve_padded(&rows_[r * stride + 2 * size_t(hl_max - hl)], kl, W, lateral_out_.data());
      float* env = &out.envelope[size_t(row0 + r) * W];
      for (int col = 0; col < W; ++col) {
        const float re = lateral_out_[2 * size_t(col)], im = lateral_out_[2 * size_t(col) + 1];
        env[col] = std::sqrt(re * re + im * im);
      }
    }
  }
  // Log compression: 0 dB (white) at 8× the unit-echogenicity speckle's mean, `dynamic_range` to black.
  const float ref = 8.0f, dr = float(p.dynamic_range), to_db = 20.0f / std::log(10.0f);
  for (size_t i = 0; i < N; ++i) {
    const float e = out.envelope[i];
    const float db = e > 0 ? to_db * std::log(e / ref) : -1e9f;
    out.grey[i] = std::uint8_t(std::clamp(255.0f * (db + dr) / dr + 0.5f, 0.0f, 255.0f));
  }
  draw_ultrasound_overlay(out);
}

void draw_ultrasound_overlay(UltrasoundImage& image) noexcept {
  const int W = image.width, H = image.height;
  if (W < 16 || H < 16 || !(image.pixel_depth > 0)) return;
  auto set = [&](int col, int row, std::uint8_t g) {
    if (col >= 0 && col < W && row >= 0 && row < H) image.grey[size_t(row) * size_t(W) + size_t(col)] = g;
  };
  // The depth scale on the right edge: a tick every 5 mm from the face, a longer one every 10 mm,
  // each one pixel high, white, edged in black above, below and at its left end so it shows on
  // white tissue too.
  const double step = 0.005;
  const int n = int(std::floor((H - 1) * image.pixel_depth / step + 1e-9));
  for (int k = 1; k <= n; ++k) {
    const int row = int(std::lround(k * step / image.pixel_depth));
    const int len = k % 2 == 0 ? kDepthTickLong : kDepthTickShort;
    for (int r = row - 1; r <= row + 1; r += 2)
      for (int c = W - len - 1; c < W; ++c) set(c, r, 0);
    set(W - len - 1, row, 0);
    for (int c = W - len; c < W; ++c) set(c, row, 255);
  }
  // The orientation marker: a white square with a black border at the top left, the image's side of
  // the probe's −lateral end (ProbeDef::lateral points from the image's left to its right).
  for (int r = 1; r <= 2 + kMarkerSide; ++r)
    for (int c = 1; c <= 2 + kMarkerSide; ++c)
      set(c, r, (r >= 2 && r < 2 + kMarkerSide && c >= 2 && c < 2 + kMarkerSide) ? 255 : 0);
}

Status write_ultrasound_png(const UltrasoundImage& image, const std::filesystem::path& file) {
  Image rgba;
  rgba.width = image.width, rgba.height = image.height;
  rgba.rgba.resize(size_t(image.width) * image.height * 4);
  for (size_t i = 0; i < image.grey.size(); ++i) {
    const std::uint8_t g = image.grey[i];
    rgba.rgba[4 * i] = rgba.rgba[4 * i + 1] = rgba.rgba[4 * i + 2] = g;
    rgba.rgba[4 * i + 3] = 255;
  }
  return write_png(rgba, file);
}

}  // namespace palpate
