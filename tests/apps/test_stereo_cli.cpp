// test_stereo_cli.cpp — `palpate run --frames N --stereo MODE` (docs/viewer.md, "Stereo"): the
// frame's layout and the tool's disparity in it by image content, and the refusals (a bad mode,
// quad-buffer off-screen, stereo without frames) with their messages.
#include <palpate/render.h>

#include "components.h"
#include "png_read.h"
#include "shell_run.h"

#include "apps/stereo_sheet.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

namespace fs = std::filesystem;

namespace {

using palpate::test::Png;
using palpate::test::Ran;
using palpate::test::run_cli;

class StereoRun : public ::testing::Test {
 protected:
  void SetUp() override {
    PALPATE_NEEDS_CLI();
    dir_ = fs::path(::testing::TempDir()) / ("palpate_stereo_run_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    // The sheet, the sphere over it and the camera past it (stereo_sheet.h).
    scene_ = dir_ / "sheet.yaml";
    palpate::test::write_stereo_sheet(scene_, "stereo-sheet", 0.01, 200, 150);
  }
  void TearDown() override {
    if (!dir_.empty()) fs::remove_all(dir_);
  }
  fs::path dir_, scene_;
};

// The sphere's silhouette in [x0, x0 + w) and the image's top 60 %, where nothing else is drawn
// (the sheet lies lower): the centroid's x of the pixels not the background's colour (0.12, 0.13,
// 0.16), NaN when none. The silhouette, not the shading: the lit side is not where the disc is.
double sphere_x(const Png& png, int x0, int w) {
  double n = 0, sx = 0;
  for (int y = 0; y < png.height * 6 / 10; ++y)
    for (int x = x0; x < x0 + w; ++x) {
      const unsigned char* p = png.at(x, y);
      if (std::abs(p[0] - 31) + std::abs(p[1] - 33) + std::abs(p[2] - 41) > 30) n += 1, sx += x - x0 + 0.5;
    }
  return n > 0 ? sx / n : NAN;
}

TEST_F(StereoRun, SideBySideFramesAreTwiceAsWideAndShowTheToolsDisparity) {
  PALPATE_NEEDS(OSMESA, "OSMesa");
  const fs::path out = dir_ / "sbs";
  const Ran r = run_cli("run " + scene_.string() + " -q --frames 1 --stereo side-by-side --eye-separation 20 -o " +
                        out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  const Png png = palpate::test::load_png(out / "frame_000.png");
  ASSERT_EQ(png.width, 400) << r.out;
  ASSERT_EQ(png.height, 150);
  // The tool at depth z from the camera, the convergence the camera's distance to its target.
  const palpate::Vec3 eye(0, 0.01, 0.06), target(0, 0.01, -0.04), tool(0, 0.01, 0);
  const double z = (tool - eye).dot((target - eye).normalized());
  palpate::CameraDef cam;
  cam.position = eye;
  cam.target = target;
  cam.fov = 40;
  cam.width = 200;
  cam.height = 150;
  const double closed = palpate::stereo_disparity_px(cam, {palpate::StereoMode::side_by_side, 0.020, 0}, z);
  const double left = sphere_x(png, 0, 200), right = sphere_x(png, 200, 200);
  ASSERT_TRUE(std::isfinite(left) && std::isfinite(right)) << "the tool shows in both halves";
  std::printf("[ disparity ] palpate run frame: measured %+.3f px, closed form %+.3f px\n", right - left, closed);
  EXPECT_LT(closed, -20.0);  // nearer than the target: crossed
  EXPECT_NEAR(right - left, closed, 1.0);
}

TEST_F(StereoRun, AnaglyphAndTopBottomFramesHaveTheirLayout) {
  PALPATE_NEEDS(OSMESA, "OSMesa");
  const Ran a = run_cli("run " + scene_.string() + " -q --frames 1 --stereo anaglyph -o " + (dir_ / "a").string());
  ASSERT_EQ(a.code, 0) << a.out;
  const Png ana = palpate::test::load_png(dir_ / "a" / "frame_000.png");
  EXPECT_EQ(ana.width, 200);
  EXPECT_EQ(ana.height, 150);
  const Ran t = run_cli("run " + scene_.string() + " -q --frames 1 --stereo top-bottom --convergence 0.1 -o " +
                        (dir_ / "t").string());
  ASSERT_EQ(t.code, 0) << t.out;
  const Png tb = palpate::test::load_png(dir_ / "t" / "frame_000.png");
  EXPECT_EQ(tb.width, 200);
  EXPECT_EQ(tb.height, 300);
  // The mono frame, for comparison: the anaglyph differs from it (the eyes see apart).
  const Ran m = run_cli("run " + scene_.string() + " -q --frames 1 -o " + (dir_ / "m").string());
  ASSERT_EQ(m.code, 0) << m.out;
  const Png mono = palpate::test::load_png(dir_ / "m" / "frame_000.png");
  EXPECT_GT(palpate::test::changed_pixels(mono, ana), 100);
}

TEST(StereoCli, BadModesAndQuadBufferOffScreenAreRefusedNamingWhy) {
  PALPATE_NEEDS_CLI();
  const std::string scene = PALPATE_SOURCE_DIR "/data/scenes/liver-probe.yaml";
  Ran r = run_cli("run " + scene + " --frames 1 --stereo red-blue -o /nonexistent/never");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("stereo mode 'red-blue'; expected anaglyph, side-by-side, top-bottom or quad-buffer"),
            std::string::npos)
      << r.out;
  r = run_cli("view " + scene + " --stereo 3d --exit");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("stereo mode '3d'; expected anaglyph, side-by-side, top-bottom or quad-buffer"),
            std::string::npos)
      << r.out;
  r = run_cli("run " + scene + " --frames 1 --stereo quad-buffer -o /nonexistent/never");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("palpate run: --stereo quad-buffer: frames are drawn off-screen (OSMesa), which has no "
                       "stereo (left and right) buffers; use anaglyph, side-by-side or top-bottom"),
            std::string::npos)
      << r.out;
  r = run_cli("run " + scene + " --stereo anaglyph -o /nonexistent/never");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("palpate run: --stereo draws the frames in stereo; give --frames N or --frame-times"),
            std::string::npos)
      << r.out;
  for (const char* bad : {"--eye-separation -1", "--eye-separation x", "--convergence 0", "--convergence nan"}) {
    r = run_cli("run " + scene + " --frames 1 --stereo anaglyph " + bad + " -o /nonexistent/never");
    EXPECT_EQ(r.code, 2) << bad << "\n" << r.out;
  }
  for (const char* command : {"run", "view"}) {
    r = run_cli(std::string(command) + " --help");
    EXPECT_EQ(r.code, 0);
    for (const char* flag : {"--stereo", "--eye-separation", "--convergence"})
      EXPECT_NE(r.out.find(flag), std::string::npos) << command << " " << flag;
  }
}

}  // namespace
