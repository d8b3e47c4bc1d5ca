// test_run_frames.cpp — `palpate run --frames N`: frames evenly spaced over a run, headless and
// realtime, showing the tissue as it was at their tick; SnapshotTissue's stamps.
#include <palpate/run.h>
#include <palpate/snapshot_tissue.h>
#include <palpate/tissue.h>
#include <palpate/scene.h>

#include "components.h"
#include "png_read.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>

namespace fs = std::filesystem;
using palpate::Vec3;

namespace {

using palpate::test::changed_pixels;
using palpate::test::load_png;
using palpate::test::Png;

palpate::SceneDef probe_scene() {
  auto scene = palpate::load_scene(PALPATE_SOURCE_DIR "/data/scenes/probe.yaml");
  EXPECT_TRUE(scene.ok()) << scene.error().message;
  scene->camera->width = 240, scene->camera->height = 180;
  return *scene;
}

// A realtime run into `out` (emptied first), without plots or the realtime priority a test
// cannot count on.
palpate::RunOptions realtime_run_options(const fs::path& out) {
  fs::remove_all(out);
  palpate::RunOptions opt;
  opt.out = out;
  opt.plots = false;
  opt.realtime = true;
  opt.realtime_priority = false;
  return opt;
}

}  // namespace

TEST(RunFrames, HeadlessFramesAreEvenlySpacedAndShowThePressAndTheReturn) {
  PALPATE_NEEDS(OSMESA, "OSMesa");
  // probe.yaml: approach (0–1 s), press to 5 mm (1–2 s), hold, release by 3.5 s, rest at 4 s.
  const palpate::SceneDef scene = probe_scene();
  const fs::path out = fs::temp_directory_path() / "palpate_test_run_frames";
  fs::remove_all(out);
  palpate::RunOptions opt;
  opt.out = out;
  opt.plots = false;
  opt.frames = 5;
  auto r = palpate::run_scene(scene, opt);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->frame_error, "");
  ASSERT_EQ(r->frames.size(), 5u);
  // The first after the first tick, the last at the end, evenly spaced between.
  const double expect[5] = {0.001, 1.001, 2.0, 3.0, 4.0};
  for (size_t k = 0; k < 5; ++k) {
    EXPECT_NEAR(r->frames[k].time, expect[k], 0.0011) << k;
    EXPECT_EQ(r->frames[k].file, out / ("frame_00" + std::to_string(k) + ".png"));
    EXPECT_TRUE(fs::exists(r->frames[k].file));
  }
  std::ifstream js(out / "summary.json");
  const auto j = nlohmann::json::parse(js);
  ASSERT_EQ(j["outputs"]["frames"].size(), 5u);
  EXPECT_EQ(j["outputs"]["frames"][2]["file"], "frame_002.png");
  EXPECT_NEAR(j["outputs"]["frames"][2]["time_s"].get<double>(), 2.0, 0.0011);

  const Png before = load_png(r->frames[0].file), pressed = load_png(r->frames[2].file),
            after = load_png(r->frames[4].file);
  ASSERT_EQ(before.width, 240);
  ASSERT_EQ(pressed.rgb.size(), before.rgb.size());
  // Pressed 5 mm in: the tool moved and the surface dents; released: the tool is back where it
  // started and the tissue has returned (elasticity 20/s, 0.5 s after release), so the last frame
  // looks like the first.
  const long press_diff = changed_pixels(before, pressed), after_diff = changed_pixels(before, after);
  EXPECT_GT(press_diff, 300);
  EXPECT_LT(after_diff, press_diff / 10);
}

TEST(RunFrames, RealtimeFramesAreDrawnWhileTheLoopRuns) {
  PALPATE_NEEDS(OSMESA, "OSMesa");
  palpate::SceneDef scene = probe_scene();
  const fs::path out = fs::temp_directory_path() / "palpate_test_run_frames_rt";
  // The run lasts long enough for the renderer to keep up: 0.6 s, or 8 frames' time where drawing
  // is slow (a sanitizer build, a loaded machine), so that each frame can be drawn in its turn.
  double frame_s = 0;
  {
    scene.duration = 0.01;
    palpate::RunOptions one;
    one.out = out;
    one.plots = false;
    one.frames = 1;
    const auto t0 = std::chrono::steady_clock::now();
    ASSERT_TRUE(palpate::run_scene(scene, one).ok());
    frame_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  scene.duration = std::max(0.6, std::ceil(80 * frame_s) / 10);
  const auto ticks = static_cast<std::uint64_t>(std::llround(scene.duration * 1000));
  palpate::RunOptions opt = realtime_run_options(out);
  opt.frames = 3;
  auto r = palpate::run_scene(scene, opt);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->frame_error, "");
  EXPECT_EQ(r->ticks, ticks);
  ASSERT_EQ(r->frames.size(), 3u);
  for (size_t k = 0; k < 3; ++k) EXPECT_TRUE(fs::exists(r->frames[k].file)) << k;
  // Each shows a later tick than the one before, the last near the end of the run.
  EXPECT_LT(r->frames[0].time, r->frames[1].time);
  EXPECT_LT(r->frames[1].time, r->frames[2].time);
  EXPECT_LT(r->frames[0].time, 0.1);
  EXPECT_GT(r->frames[2].time, scene.duration * 5 / 6);
  // The recording is untouched by the frames: every tick is there.
  std::ifstream csv(out / "run.csv");
  size_t rows = 0;
  for (std::string line; std::getline(csv, line);) ++rows;
  EXPECT_EQ(rows, ticks + 1);
}

