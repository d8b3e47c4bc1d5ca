// test_view_stereo.cpp — `palpate view --stereo MODE` under a virtual X server (xvfb-run) with Mesa's
// software OpenGL, as tests/test_view.cpp runs the viewer: each one-window layout by the content of
// its exit screenshot (the tool's disparity the closed form's within a pixel), and quad-buffer
// refused, naming what is missing, where the display offers no stereo context (Xvfb never does).
#include "apps/stereo_sheet.h"

#include <gtest/gtest.h>
#include <palpate/render.h>

#include "png_read.h"
#include "sanitized.h"
#include "shell_run.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

namespace fs = std::filesystem;

namespace {

using palpate::test::Png;
using palpate::test::Ran;
using palpate::Vec3;

bool have_xvfb() { return std::system("command -v xvfb-run >/dev/null 2>&1") == 0; }

// As test_view.cpp's view(): a private virtual X server, its own X authority file, software GL,
// LeakSanitizer off under ASan (Mesa's GLX driver's blocks).
Ran view(const std::string& args) {
  static int serial = 0;
  const fs::path auth = fs::temp_directory_path() /
                        ("palpate_test_view_stereo_" + std::to_string(::getpid()) + "_" + std::to_string(serial++) + ".xauth");
  std::ofstream{auth};
  const std::string leak = kAddressSanitized ? "ASAN_OPTIONS=detect_leaks=0 " : "";
  Ran r = palpate::test::shell_run(leak + "LIBGL_ALWAYS_SOFTWARE=1 xvfb-run -a -f '" + auth.string() +
                                   "' -s '-screen 0 1024x768x24' " + std::string(PALPATE_CLI) + " view " + args);
  std::error_code ec;
  fs::remove(auth, ec);
  return r;
}

// The printed "tool: x y z" of a viewer run.
Vec3 exit_tool(const std::string& out) {
  const size_t at = out.find("tool: ");
  double x = NAN, y = NAN, z = NAN;
  if (at != std::string::npos) std::sscanf(out.c_str() + at, "tool: %lf %lf %lf", &x, &y, &z);
  return Vec3(x, y, z);
}

// The tool's pixels in the rectangle [x0, x0 + w) × [y0, y0 + h), in its top 60 % where nothing
// else is drawn (the sheet lies lower): their centroid relative to the corner, (NaN, NaN) when none.
// `channels` says which: 7 the sphere's silhouette (any pixel not the background's colour, (0.12,
// 0.13, 0.16) in 8 bits: the disc, not its lit side); 1 the anaglyph's left eye (red not the
// background's, green and blue the background's), 6 its right eye (the other way round).
Eigen::Vector2d tool_pixels(const Png& png, int x0, int y0, int w, int h, int channels = 7) {
  double n = 0, sx = 0, sy = 0;
  for (int y = y0; y < y0 + h * 6 / 10; ++y)
    for (int x = x0; x < x0 + w; ++x) {
      const unsigned char* p = png.at(x, y);
      bool hit = false;
      if (channels == 7) hit = std::abs(p[0] - 31) + std::abs(p[1] - 33) + std::abs(p[2] - 41) > 30;
      else if (channels == 1) hit = std::abs(p[0] - 31) > 8 && std::abs(p[1] - 33) + std::abs(p[2] - 41) < 6;
      else hit = std::abs(p[0] - 31) < 4 && std::abs(p[1] - 33) + std::abs(p[2] - 41) > 12;
      if (hit) n += 1, sx += x - x0 + 0.5, sy += y - y0 + 0.5;
    }
  return n > 0 ? Eigen::Vector2d(sx / n, sy / n) : Eigen::Vector2d(NAN, NAN);
}

class ViewStereo : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!have_xvfb()) GTEST_SKIP() << "xvfb-run is missing: scripts/install-deps installs it (package xvfb)";
    dir_ = fs::path(::testing::TempDir()) / ("palpate_view_stereo_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    // The sheet, the sphere over it and the camera past it (stereo_sheet.h).
    scene_ = dir_ / "sheet.yaml";
    palpate::test::write_stereo_sheet(scene_, "view-stereo", 1, 400, 300);
  }
  void TearDown() override {
    if (!dir_.empty()) fs::remove_all(dir_);
  }
  // The closed-form disparity of the tool in an eye image `height` pixels tall.
  double closed_form(const Vec3& tool, int height, double separation) const {
    palpate::CameraDef cam;
    cam.position = Vec3(0, 0.01, 0.06);
    cam.target = Vec3(0, 0.01, -0.04);
    cam.fov = 40;
    cam.width = 400;
    cam.height = height;
    const double z = (tool - cam.position).dot((cam.target - cam.position).normalized());
    return palpate::stereo_disparity_px(cam, {palpate::StereoMode::side_by_side, separation, 0}, z);
  }
  fs::path dir_, scene_;
};

