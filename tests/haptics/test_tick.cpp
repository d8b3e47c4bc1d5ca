// test_tick.cpp — the tick's named stages: each is timed every tick, the time lands in the stage
// that spent it, the stage timing can be switched off, and a run's summary.json reports each
// stage's median and p99.
#include <palpate/haptics.h>
#include <palpate/run.h>
#include <palpate/scene.h>

#include "haptics/doubles.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <string>

namespace fs = std::filesystem;
using palpate::Vec3;
using namespace palpate::test;

namespace {

palpate::LoopSettings headless() {
  palpate::LoopSettings s;
  s.dt = 0.001;
  s.realtime = false;
  s.try_realtime_priority = false;
  return s;
}

const palpate::TimingFigures& stage(const palpate::LoopStats& st, palpate::TickStage s) {
  return st.stages[static_cast<size_t>(s)];
}

}  // namespace

TEST(TickStages, NamedInOrder) {
  const char* want[] = {"read_devices", "step_tissues", "render_forces", "watchdog",
                        "safety_and_write", "record", "live_figures"};
  ASSERT_EQ(std::size(want), palpate::kTickStageCount);
  for (size_t i = 0; i < palpate::kTickStageCount; ++i)
    EXPECT_STREQ(palpate::tick_stage_name(palpate::TickStage(i)), want[i]);
}

// A tissue whose step takes 300 µs or more: that time is the step_tissues stage's, not another's,
// and no stage is longer than the whole tick.
TEST(TickStages, TheTimeLandsInTheStageThatSpentIt) {
  LinearFloor slow(500.0);
  slow.sleep_every = 1;
  slow.step_sleep = 300e-6;
  FunctionDevice dev([](long) { return Vec3(0, -0.001, 0); }, 0.001, 200);
  auto loop = palpate::HapticLoop::create(dev, {{&slow, 0.0}}, headless());
  ASSERT_TRUE(loop.ok()) << loop.error().message;
  (*loop)->run_headless(200);
  const palpate::LoopStats st = (*loop)->stats();
  EXPECT_GE(stage(st, palpate::TickStage::step_tissues).median, 290e-6);  // the 300 µs sleep (±1.6 % buckets)
  double sum = 0;
  for (size_t i = 0; i < palpate::kTickStageCount; ++i) {
    const palpate::TimingFigures& f = st.stages[i];
    EXPECT_GE(f.p99, f.median) << palpate::tick_stage_name(palpate::TickStage(i));
    EXPECT_GE(f.max, f.p99) << palpate::tick_stage_name(palpate::TickStage(i));
    EXPECT_LE(f.median, st.step.max) << palpate::tick_stage_name(palpate::TickStage(i));
    sum += f.median;
    if (palpate::TickStage(i) != palpate::TickStage::step_tissues) {  // a few µs at most; loose on a shared machine
      EXPECT_LT(f.median, 100e-6) << palpate::tick_stage_name(palpate::TickStage(i));
    }
  }
  EXPECT_LE(sum, 1.05 * st.step.max);
}

TEST(TickStages, OffMeansNoneIsTimed) {
  LinearFloor floor(500.0);
  FunctionDevice dev([](long) { return Vec3(0, -0.001, 0); }, 0.001, 100);
  auto s = headless();
  s.time_stages = false;
  auto loop = palpate::HapticLoop::create(dev, {{&floor, 0.0}}, s);
  ASSERT_TRUE(loop.ok()) << loop.error().message;
  (*loop)->run_headless(100);
  const palpate::LoopStats st = (*loop)->stats();
  EXPECT_EQ(st.ticks, 100u);
  EXPECT_GT(dev.written.back().y(), 0.5);  // the ticks ran: 2 mm into 500 N/m, ramping in
  for (size_t i = 0; i < palpate::kTickStageCount; ++i) EXPECT_EQ(st.stages[i].max, 0.0);
}

TEST(TickStages, SummaryJsonReportsEachStagesMedianAndP99) {
  auto scene = palpate::load_scene(PALPATE_DATA_DIR "/scenes/probe.yaml");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  scene->duration = 0.2;
  palpate::RunOptions o;
  o.out = fs::temp_directory_path() / "palpate_test_tick_stages";
  o.plots = false;
  auto r = palpate::run_scene(*scene, o);
  ASSERT_TRUE(r.ok()) << r.error().message;
  std::ifstream in(r->summary_json);
  const auto j = nlohmann::json::parse(in);
  ASSERT_TRUE(j.contains("tick_stages_s"));
  ASSERT_EQ(j["tick_stages_s"].size(), palpate::kTickStageCount);
  for (size_t i = 0; i < palpate::kTickStageCount; ++i) {
    const auto& f = j["tick_stages_s"][palpate::tick_stage_name(palpate::TickStage(i))];
    EXPECT_GE(f["p99"].get<double>(), f["median"].get<double>());
    EXPECT_EQ(f["median"].get<double>(), r->stages[i].median);
  }
  // The tissues' step is where a charged-particle probe's tick goes.
  EXPECT_GT(r->stages[size_t(palpate::TickStage::step_tissues)].median, 0.0);
  fs::remove_all(o.out);
}