// The first tick publishes a copy that nobody asked for (the slots' first fill, for a viewer's
// first frame); a frame asked for later must not take it, nor the one its request leaves behind
// for the next frame: each realtime frame shows the tissue at its own time (a TSan run in CI drew
// the last of three frames at the middle one's time).
TEST(RunFrames, RealtimeFramesAtChosenTimesShowThoseTimes) {
  PALPATE_NEEDS(OSMESA, "OSMesa");
  palpate::SceneDef scene = probe_scene();
  scene.duration = 1.2;
  palpate::RunOptions opt = realtime_run_options(fs::temp_directory_path() / "palpate_test_run_frames_rt_times");
  opt.frame_times = {0.3, 0.6, 0.9};
  auto r = palpate::run_scene(scene, opt);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->frame_error, "");
  ASSERT_EQ(r->frames.size(), 3u);
  // A frame is asked for 3 ticks before its time and shows the first step after the request; one
  // that is late (the drawing of the one before took long) shows a later tick, never an earlier;
  // one drawn after the run ended (a loaded machine, a sanitizer) shows its last tick.
  for (size_t k = 0; k < 3; ++k) {
    EXPECT_GE(r->frames[k].time, opt.frame_times[k] - 0.0035) << k;
    EXPECT_LE(r->frames[k].time, scene.duration + 1e-9) << k;
    if (k + 1 < 3) {
      EXPECT_LE(r->frames[k].time, r->frames[k + 1].time) << k;
    }
  }
}

TEST(RunFrames, MoreFramesThanTicksIsAClearError) {
  palpate::SceneDef scene = probe_scene();
  scene.duration = 0.01;
  palpate::RunOptions opt;
  opt.out = fs::temp_directory_path() / "palpate_test_run_frames_err";
  opt.frames = 11;
  auto r = palpate::run_scene(scene, opt);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("probe.yaml: frames must be between 0 and the run's 10 ticks, not 11"),
            std::string::npos)
      << r.error().message;
}

namespace {

// Pushes back with the tool's x coordinate as its force, and reports it as the one drawn point.
class Echo final : public palpate::Tissue {
 public:
  const std::string& name() const override { return name_; }
  Vec3 step(const palpate::ToolState& tool, double) noexcept override {
    x_ = tool.tip.x();
    return Vec3(0, x_, 0);
  }
  std::span<const std::string> figure_names() const override { return {}; }
  void figures(std::span<double>) const noexcept override {}
  size_t drain_events(std::span<palpate::TissueEvent>) noexcept override { return 0; }
  void snapshot(palpate::TissueSnapshot& s) const override {
    s.points.assign(1, palpate::Vec3f(float(x_), 0, 0));
  }
  void reset() noexcept override { x_ = 0; }

 private:
  std::string name_ = "echo";
  double x_ = 0;
};

}  // namespace

TEST(SnapshotTissue, StampsACopyWithTheToolAndForceOfItsStep) {
  palpate::SnapshotTissue t(std::make_unique<Echo>());
  palpate::ToolState tool;
  bool fresh = true;
  t.latest(&fresh);
  EXPECT_FALSE(t.current_stamp().stepped);  // the copy made at construction
  for (int k = 1; k <= 5; ++k) {
    tool.time = k * 0.001;
    tool.tip = Vec3(0.01 * k, 0, 0);
    if (k == 3) t.request();
    t.step(tool, 0.001);
  }
  // Served twice: the request pending since construction (step 1) and the one before step 3.
  EXPECT_EQ(t.published(), 2u);
  const palpate::TissueSnapshot& s = t.latest(&fresh);
  ASSERT_TRUE(fresh);
  const palpate::SnapshotStamp& st = t.current_stamp();
  EXPECT_TRUE(st.stepped);
  EXPECT_DOUBLE_EQ(st.time, 0.003);
  EXPECT_DOUBLE_EQ(st.tip.x(), 0.03);
  EXPECT_DOUBLE_EQ(st.force.y(), 0.03);
  ASSERT_EQ(s.points.size(), 1u);
  EXPECT_FLOAT_EQ(s.points[0].x(), 0.03f);
}

TEST(SnapshotTissue, PublishLastStepStampsTheCopyWithTheLastStepNotTheLastRequest) {
  // A realtime run that ended before its renderer asked again: the frame drawn afterwards shows
  // the tissue as the last tick left it and must say so (time, tool, force of that tick).
  palpate::SnapshotTissue t(std::make_unique<Echo>());
  palpate::ToolState tool;
  for (int k = 1; k <= 7; ++k) {
    tool.time = k * 0.001;
    tool.tip = Vec3(0.01 * k, 0, 0);
    t.step(tool, 0.001);  // only step 1 serves a request (the one pending since construction)
  }
  t.latest();
  EXPECT_DOUBLE_EQ(t.current_stamp().time, 0.001);
  t.publish_last_step();
  bool fresh = false;
  const palpate::TissueSnapshot& s = t.latest(&fresh);
  ASSERT_TRUE(fresh);
  const palpate::SnapshotStamp& st = t.current_stamp();
  EXPECT_TRUE(st.stepped);
  EXPECT_DOUBLE_EQ(st.time, 0.007);
  EXPECT_DOUBLE_EQ(st.tip.x(), 0.07);
  EXPECT_DOUBLE_EQ(st.force.y(), 0.07);
  ASSERT_EQ(s.points.size(), 1u);
  EXPECT_FLOAT_EQ(s.points[0].x(), 0.07f);
}