TEST_F(ViewStereo, SideBySideAndTopBottomShowTheToolsDisparityInTheirHalves) {
  for (const char* mode : {"side-by-side", "top-bottom"}) {
    const bool sbs = std::string(mode) == "side-by-side";
    const fs::path shot = dir_ / (std::string(mode) + ".png");
    const Ran r = view(scene_.string() + " --frames 3 --exit --no-panels --no-report --stereo " + mode +
                       " --eye-separation 10 --screenshot " + shot.string());
    ASSERT_EQ(r.code, 0) << r.out;
    const Png png = palpate::test::load_png(shot);
    ASSERT_EQ(png.width, 400) << r.out;  // the window's size: each eye gets half of it
    ASSERT_EQ(png.height, 300);
    const Vec3 tool = exit_tool(r.out);
    ASSERT_TRUE(tool.allFinite()) << r.out;
    const int w = sbs ? 200 : 400, h = sbs ? 300 : 150;
    const Eigen::Vector2d left = tool_pixels(png, 0, 0, w, h);  // left half, or the top one
    const Eigen::Vector2d right = sbs ? tool_pixels(png, 200, 0, w, h) : tool_pixels(png, 0, 150, w, h);
    ASSERT_TRUE(left.allFinite() && right.allFinite()) << mode << ": the tool in both halves\n" << r.out;
    const double closed = closed_form(tool, h, 0.010);
    std::printf("[ disparity ] palpate view %s: measured %+.3f px, closed form %+.3f px\n", mode,
                right.x() - left.x(), closed);
    EXPECT_LT(closed, -2.0) << "the tool is nearer than the target: crossed";
    EXPECT_NEAR(right.x() - left.x(), closed, 1.0) << mode;
    EXPECT_NEAR(right.y() - left.y(), 0.0, 1.0) << mode << ": no vertical parallax";
  }
}

TEST_F(ViewStereo, AnaglyphDrawsTheLeftEyeInRedAndTheRightInCyan) {
  const fs::path shot = dir_ / "anaglyph.png";
  // 20 mm apart: the tool's two images (40 pixels wide) do not overlap.
  const Ran r = view(scene_.string() + " --frames 3 --exit --no-panels --no-report --stereo anaglyph "
                     "--eye-separation 20 --screenshot " + shot.string());
  ASSERT_EQ(r.code, 0) << r.out;
  const Png png = palpate::test::load_png(shot);
  ASSERT_EQ(png.width, 400) << r.out;
  const Vec3 tool = exit_tool(r.out);
  ASSERT_TRUE(tool.allFinite()) << r.out;
  // Red where the left eye sees the tool (the right eye the dark background), cyan where the right
  // eye does: two discs, the red one right of the cyan one (crossed: nearer than the target).
  const Eigen::Vector2d red = tool_pixels(png, 0, 0, 400, 300, 1), cyan = tool_pixels(png, 0, 0, 400, 300, 6);
  ASSERT_TRUE(red.allFinite() && cyan.allFinite()) << r.out;
  const double closed = closed_form(tool, 300, 0.020);
  std::printf("[ disparity ] palpate view anaglyph: red to cyan %+.3f px, closed form %+.3f px\n",
              cyan.x() - red.x(), closed);
  EXPECT_LT(closed, -40.0);
  EXPECT_NEAR(cyan.x() - red.x(), closed, 1.0);
  EXPECT_NEAR(cyan.y() - red.y(), 0.0, 1.0);
}

// Side by side, the mouse (here --probe) picks in the half it is over: the centre of either half
// presses the sheet at the same point, the one under the centre of a mono window.
TEST_F(ViewStereo, APressInEitherHalfReachesTheSamePoint) {
  const fs::path file = dir_ / "above.yaml";
  std::ofstream(file) << "name: view-stereo-press\nduration: 1\ndt: 0.001\noutput: out\n"
                         "tool: {kind: sphere, radius: 0.003}\n"
                         "device:\n  kind: scripted\n  waypoints:\n    - {t: 0, position: [0, 0.01, 0]}\n"
                         "camera: {position: [0, 0.05, 0.045], target: [0, 0, 0], fov: 40, width: 400, height: 300}\n"
                         "tissues:\n  - name: sheet\n    model: mass_spring\n"
                         "    patch: {shape: flat, width: 0.04, height: 0.04, spacing: 0.004}\n"
                         "    material: {topology: edges, solver: desbrun, stiffness: 200, gravity: false}\n"
                         "    anchors: [0, 10, 110, 120]\n";
  Vec3 tips[2];
  for (int k = 0; k < 2; ++k) {
    const Ran r = view(file.string() + " --frames 3 --exit --no-panels --no-report --stereo side-by-side --probe " +
                       (k == 0 ? "100" : "300") + ",150,0.002 --overrun-margin 0.05");
    ASSERT_EQ(r.code, 0) << r.out;
    tips[k] = exit_tool(r.out);
    ASSERT_TRUE(tips[k].allFinite()) << r.out;
  }
  EXPECT_LT((tips[0] - tips[1]).norm(), 1e-4) << tips[0].transpose() << " vs " << tips[1].transpose();
  EXPECT_NEAR(tips[0].x(), 0.0, 1e-4);  // under the window's centre line: x = 0
  EXPECT_LT(tips[0].y(), 0.0);          // pressed in
}

TEST_F(ViewStereo, QuadBufferIsRefusedWhereTheDisplayOffersNoStereo) {
  const Ran r = view(scene_.string() + " --frames 1 --exit --no-panels --no-report --stereo quad-buffer");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("palpate view: --stereo quad-buffer: the display offers no stereo OpenGL context (no "
                       "framebuffer with left and right back buffers, GLFW_STEREO); quad-buffered stereo needs a "
                       "GPU and driver with stereo enabled and a stereo display; use anaglyph, side-by-side or "
                       "top-bottom"),
            std::string::npos)
      << r.out;
  EXPECT_EQ(r.out.find("frames:"), std::string::npos) << "no frame drawn\n" << r.out;
}

}  // namespace
