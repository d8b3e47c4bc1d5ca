// The ultrasound view (docs/ultrasound.md): the neck under the probe and the B-mode image, checked by
// content — the vein collapses under a clinician's press and the carotid does not, the needle is a
// bright segment where the geometry puts it, speckle is fully developed, and the same inputs give the
// same image.
#include <palpate/anatomy.h>
#include <palpate/scene.h>
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

}  // namespace
}  // namespace palpate
