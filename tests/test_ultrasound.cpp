// The ultrasound view (docs/ultrasound.md): the neck under the probe and the B-mode image, checked by
// content — the vein collapses under a clinician's press and the carotid does not, the needle is a
// bright segment where the geometry puts it, speckle is fully developed, and the same inputs give the
// same image.
#include <palpate/anatomy.h>
#include <palpate/scene_def.h>
#include <palpate/ultrasound.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <numeric>

namespace palpate {
namespace {

// The probe across the neck (transverse view), its face centred over the vein, pressed `press`
// metres below the skin's top.
ProbePose transverse(const NeckDef& neck, double press) {
  ProbePose pose;
  pose.position = Vec3(neck_vein(neck).axis_point.x(), neck_skin_height(neck, neck_vein(neck).axis_point.x()) - press, 0);
  return pose;
}

// The probe pressed until it carries `force` newtons (bisection on the indentation).
ProbePose pressed_with(const NeckCompression& model, const NeckDef& neck, double force) {
  double lo = 0, hi = 0.03;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (model.probe_force(transverse(neck, mid)).norm() < force ? lo : hi) = mid;
  }
  return transverse(neck, 0.5 * (lo + hi));
}

// Pixels of a dark region around a point: the image smoothed over 5 × 5 pixels (speckle's dark
// spots are small), below `level`, connected to the seed pixel (flood fill).
int dark_area(const UltrasoundImage& img, int seed_col, int seed_row, int level = 40) {
  const int W = img.width, H = img.height;
  std::vector<int> smooth(size_t(W) * H, 255);
  for (int r = 2; r < H - 2; ++r)
    for (int c = 2; c < W - 2; ++c) {
      int sum = 0;
      for (int dr = -2; dr <= 2; ++dr)
        for (int dc = -2; dc <= 2; ++dc) sum += img.grey[size_t(r + dr) * W + c + dc];
      smooth[size_t(r) * W + c] = sum / 25;
    }
  std::vector<char> seen(size_t(W) * H, 0);
  std::vector<std::pair<int, int>> stack;
  // Start from the darkest pixel within 6 pixels of the seed (the seed may sit on the lumen's edge).
  int best = 256, bc = seed_col, br = seed_row;
  for (int r = std::max(0, seed_row - 6); r < std::min(H, seed_row + 7); ++r)
    for (int c = std::max(0, seed_col - 6); c < std::min(W, seed_col + 7); ++c)
      if (smooth[size_t(r) * W + c] < best) best = smooth[size_t(r) * W + c], bc = c, br = r;
  if (best >= level) return 0;
  stack.push_back({bc, br});
  seen[size_t(br) * W + bc] = 1;
  int area = 0;
  while (!stack.empty()) {
    const auto [c, r] = stack.back();
    stack.pop_back();
    ++area;
    const int nb[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
    for (const auto& d : nb) {
      const int cc = c + d[0], rr = r + d[1];
      if (cc < 0 || rr < 0 || cc >= W || rr >= H) continue;
      const size_t j = size_t(rr) * W + cc;
      if (!seen[j] && smooth[j] < level) seen[j] = 1, stack.push_back({cc, rr});
    }
  }
  return area;
}

// Where a world point lands in the image (column, row) for a pose.
Eigen::Vector2d to_pixel(const UltrasoundImager& us, const ProbePose& pose, const Vec3& x) {
  const NeckCompression::Frame f = us.neck().frame(pose);
  const ProbeDef& p = us.neck().probe();
  const Vec3 d = x - f.origin;
  return {(d.dot(f.lateral) + 0.5 * p.width) / (p.width / p.image_width) - 0.5,
          d.dot(f.beam) / (p.depth / p.image_height) - 0.5};
}

void save_if_asked(const UltrasoundImage& img, const char* name) {
  if (const char* dir = std::getenv("PALPATE_US_DEBUG")) {
    ASSERT_TRUE(write_ultrasound_png(img, std::filesystem::path(dir) / name));
  }
}

TEST(Ultrasound, TheVeinCollapsesUnderAClinicianPressAndTheCarotidStaysRound) {
  const NeckDef neck;
  const ProbeDef probe;
  UltrasoundImager us(neck, probe);
  const ProbePose light = pressed_with(us.neck(), neck, 0.3);
  const ProbePose firm = pressed_with(us.neck(), neck, 3.0);
  const double t = 0.0;  // the same phase of the pulse in both
  UltrasoundImage a, b;
  us.render(light, {}, t, a);
  us.render(firm, {}, t, b);
  save_if_asked(a, "us_light.png");
  save_if_asked(b, "us_firm.png");
  const auto s_light = us.neck().state(light, t), s_firm = us.neck().state(firm, t);
  const Eigen::Vector2d vein_a = to_pixel(us, light, s_light.vein.centre), vein_b = to_pixel(us, firm, s_firm.vein.centre);
  const Eigen::Vector2d art_a = to_pixel(us, light, s_light.artery.centre), art_b = to_pixel(us, firm, s_firm.artery.centre);
  const int va = dark_area(a, int(vein_a.x()), int(vein_a.y())), vb = dark_area(b, int(vein_b.x()), int(vein_b.y()));
  const int aa = dark_area(a, int(art_a.x()), int(art_a.y())), ab = dark_area(b, int(art_b.x()), int(art_b.y()));
  // The vein's lumen at a light touch is its area in pixels (13 mm across at 0.15 mm pixels).
  const double px_area = a.pixel_width * a.pixel_depth;
  EXPECT_NEAR(va * px_area, 3.14159 * 0.0065 * 0.0065 * s_light.vein.area_ratio, 0.25 * 3.14159 * 0.0065 * 0.0065);
  EXPECT_LT(vb, 0.5 * va) << "light " << va << " px, firm " << vb << " px";
  EXPECT_GT(aa, 0);
  EXPECT_LT(std::abs(ab - aa), 0.10 * aa) << "artery light " << aa << " px, firm " << ab << " px";
}

// Brightest row of the image smoothed over 3 × 3 pixels in a column, between two rows.
int brightest_row(const UltrasoundImage& img, int col, int row0, int row1) {
  int best = -1, best_row = row0;
  for (int r = std::max(1, row0); r <= std::min(img.height - 2, row1); ++r) {
    int sum = 0;
    for (int dr = -1; dr <= 1; ++dr)
      for (int dc = -1; dc <= 1; ++dc) sum += img.grey[size_t(r + dr) * img.width + std::clamp(col + dc, 0, img.width - 1)];
    if (sum > best) best = sum, best_row = r;
  }
  return best_row;
}

TEST(Ultrasound, AnInPlaneNeedleIsABrightSegmentWhereTheGeometryPutsIt) {
  const NeckDef neck;
  const ProbeDef probe;
  UltrasoundImager us(neck, probe);
  const ProbePose pose = pressed_with(us.neck(), neck, 0.5);
  // In-plane technique: from the lateral side along the array, 30° down, tip in the fat-muscle region.
  NeedlePose needle;
  needle.present = true;
  needle.axis = Vec3(-std::cos(0.5236), -std::sin(0.5236), 0);
  needle.tip = pose.position + Vec3(-0.004, -0.009, 0);
  UltrasoundImage img;
  us.render(pose, needle, 0, img);
  save_if_asked(img, "us_needle_in_plane.png");
  int checked = 0;
  for (double back = 0.001; back < 0.02; back += 0.001) {
    const Vec3 on_shaft = needle.tip - back * needle.axis;
    const Eigen::Vector2d px = to_pixel(us, pose, on_shaft);
    if (px.x() < 2 || px.x() > img.width - 3 || px.y() < 3) continue;
    const int col = int(std::lround(px.x()));
    const int row = brightest_row(img, col, int(px.y()) - 20, int(px.y()) + 20);  // ±3 mm
    EXPECT_LE(std::abs(row - px.y()) * img.pixel_depth, 0.001) << back * 1000 << " mm behind the tip";
    EXPECT_GE(img.grey[size_t(row) * img.width + col], 230) << "the shaft is bright";
    ++checked;
  }
  EXPECT_GE(checked, 10);
  // Past the tip there is no needle: the brightest row 3 mm beyond it is tissue, not a bright echo.
  const Eigen::Vector2d beyond = to_pixel(us, pose, needle.tip + 0.003 * needle.axis);
  const int col = int(std::lround(beyond.x()));
  EXPECT_LT(img.grey[size_t(std::lround(beyond.y())) * img.width + col], 200);
}

TEST(Ultrasound, AnOutOfPlaneNeedleIsABrightDotInTheVeinWhereItCrossesThePlane) {
  const NeckDef neck;
  const ProbeDef probe;
  UltrasoundImager us(neck, probe);
  const ProbePose pose = pressed_with(us.neck(), neck, 0.5);
  const auto s = us.neck().state(pose, 0);
  // The CVC scene's 45° caudal needle, its tip 2 mm past the plane at the vein's centre.
  NeedlePose needle;
  needle.present = true;
  needle.axis = Vec3(0, -1, 1).normalized();
  const Vec3 crossing = s.vein.centre;
  needle.tip = crossing + (0.002 / needle.axis.z()) * needle.axis;
  UltrasoundImage img;
  us.render(pose, needle, 0, img);
  save_if_asked(img, "us_needle_dot.png");
  const Eigen::Vector2d px = to_pixel(us, pose, crossing);
  const int col = int(std::lround(px.x()));
  const int row = brightest_row(img, col, int(px.y()) - 30, int(px.y()) + 30);
  EXPECT_LE(std::abs(row - px.y()) * img.pixel_depth, 0.001);
  EXPECT_GE(img.grey[size_t(row) * img.width + col], 200);
  // The lumen around the dot stays dark (3 mm to the side).
  const int side = col + int(0.003 / img.pixel_width);
  EXPECT_LT(img.grey[size_t(std::lround(px.y())) * img.width + side], 60);
}

// Mean over standard deviation of the envelope in a window, after dividing out a straight-line
// trend of the rows' means (attenuation and time-gain compensation vary slowly with depth).
double speckle_snr(const UltrasoundImage& img, int c0, int c1, int r0, int r1) {
  std::vector<double> row_mean;
  for (int r = r0; r < r1; ++r) {
    double mean = 0;
    for (int c = c0; c < c1; ++c) mean += img.envelope[size_t(r) * img.width + c];
    row_mean.push_back(mean / (c1 - c0));
  }
  const double n = double(row_mean.size()), rm = 0.5 * (n - 1);
  double my = 0, sxy = 0, sxx = 0;
  for (size_t i = 0; i < row_mean.size(); ++i) my += row_mean[i] / n;
  for (size_t i = 0; i < row_mean.size(); ++i) sxy += (double(i) - rm) * (row_mean[i] - my), sxx += (double(i) - rm) * (double(i) - rm);
  const double slope = sxy / sxx;
  std::vector<double> v;
  for (int r = r0; r < r1; ++r) {
    const double trend = my + slope * (double(r - r0) - rm);
    for (int c = c0; c < c1; ++c) v.push_back(img.envelope[size_t(r) * img.width + c] / trend);
  }
  const double m = std::accumulate(v.begin(), v.end(), 0.0) / double(v.size());
  double var = 0;
  for (double x : v) var += (x - m) * (x - m);
  return m / std::sqrt(var / double(v.size()));
}

TEST(Ultrasound, SpeckleInHomogeneousTissueIsFullyDeveloped) {
  // A Rayleigh envelope has mean/std = √(π/(4 − π)) = 1.913 (Burckhardt 1978; Wagner et al. 1983).
  const NeckDef neck;
  ProbeDef probe;
  double sum = 0;
  for (int seed = 1; seed <= 4; ++seed) {
    probe.seed = seed;
    UltrasoundImager us(neck, probe);
    UltrasoundImage img;
    us.render(pressed_with(us.neck(), neck, 0.5), {}, 0, img);
    // Deep connective tissue, lateral of the vein: rows 32–38 mm, the outer quarter of the image.
    const int r0 = int(0.032 / img.pixel_depth), r1 = int(0.038 / img.pixel_depth);
    const double snr = speckle_snr(img, 3 * img.width / 4, img.width - 4, r0, r1);
    EXPECT_NEAR(snr, 1.913, 0.15) << "seed " << seed;
    sum += snr;
  }
  EXPECT_NEAR(sum / 4, 1.913, 0.08);
}

TEST(Ultrasound, TheSameInputsGiveTheSameImageAndSpeckleMovesWithTheTissue) {
  const NeckDef neck;
  const ProbeDef probe;
  UltrasoundImager a(neck, probe), b(neck, probe);
  const ProbePose pose = pressed_with(a.neck(), neck, 1.0);
  UltrasoundImage ia, ib, ic;
  a.render(pose, {}, 0.25, ia);
  b.render(pose, {}, 0.25, ib);
  a.render(pose, {}, 0.25, ic);
  EXPECT_EQ(ia.grey, ib.grey);
  EXPECT_EQ(ia.grey, ic.grey);
  // Slide the probe 8 pixels along the array on the (nearly flat) skin: the deep speckle is the
  // same tissue's, 8 columns over — correlated, not regenerated.
  ProbePose moved = pose;
  const double shift = 8 * ia.pixel_width;
  moved.position.x() += shift;
  moved.position.y() = neck_skin_height(neck, moved.position.x()) - (neck_skin_height(neck, pose.position.x()) - pose.position.y());
  UltrasoundImage im;
  a.render(moved, {}, 0.25, im);
  const int r0 = int(0.030 / ia.pixel_depth), r1 = int(0.036 / ia.pixel_depth);
  auto correlation = [&](int lag) {
    double sxy = 0, sxx = 0, syy = 0, mx = 0, my = 0;
    int n = 0;
    for (int r = r0; r < r1; ++r)
      for (int c = 185; c < 245; ++c) mx += ia.envelope[size_t(r) * ia.width + c], my += im.envelope[size_t(r) * ia.width + c - lag], ++n;
    mx /= n, my /= n;
    for (int r = r0; r < r1; ++r)
      for (int c = 185; c < 245; ++c) {
        const double x = ia.envelope[size_t(r) * ia.width + c] - mx, y = im.envelope[size_t(r) * ia.width + c - lag] - my;
        sxy += x * y, sxx += x * x, syy += y * y;
      }
    return sxy / std::sqrt(sxx * syy);
  };
  EXPECT_GT(correlation(8), 0.6) << "the speckle followed the tissue";
  EXPECT_LT(std::abs(correlation(0)), 0.3) << "unshifted, the pattern does not line up";
  // Another seed is other tissue: uncorrelated.
  ProbeDef other = probe;
  other.seed = 99;
  UltrasoundImager c(neck, other);
  c.render(pose, {}, 0.25, im);
  EXPECT_LT(std::abs(correlation(0)), 0.3) << "another seed, other speckle";
}

TEST(Ultrasound, AProbeOffTheSkinShowsNothing) {
  const NeckDef neck;
  const ProbeDef probe;
  UltrasoundImager us(neck, probe);
  ProbePose lifted;
  lifted.position = Vec3(0, 0.005, 0);  // 5 mm above the skin: no coupling
  UltrasoundImage img;
  us.render(lifted, {}, 0, img);
  EXPECT_FALSE(img.in_contact);
  EXPECT_EQ(*std::max_element(img.envelope.begin(), img.envelope.end()), 0.0f);
  // Black but for the depth scale and the orientation marker, exactly as drawn on a black image.
  UltrasoundImage black = img;
  std::fill(black.grey.begin(), black.grey.end(), std::uint8_t(0));
  draw_ultrasound_overlay(black);
  EXPECT_EQ(img.grey, black.grey);
  EXPECT_EQ(us.neck().probe_force(lifted).norm(), 0.0);
}

// Issue 35: the images had no depth scale nor orientation marker. A tick every 5 mm of depth on
// the right edge (a longer one every 10 mm) at the row of that depth, and the marker at the top left.
TEST(Ultrasound, ImagesCarryADepthScaleAndAnOrientationMarker) {
  const NeckDef neck;
  const ProbeDef probe;  // 40 mm deep, 256 rows
  UltrasoundImager us(neck, probe);
  ProbePose pose;
  pose.position = Vec3(0, -0.003, 0);
  UltrasoundImage img;
  us.render(pose, {}, 0, img);
  ASSERT_TRUE(img.in_contact);
  const int W = img.width;
  auto grey = [&](int col, int row) { return int(img.grey[size_t(row) * size_t(W) + size_t(col)]); };
  int ticks = 0;
  for (int mm = 5; mm * 1e-3 <= (img.height - 1) * img.pixel_depth; mm += 5) {
    const int row = int(std::lround(mm * 1e-3 / img.pixel_depth));
    const int len = mm % 10 == 0 ? kDepthTickLong : kDepthTickShort;
    for (int c = W - len; c < W; ++c) EXPECT_EQ(grey(c, row), 255) << mm << " mm, column " << c;
    EXPECT_EQ(grey(W - len - 1, row), 0) << mm << " mm: the tick's black edge";
    EXPECT_EQ(grey(W - 1, row - 1), 0) << mm << " mm: black above";
    EXPECT_EQ(grey(W - 1, row + 1), 0) << mm << " mm: black below";
    ++ticks;
  }
  EXPECT_EQ(ticks, 7);  // 5 … 35 mm in a 40 mm image (row 255 is 39.8 mm)
  for (int r = 2; r < 2 + kMarkerSide; ++r)
    for (int c = 2; c < 2 + kMarkerSide; ++c) EXPECT_EQ(grey(c, r), 255);
  EXPECT_EQ(grey(1, 1), 0);
  // The overlay is on the grey image only: the echoes (envelope) under it are the tissue's.
  EXPECT_GT(img.envelope[size_t(3) * size_t(W) + 3] + img.envelope[size_t(100) * size_t(W) + size_t(W - 2)], 0.0f);
}

TEST(Ultrasound, TheProbesForceRisesSmoothlyWithItsPressAndPointsOutOfTheSkin) {
  const NeckDef neck;
  const ProbeDef probe;
  NeckCompression model(neck, probe);
  const double x = neck_vein(neck).axis_point.x();
  double previous = 0, previous_slope = 0;
  for (int i = 1; i <= 200; ++i) {  // 0.1 mm steps to 20 mm
    ProbePose pose;
    pose.position = Vec3(x, neck_skin_height(neck, x) - 1e-4 * i, 0);
    const Vec3 f = model.force(pose.position, pose.orientation, 0.001 * i);
    ASSERT_TRUE(f.allFinite());
    EXPECT_GT(f.y(), 0.9 * f.norm()) << "pushes the probe back out";
    EXPECT_GT(f.norm(), previous) << "rises at " << 0.1 * i << " mm";
    const double slope = (f.norm() - previous) / 1e-4;
    if (i > 1) {
      EXPECT_LT(std::abs(slope - previous_slope), 0.15 * model.contact_stiffness()) << "no kink";
    }
    previous = f.norm(), previous_slope = slope;
  }
  // A flat punch: K = 2E*·√(A/π), E* = E/(1 − ν²) (Johnson 1985): 10 kPa, 38 × 10 mm → 276 N/m.
  EXPECT_NEAR(model.contact_stiffness(), 2 * 10e3 / (1 - 0.45 * 0.45) * std::sqrt(0.038 * 0.010 / 3.14159265358979), 1e-9);
  // Deep in the flat part the curve's slope is the stiffness, within the neck's curvature.
  EXPECT_NEAR(previous_slope, model.contact_stiffness(), 0.1 * model.contact_stiffness());
  // Not a number in, zero out (the haptic thread never sends NaN).
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(model.force(Vec3(nan, 0, 0), Quat::Identity(), 0), Vec3::Zero());
  // Rocked 10° along the array, the same press at the centre: one end presses deeper, the load's
  // centroid moves toward it, and the force still pushes out of the skin (frictionless contact).
  ProbePose level;
  level.position = Vec3(x, neck_skin_height(neck, x) - 0.004, 0);
  ProbePose rocked = level;
  rocked.orientation = Quat(Eigen::AngleAxisd(-0.1745, Vec3::UnitZ()));  // the +x end goes down
  const auto sl = model.state(level, 0), sr = model.state(rocked, 0);
  EXPECT_GT(sr.load_point.x(), sl.load_point.x() + 0.002);
  const Vec3 fr = model.probe_force(rocked);
  EXPECT_GT(fr.y(), 0.95 * fr.norm());
  EXPECT_NEAR(fr.norm(), model.probe_force(level).norm(), 0.25 * model.probe_force(level).norm());
}

TEST(Ultrasound, TheCarotidPulsesAFewPercentAndTheVeinDoesNot) {
  const NeckDef neck;
  const ProbeDef probe;
  NeckCompression model(neck, probe);
  ProbePose pose;
  pose.position = Vec3(0, -0.0005, 0);
  double dmin = 1e9, dmax = 0, vmin = 1e9, vmax = 0, dmean = 0;
  const int n = 400;
  for (int i = 0; i < n; ++i) {
    const double t = i / (n * neck.heart_rate);  // one beat
    const auto s = model.state(pose, t);
    const double d = 2 * std::sqrt(s.artery.a * s.artery.b);
    dmin = std::min(dmin, d), dmax = std::max(dmax, d), dmean += d / n;
    vmin = std::min(vmin, s.vein.area_ratio), vmax = std::max(vmax, s.vein.area_ratio);
  }
  // Diastole to systole (80 → 120 mmHg) with β = 8: ln(1.5)/8 ≈ 5 % of the diameter.
  EXPECT_GT((dmax - dmin) / dmean, 0.03);
  EXPECT_LT((dmax - dmin) / dmean, 0.08);
  EXPECT_NEAR(dmean, neck.cca_diameter, 0.02 * neck.cca_diameter) << "the scene's diameter is the mean";
  EXPECT_EQ(vmin, vmax) << "the vein does not pulse with the artery";
}

TEST(Ultrasound, TheVeinsTubeLawCollapsesItBetweenAFractionOfANewtonAndAFewNewtons) {
  const NeckDef neck;
  const ProbeDef probe;
  NeckCompression model(neck, probe);
  double previous = 2;
  for (double f : {0.1, 0.5, 1.0, 2.0, 3.0, 5.0}) {
    const auto s = model.state(pressed_with(model, neck, f), 0);
    EXPECT_LT(s.vein.area_ratio, previous) << f << " N";
    EXPECT_GE(s.vein.a, s.vein.b);
    EXPECT_LT(s.vein.a, 1.31 * s.vein.rest_radius);
    previous = s.vein.area_ratio;
    if (f == 0.1) {
      EXPECT_GT(s.vein.area_ratio, 0.85);
    }
    if (f == 3.0) {
      EXPECT_LT(s.vein.area_ratio, 0.5);
      const auto rest = model.state(ProbePose{}, 0);  // the same phase of the pulse, no press
      EXPECT_GT(s.artery.area_ratio / rest.artery.area_ratio, 0.9);
    }
  }
}

// The first row, going down a column from `row0`, whose 5-row vertical mean is below `level`.
int first_dark_row(const UltrasoundImage& img, int col, int row0, int level = 40) {
  for (int r = row0 + 2; r < img.height - 2; ++r) {
    int sum = 0;
    for (int dr = -2; dr <= 2; ++dr)
      for (int dc = -2; dc <= 2; ++dc) sum += img.grey[size_t(r + dr) * img.width + col + dc];
    if (sum / 25 < level) return r;
  }
  return -1;
}

TEST(Ultrasound, ALongitudinalViewShowsThePressedVeinSmoothAlongItsLength) {
  // The probe along the neck over the vein (in-plane with it), pressed: the probe loads the vein
  // unevenly along its length (most under the face's middle), so its lumen's top dips toward the
  // image's middle. It must do so smoothly: the image takes each column's section between the few
  // computed along the vein; the nearest of them drew the vein as a staircase of 9 steps, its top
  // jumping 3 rows between two columns at 1.5 N and 10 at 1.25 N (the PSF spreads a step over a
  // few columns, so the check needs a press where the steps are large).
  const NeckDef neck;
  ProbeDef probe;
  probe.lateral = Vec3(0, 0, 1);
  UltrasoundImager us(neck, probe);
  for (const double force : {1.25, 1.5}) {
    const ProbePose pose = pressed_with(us.neck(), neck, force);
    UltrasoundImage img;
    us.render(pose, {}, 0, img);
    save_if_asked(img, force == 1.5 ? "us_longitudinal.png" : "us_longitudinal_light.png");
    const auto s = us.neck().state(pose, 0);
    const int centre = int(std::lround(to_pixel(us, pose, s.vein.centre).y()));
    const int from = int(centre - 1.5 * s.vein.rest_radius / img.pixel_depth);  // above the vein
    // The lumen's top in one column (alone, so a step stays a step): from the darkest 3-row mean
    // within 15 rows of the centre's row, up to the last dark row (the blood is ~40 dB below tissue).
    std::vector<int> top;
    for (int col = img.width / 10; col < img.width - img.width / 10; ++col) {
      const auto mean3 = [&](int r) {
        return (img.grey[size_t(r - 1) * img.width + col] + img.grey[size_t(r) * img.width + col] +
                img.grey[size_t(r + 1) * img.width + col]) / 3;
      };
      int darkest = 256, row = -1;
      for (int r = centre - 15; r <= centre + 15; ++r)
        if (mean3(r) < darkest) darkest = mean3(r), row = r;
      ASSERT_LT(darkest, 30) << force << " N: a lumen under column " << col;
      while (row > from && mean3(row - 1) < 60) --row;
      top.push_back(row);
    }
    // It dips (the press is real), and it is smooth: at most two rows between neighbouring columns.
    EXPECT_GT(*std::max_element(top.begin(), top.end()), std::min(top.front(), top.back()) + 4) << force << " N";
    int largest = 0;
    for (size_t i = 1; i < top.size(); ++i) largest = std::max(largest, std::abs(top[i] - top[i - 1]));
    EXPECT_LE(largest, 2) << force << " N: the lumen's top jumps by " << largest << " rows between neighbouring columns";
  }
}

TEST(Ultrasound, TheVeinsWallShowsTentedWhereTheNeedlesTissuePushesIt) {
  const NeckDef neck;
  const ProbeDef probe;
  UltrasoundImager us(neck, probe);
  const ProbePose pose = pressed_with(us.neck(), neck, 0.3);
  const VesselGeometry g = neck_vein(neck);
  // A ring of wall particles every 5° and every 0.5 mm along the vein, rest and now: the top of the
  // wall pushed 3 mm into the lumen, tapering over ±30° (a needle tenting it from above).
  std::vector<Vec3f> rest, now;
  for (double z = -0.004; z <= 0.004; z += 0.0005)
    for (int deg = 0; deg < 360; deg += 5) {
      const double a = deg * 3.14159265358979 / 180;
      const Vec3 radial(std::cos(a), std::sin(a), 0);
      const Vec3 r = g.axis_point + g.radius * radial + Vec3(0, 0, z);
      const double off = std::abs(deg - 90);
      const double push = off < 30 ? 0.003 * std::pow(std::cos(off / 30 * 1.5708), 2) : 0.0;
      rest.push_back(r.cast<float>());
      now.push_back((r - push * radial).cast<float>());
    }
  UltrasoundImage plain, tented;
  us.render(pose, {}, 0, plain);
  us.set_vein_wall(rest, now);
  us.render(pose, {}, 0, tented);
  save_if_asked(tented, "us_tented.png");
  const auto s = us.neck().state(pose, 0);
  const Eigen::Vector2d c = to_pixel(us, pose, s.vein.centre);
  const int col = int(std::lround(c.x()));
  const int from = int(c.y() - 1.5 * g.radius / plain.pixel_depth);  // above the vein
  const int top_plain = first_dark_row(plain, col, from), top_tented = first_dark_row(tented, col, from);
  ASSERT_GT(top_plain, 0);
  EXPECT_NEAR((top_tented - top_plain) * plain.pixel_depth, 0.003, 0.0006);
  // Away from the tent (the bottom wall) nothing moved.
  const int side = col + int(0.8 * g.radius / plain.pixel_width);
  EXPECT_NEAR(first_dark_row(tented, side, from), first_dark_row(plain, side, from), 2);
  // Particles outside the slice do not show: the same push 10 mm along the vein changes nothing.
  for (auto& p : rest) p.z() += 0.010f;
  for (auto& p : now) p.z() += 0.010f;
  us.set_vein_wall(rest, now);
  UltrasoundImage away;
  us.render(pose, {}, 0, away);
  EXPECT_EQ(away.grey, plain.grey);
}

}  // namespace
}  // namespace palpate
