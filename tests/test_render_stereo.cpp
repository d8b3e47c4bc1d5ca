// test_render_stereo.cpp — stereo's math (render.h, "Stereo": off-axis eyes, the closed-form
// disparity) and its off-screen images checked by content: a marker at a known depth lands where
// each eye's projection puts it, its disparity the closed form's within a pixel, zero at the
// convergence distance; the three one-image layouts; quad-buffer refused off-screen.
#include <palpate/render.h>
#include <palpate/surface.h>

#include "components.h"
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

namespace {

using namespace palpate;

CameraDef stereo_camera() {
  CameraDef c;
  c.position = Vec3(0, 0.05, 0.12);
  c.target = Vec3(0, 0, 0);  // 0.13 m away: the default convergence
  c.fov = 40;
  c.width = 200;
  c.height = 150;
  return c;
}

Vec3 forward_of(const CameraDef& c) { return (c.target - c.position).normalized(); }
Vec3 right_of(const CameraDef& c) { return forward_of(c).cross(Vec3::UnitY()).normalized(); }

// The point at depth z (m along the view) and (sx, sy) m off the axis along right and up.
Vec3 at_depth(const CameraDef& c, double z, double sx = 0, double sy = 0) {
  const Vec3 f = forward_of(c), r = right_of(c), u = r.cross(f);
  return c.position + z * f + sx * r + sy * u;
}

TEST(StereoMath, ModesParseByTheirNamesAndABadOneNamesTheAcceptedOnes) {
  for (StereoMode m : {StereoMode::anaglyph, StereoMode::side_by_side, StereoMode::top_bottom, StereoMode::quad_buffer}) {
    auto parsed = parse_stereo_mode(stereo_mode_name(m));
    ASSERT_TRUE(parsed.ok()) << stereo_mode_name(m);
    EXPECT_EQ(*parsed, m);
  }
  for (const char* bad : {"", "mono", "Anaglyph", "sbs", "side_by_side", "anaglyph "}) {
    auto parsed = parse_stereo_mode(bad);
    ASSERT_FALSE(parsed.ok()) << "'" << bad << "'";
    EXPECT_EQ(parsed.error().message, "stereo mode '" + std::string(bad) +
                                          "'; expected anaglyph, side-by-side, top-bottom or quad-buffer");
  }
}

TEST(StereoMath, BadSeparationOrConvergenceIsRefusedNamingIt) {
  EXPECT_TRUE(check_stereo({}).ok());
  for (double s : {-0.001, 1.5, double(NAN), double(INFINITY)}) {
    const Status st = check_stereo({StereoMode::anaglyph, s, 0});
    ASSERT_FALSE(st.ok()) << s;
    EXPECT_NE(st.error().message.find("eye separation"), std::string::npos);
  }
  for (double d : {-0.1, double(NAN), double(INFINITY)}) {
    const Status st = check_stereo({StereoMode::anaglyph, 0.063, d});
    ASSERT_FALSE(st.ok()) << d;
    EXPECT_NE(st.error().message.find("convergence"), std::string::npos);
  }
  // And an image is refused, not drawn, with it.
  RenderScene s;
  s.camera = stereo_camera();
  s.stereo = {StereoMode::side_by_side, NAN, 0};
  auto img = render_rgba(s);
  ASSERT_FALSE(img.ok());
  EXPECT_NE(img.error().message.find("render: stereo: eye separation"), std::string::npos) << img.error().message;
}

// The eyes are the camera moved ±s/2 along its right axis, looking the same way (never toed in);
// their image planes are parallel, so no point has vertical parallax.
TEST(StereoMath, EyesAreShiftedAlongRightAndLookTheSameWay) {
  const CameraDef c = stereo_camera();
  const Vec3 f = forward_of(c), r = right_of(c), u = r.cross(f);
  const double s = 0.063, d = 0.13;
  const EyeMatrices l = stereo_eye_matrices(c.position, r, u, f, c.fov, 4.0 / 3, 0.01, 1, s, d, Eye::left);
  const EyeMatrices rt = stereo_eye_matrices(c.position, r, u, f, c.fov, 4.0 / 3, 0.01, 1, s, d, Eye::right);
  EXPECT_LT((rt.position - l.position - s * r).norm(), 1e-12);
  EXPECT_LT((0.5 * (rt.position + l.position) - c.position).norm(), 1e-12);
  EXPECT_LT((l.view.block<3, 3>(0, 0) - rt.view.block<3, 3>(0, 0)).norm(), 1e-12);  // same rotation
  EXPECT_LT((l.view.block<1, 3>(2, 0).transpose() + f).norm(), 1e-12);             // looking along f
  // The frusta are sheared in opposite directions by the same amount, and only in x.
  EXPECT_NEAR(l.projection(0, 2), -rt.projection(0, 2), 1e-12);
  EXPECT_GT(l.projection(0, 2), 0);
  EXPECT_EQ(l.projection(1, 2), 0);
  EXPECT_TRUE(((l.projection - rt.projection).array().abs() > 0).count() == 1);
  // Separation 0 is the plain perspective camera: both eyes at the camera, no shear.
  const EyeMatrices m = stereo_eye_matrices(c.position, r, u, f, c.fov, 4.0 / 3, 0.01, 1, 0, d, Eye::right);
  EXPECT_LT((m.position - c.position).norm(), 1e-15);
  EXPECT_EQ(m.projection(0, 2), 0);
}

// Each eye's projection of points at many depths and off the axis: x_right − x_left is the closed
// form f_px·s·(1/D − 1/z) (zero at the convergence distance), the rows are the same in both eyes.
TEST(StereoMath, DisparityIsTheClosedFormAndZeroAtTheConvergenceDistance) {
  const CameraDef c = stereo_camera();
  const double f_px = 0.5 * c.height / std::tan(20.0 * 3.14159265358979323846 / 180);
  for (double conv : {0.0, 0.08, 0.3}) {
    const StereoOptions st{StereoMode::side_by_side, 0.063, conv};
    const double d = conv > 0 ? conv : 0.13;
    EXPECT_NEAR(stereo_convergence(c, st), d, 1e-12);
    EXPECT_NEAR(stereo_disparity_px(c, st, d), 0.0, 1e-9);
    for (double z : {0.05, 0.1, d, 0.2, 0.5, 2.0})
      for (double sx : {-0.02, 0.0, 0.015})
        for (double sy : {-0.01, 0.0, 0.02}) {
          const Vec3 p = at_depth(c, z, sx, sy);
          auto l = project_to_pixel(c, st, Eye::left, p), r = project_to_pixel(c, st, Eye::right, p);
          ASSERT_TRUE(l && r);
          const double closed = f_px * 0.063 * (1 / d - 1 / z);
          EXPECT_NEAR(stereo_disparity_px(c, st, z), closed, 1e-9 * std::max(1.0, std::abs(closed)));
          EXPECT_NEAR(r->x() - l->x(), closed, 1e-9) << "z " << z << " conv " << d;
          EXPECT_NEAR(r->y() - l->y(), 0.0, 1e-9);
          // The two eyes straddle the centre camera's point symmetrically.
          const auto centre = project_to_pixel(c, p);
          ASSERT_TRUE(centre);
          EXPECT_NEAR(0.5 * (l->x() + r->x()), centre->x(), 1e-9);
          EXPECT_NEAR(l->y(), centre->y(), 1e-9);
        }
  }
  // Far away the disparity tends to f_px·s/D (uncrossed), near it is crossed (negative).
  const StereoOptions st{StereoMode::anaglyph, 0.063, 0};
  EXPECT_NEAR(stereo_disparity_px(c, st, 1e9), f_px * 0.063 / 0.13, 1e-6);
  EXPECT_LT(stereo_disparity_px(c, st, 0.05), 0);
  // Nothing for a point behind the eye.
  EXPECT_FALSE(project_to_pixel(c, st, Eye::left, at_depth(c, -0.01)).has_value());
}

// --- images ------------------------------------------------------------------------------------

// A dark scene with one bright marker at `p`: a white dot 6 pixels across (flat, centred on the
// point's projection), or the tool's sphere (radius 2 mm, lit). `storage` holds the dot.
RenderScene marker_scene(const Vec3& p, StereoMode mode, std::vector<Vec3f>& storage, bool sphere = false,
                         double convergence = 0, double separation = 0.063) {
  RenderScene s;
  s.camera = stereo_camera();
  s.background = Vec3f(0, 0, 0);
  s.supersample = 4;
  if (sphere) {
    RenderTool t;
    t.kind = "sphere";
    t.tip = p;
    t.radius = 0.002;
    t.color = Vec3f(1, 1, 1);
    s.tool = t;
  } else {
    storage.assign(1, p.cast<float>());
    s.points.push_back({storage, Vec3f(1, 1, 1), 6.0f});
  }
  s.stereo = {mode, separation, convergence};
  return s;
}

// The centroid (pixels, pixel centres at +0.5) of the pixels whose channel `ch` is above `floor`,
// in the rectangle [x0, x0 + w) × [y0, y0 + h), relative to its corner; (NaN, NaN) when none is.
// Counted, not weighted: the lit sphere's shading does not pull it towards the light.
Eigen::Vector2d centroid(const Image& img, int ch, int x0, int y0, int w, int h, int floor = 28) {
  double n = 0, sx = 0, sy = 0;
  for (int y = y0; y < y0 + h; ++y)
    for (int x = x0; x < x0 + w; ++x)
      if (img.pixel(x, y)[ch] > floor) n += 1, sx += x - x0 + 0.5, sy += y - y0 + 0.5;
  if (n <= 0) return Eigen::Vector2d(NAN, NAN);
  return Eigen::Vector2d(sx / n, sy / n);
}

// Side by side: 2W × H, the left eye on the left. The marker's disparity at six depths (the
// convergence distance among them), on the axis and off it, is the closed form's within a pixel;
// each eye's marker is where that eye's projection puts it, also within a pixel.
TEST(StereoImages, SideBySideShowsTheClosedFormsDisparityZeroAtConvergence) {
  PALPATE_NEEDS(OSMESA, "OSMesa");
  const CameraDef c = stereo_camera();
  const int w = c.width, h = c.height;
  std::vector<Vec3f> dot;
  for (bool sphere : {false, true})
  for (double z : {0.07, 0.1, 0.13, 0.18, 0.3, 0.6})
    for (double sx : {0.0, 0.012}) {
      const Vec3 p = at_depth(c, z, sx, 0.004);
      const RenderScene s = marker_scene(p, StereoMode::side_by_side, dot, sphere);
      auto img = render_rgba(s);
      ASSERT_TRUE(img.ok()) << img.error().message;
      ASSERT_EQ(img->width, 2 * w);
      ASSERT_EQ(img->height, h);
      const Eigen::Vector2d l = centroid(*img, 0, 0, 0, w, h), r = centroid(*img, 0, w, 0, w, h);
      ASSERT_TRUE(l.allFinite() && r.allFinite()) << "the marker at depth " << z << " is in both halves";
      const double closed = stereo_disparity_px(c, s.stereo, z);
      EXPECT_NEAR(r.x() - l.x(), closed, 1.0) << "depth " << z << " m, " << sx << " m off the axis";
      EXPECT_NEAR(r.y() - l.y(), 0.0, 0.5) << "no vertical parallax";
      const auto lp = project_to_pixel(c, s.stereo, Eye::left, p), rp = project_to_pixel(c, s.stereo, Eye::right, p);
      EXPECT_LT((l - *lp).norm(), 1.0) << "left eye at depth " << z;
      EXPECT_LT((r - *rp).norm(), 1.0) << "right eye at depth " << z;
      std::printf("[ disparity ] %s, depth %.3f m, %.3f m off axis: measured %+.3f px, closed form %+.3f px\n",
                  sphere ? "sphere" : "dot", z, sx, r.x() - l.x(), closed);
      if (z == 0.13) {
        EXPECT_NEAR(r.x() - l.x(), 0.0, 1.0) << "zero at the convergence distance";
      }
    }
}

// A set convergence distance moves the zero: the marker at 0.2 m is fused there, one at the
// camera's target (0.13 m) now shows crossed disparity.
TEST(StereoImages, TheConvergenceDistanceIsWhereTheDisparityVanishes) {
  PALPATE_NEEDS(OSMESA, "OSMesa");
  const CameraDef c = stereo_camera();
  for (double z : {0.2, 0.13}) {
    std::vector<Vec3f> dot;
    const RenderScene s = marker_scene(at_depth(c, z), StereoMode::side_by_side, dot, true, 0.2);
    auto img = render_rgba(s);
    ASSERT_TRUE(img.ok()) << img.error().message;
    const double d = (centroid(*img, 0, c.width, 0, c.width, c.height) - centroid(*img, 0, 0, 0, c.width, c.height)).x();
    EXPECT_NEAR(d, stereo_disparity_px(c, s.stereo, z), 1.0);
    if (z == 0.2) {
      EXPECT_NEAR(d, 0.0, 1.0);
    } else {
      EXPECT_LT(d, -10.0);
    }
  }
}

// Top and bottom: W × 2H, the left eye on top; the same disparity, the same rows.
TEST(StereoImages, TopBottomPutsTheLeftEyeOnTop) {
  PALPATE_NEEDS(OSMESA, "OSMesa");
  const CameraDef c = stereo_camera();
  const double z = 0.09;
  std::vector<Vec3f> dot;
  const RenderScene s = marker_scene(at_depth(c, z, -0.01, 0), StereoMode::top_bottom, dot);
  auto img = render_rgba(s);
  ASSERT_TRUE(img.ok()) << img.error().message;
  ASSERT_EQ(img->width, c.width);
  ASSERT_EQ(img->height, 2 * c.height);
  const Eigen::Vector2d top = centroid(*img, 0, 0, 0, c.width, c.height);
  const Eigen::Vector2d bottom = centroid(*img, 0, 0, c.height, c.width, c.height);
  const double closed = stereo_disparity_px(c, s.stereo, z);
  ASSERT_LT(closed, -5);  // crossed: the left eye's marker (top) is right of the right eye's
  EXPECT_NEAR(bottom.x() - top.x(), closed, 1.0);
  EXPECT_NEAR(bottom.y() - top.y(), 0.0, 0.5);
}

// Anaglyph: W × H; red is the left eye's, green and blue the right eye's. A white marker behind
// the convergence plane shows as a red disc left of a cyan one, apart by the disparity.
TEST(StereoImages, AnaglyphTakesRedFromTheLeftEyeAndCyanFromTheRight) {
  PALPATE_NEEDS(OSMESA, "OSMesa");
  const CameraDef c = stereo_camera();
  const double z = 0.4;
  std::vector<Vec3f> dot;
  const RenderScene s = marker_scene(at_depth(c, z), StereoMode::anaglyph, dot, true);
  auto img = render_rgba(s);
  ASSERT_TRUE(img.ok()) << img.error().message;
  ASSERT_EQ(img->width, c.width);
  ASSERT_EQ(img->height, c.height);
  const Eigen::Vector2d red = centroid(*img, 0, 0, 0, c.width, c.height);
  const Eigen::Vector2d green = centroid(*img, 1, 0, 0, c.width, c.height);
  const Eigen::Vector2d blue = centroid(*img, 2, 0, 0, c.width, c.height);
  const double closed = stereo_disparity_px(c, s.stereo, z);
  ASSERT_GT(closed, 10);
  EXPECT_NEAR(green.x() - red.x(), closed, 1.0);
  EXPECT_NEAR(blue.x() - red.x(), closed, 1.0);
  // Apart by more than the discs' size: no pixel is lit in all three channels.
  int white = 0;
  for (int y = 0; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x) {
      const uint8_t* q = img->pixel(x, y);
      white += q[0] > 64 && q[1] > 64 && q[2] > 64;
    }
  EXPECT_EQ(white, 0);
  // Each eye's channels equal that eye's own image.
  RenderScene one = s;
  one.stereo.mode = StereoMode::side_by_side;
  auto pair = render_rgba(one);
  ASSERT_TRUE(pair.ok());
  int differ = 0;
  for (int y = 0; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x) {
      differ += img->pixel(x, y)[0] != pair->pixel(x, y)[0];
      differ += img->pixel(x, y)[1] != pair->pixel(x + c.width, y)[1];
      differ += img->pixel(x, y)[2] != pair->pixel(x + c.width, y)[2];
    }
  EXPECT_EQ(differ, 0);
}

// With no separation both eyes are the camera: each half is the mono image, exactly.
TEST(StereoImages, ZeroSeparationGivesTheMonoImageInEachHalf) {
  PALPATE_NEEDS(OSMESA, "OSMesa");
  const CameraDef c = stereo_camera();
  std::vector<Vec3f> dot;
  RenderScene s = marker_scene(at_depth(c, 0.1, 0.01, 0.01), StereoMode::side_by_side, dot, true, 0, 0.0);
  auto pair = render_rgba(s);
  s.stereo.mode = StereoMode::mono;
  auto mono = render_rgba(s);
  ASSERT_TRUE(pair.ok() && mono.ok());
  ASSERT_EQ(mono->width, c.width);
  int differ = 0, lit = 0;
  for (int y = 0; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x)
      for (int k = 0; k < 3; ++k) {
        differ += pair->pixel(x, y)[k] != mono->pixel(x, y)[k];
        differ += pair->pixel(x + c.width, y)[k] != mono->pixel(x, y)[k];
        lit += mono->pixel(x, y)[k] > 64;
      }
  EXPECT_EQ(differ, 0);
  EXPECT_GT(lit, 10);
}

TEST(StereoImages, QuadBufferIsRefusedOffScreenNamingWhatIsMissing) {
  std::vector<Vec3f> dot;
  RenderScene s = marker_scene(Vec3::Zero(), StereoMode::quad_buffer, dot);
  auto img = render_rgba(s);
  ASSERT_FALSE(img.ok());
  EXPECT_EQ(img.error().message,
            "render: stereo quad-buffer needs a window whose OpenGL context has left and right buffers; an "
            "off-screen (OSMesa) image has none: use anaglyph, side-by-side or top-bottom");
}

// --- the docs' pictures -------------------------------------------------------------------------

// A dented Bézier sheet with the probe's sphere above the dent, in front of the convergence plane.
void write_stereo_picture(StereoMode mode, const std::filesystem::path& file) {
  const int n = 13;
  std::vector<Vec3f> grid(size_t(n) * n);
  for (int r = 0; r < n; ++r)
    for (int k = 0; k < n; ++k) {
      const float x = 0.003f * (k - 6), z = -0.003f * (r - 6);
      grid[size_t(r) * n + k] = Vec3f(x, -0.008f * std::exp(-(x * x + z * z) / 4.5e-5f), z);
    }
  auto surface = tessellate_grid(grid, n, n, {SurfaceScheme::bezier, 16});
  ASSERT_TRUE(surface.ok());
  RenderScene s;
  s.camera.position = Vec3(0, 0.03, 0.045);
  s.camera.target = Vec3(0, -0.004, 0);
  s.camera.fov = 40;
  s.camera.width = 240;
  s.camera.height = 160;
  s.surfaces.push_back({surface->positions, surface->normals, surface->triangles});
  RenderTool t;
  t.tip = Vec3(0.004, 0.006, 0.004);
  t.radius = 0.003;
  s.tool = t;
  s.stereo = {mode, 0.01, 0};  // 10 mm: a modest depth budget for a 5 cm scene seen from 5 cm
  const Status st = render_png(s, file);
  ASSERT_TRUE(st.ok()) << st.error().message;
}

}  // namespace

// Writes docs/images' stereo pictures; disabled, run on demand:
//   ./build/release/tests/palpate_tests --gtest_also_run_disabled_tests --gtest_filter='DocImages.*Stereo*'
TEST(DocImages, DISABLED_WriteStereoModes) {
  PALPATE_NEEDS(OSMESA, "OSMesa");
  const std::filesystem::path dir = std::filesystem::path(PALPATE_SOURCE_DIR) / "docs" / "images";
  std::filesystem::create_directories(dir);
  write_stereo_picture(StereoMode::anaglyph, dir / "stereo_anaglyph.png");
  write_stereo_picture(StereoMode::side_by_side, dir / "stereo_side_by_side.png");
  write_stereo_picture(StereoMode::top_bottom, dir / "stereo_top_bottom.png");
}
