// test_run_probe.cpp — run_scene with the scene's ultrasound probe: the probe's own device and
// safety filter in the run, its columns and summary; `--ultrasound N` images (count, size, listing,
// determinism); the needle's feel with and without the probe on the skin; errors.
#include <palpate/run.h>
#include <palpate/scene.h>

#include "png_read.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <algorithm>
#include <iterator>
#include <sstream>
#include <string>

namespace fs = std::filesystem;
using palpate::Vec3;

namespace {

palpate::SceneDef cvc() {
  auto s = palpate::load_scene(PALPATE_SOURCE_DIR "/data/scenes/cvc.yaml");
  EXPECT_TRUE(s.ok()) << s.error().message;
  EXPECT_TRUE(s->probe.has_value()) << "cvc.yaml holds the probe";
  return *s;
}

std::string bytes(const fs::path& f) {
  std::ifstream in(f, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

nlohmann::json summary(const fs::path& out) {
  std::ifstream in(out / "summary.json");
  return nlohmann::json::parse(in);
}

}  // namespace

TEST(RunProbe, TheCvcProbePressesWithinItsDeviceAndTheNeedleMeetsTheNeckItPressed) {
  palpate::SceneDef with = cvc();
  palpate::SceneDef without = with;
  without.probe.reset();
  const fs::path out_a = fs::temp_directory_path() / "palpate_test_run_probe_a";
  const fs::path out_b = fs::temp_directory_path() / "palpate_test_run_probe_b";
  palpate::RunOptions o;
  o.plots = false;
  o.out = out_a;
  auto a = palpate::run_scene(with, o);
  ASSERT_TRUE(a.ok()) << a.error().message;
  o.out = out_b;
  auto b = palpate::run_scene(without, o);
  ASSERT_TRUE(b.ok()) << b.error().message;

  // The probe: a light rest (0.06 N), a firm check press (about 3 N) before the needle reaches
  // the skin, then light again while the needle goes in; within its device's limits throughout.
  ASSERT_EQ(a->tools.size(), 1u);
  const palpate::LoopToolStats& p = a->tools[0];
  EXPECT_EQ(p.name, "probe");
  EXPECT_GT(p.max_force, 2.5);
  EXPECT_LE(p.max_force, with.probe->device.max_force);
  EXPECT_EQ(p.safety.clamped, 0u);
  EXPECT_EQ(p.safety.non_finite + p.safety.device_failed + p.safety.overrun, 0u);
  EXPECT_TRUE(b->tools.empty());
  const auto j = summary(out_a);
  EXPECT_NEAR(j["probe"]["max_force_N"].get<double>(), p.max_force, 1e-12);
  EXPECT_EQ(j["probe"]["safety"]["clamped"], 0);
  EXPECT_EQ(j["probe"]["safety"]["max_force_N"].get<double>(), with.probe->device.max_force);
  EXPECT_FALSE(summary(out_b).contains("probe"));

  // run.csv: the probe's columns after the needle's and the tissues'.
  std::ifstream csv(out_a / "run.csv");
  std::string header;
  std::getline(csv, header);
  EXPECT_NE(header.find(",probe_x,probe_y,probe_z,probe_qw,probe_qx,probe_qy,probe_qz,probe_force_x,"
                        "probe_force_y,probe_force_z,probe_force_N,probe_events"),
            std::string::npos)
      << header;

  // The press is over before the needle first touches the skin, and the probe rests lightly
  // while the needle is in.
  const double first_skin = a->metrics.first_skin_puncture;
  ASSERT_GT(first_skin, 0);
  std::ifstream rows(out_a / "run.csv");
  std::getline(rows, header);
  std::vector<std::string> names;
  for (std::stringstream ss(header); std::getline(ss, header, ',');) names.push_back(header);
  const size_t col_t = 0;
  const size_t col_pf = size_t(std::find(names.begin(), names.end(), "probe_force_N") - names.begin());
  ASSERT_LT(col_pf, names.size());
  double peak_before = 0, max_during = 0, min_during = 1e9;
  for (std::string line; std::getline(rows, line);) {
    std::vector<double> v;
    for (std::stringstream ss(line); std::getline(ss, header, ',');) v.push_back(std::strtod(header.c_str(), nullptr));
    const double time = v[col_t], f = v[col_pf];
    if (time < first_skin - 0.5) peak_before = std::max(peak_before, f);
    if (time > first_skin - 0.3 && time < a->metrics.flashback_time + 1.0)
      max_during = std::max(max_during, f), min_during = std::min(min_during, f);
  }
  EXPECT_GT(peak_before, 2.5) << "the check press comes before the needle";
  EXPECT_LT(max_during, 0.6) << "a light touch while the needle goes in";
  EXPECT_GT(min_during, 0.02) << "and still on the skin";

  // The needle meets the neck the probe has deformed (one neck under both tools, docs/ultrasound.md):
  // the resting probe sinks the skin and the vein a little beside and under it, so the same script
  // gives the same events in the same order and the same outcome, each within 0.15 s (0.75 mm of
  // the needle's travel at 5 mm/s), the punctures at the same set forces.
  ASSERT_EQ(a->ticks, b->ticks);
  EXPECT_EQ(a->metrics.outcome, b->metrics.outcome);
  ASSERT_EQ(a->events.size(), b->events.size());
  for (size_t i = 0; i < a->events.size(); ++i) {
    EXPECT_EQ(a->events[i].kind, b->events[i].kind);
    EXPECT_EQ(a->events[i].tissue, b->events[i].tissue);
    // Going in, the tissue it meets lies deeper (later); coming out, it is out sooner (earlier).
    const double late = a->events[i].time - b->events[i].time;
    EXPECT_LE(std::abs(late), 0.15) << a->events[i].kind << " " << a->events[i].tissue;
    if (a->events[i].kind == "exit") EXPECT_LE(late, 0.0) << a->events[i].tissue;
    else EXPECT_GE(late, 0.0) << a->events[i].kind << " " << a->events[i].tissue;
    if (a->events[i].kind == "puncture") {
      EXPECT_EQ(a->events[i].force, b->events[i].force);
    }
  }
  fs::remove_all(out_a);
  // Lifted off the skin the probe deforms nothing, and the needle is as it was without it.
  palpate::SceneDef lifted = with;
  lifted.probe->device.waypoints = {{0.0, Vec3(0, 0.01, 0)}};
  o.out = out_a;
  a = palpate::run_scene(lifted, o);
  ASSERT_TRUE(a.ok()) << a.error().message;
  ASSERT_EQ(a->ticks, b->ticks);
  EXPECT_EQ(a->max_force, b->max_force);
  EXPECT_EQ(a->metrics.outcome, b->metrics.outcome);
  ASSERT_EQ(a->events.size(), b->events.size());
  for (size_t i = 0; i < a->events.size(); ++i) {
    EXPECT_EQ(a->events[i].kind, b->events[i].kind);
    EXPECT_EQ(a->events[i].time, b->events[i].time);
    EXPECT_EQ(a->events[i].force, b->events[i].force);
  }
  // Row by row, the needle's and the tissues' part of run.csv (every column of the run without a
  // probe) is identical, text for text.
  std::ifstream ia(out_a / "run.csv"), ib(out_b / "run.csv");
  std::string la, lb;
  size_t n = 0;
  size_t keep = 0;
  while (std::getline(ia, la) && std::getline(ib, lb)) {
    if (n == 0) keep = std::count(lb.begin(), lb.end(), ',') + 1;  // the run without a probe's columns
    // The first `keep` cells of each row.
    size_t pos = 0;
    for (size_t c = 0; c < keep && pos != std::string::npos; ++c) pos = la.find(',', pos + (c ? 1 : 0));
    ASSERT_EQ(la.substr(0, pos), lb) << "row " << n;
    ++n;
  }
  EXPECT_EQ(n, a->ticks + 1);
  fs::remove_all(out_a);
  fs::remove_all(out_b);
}

TEST(RunProbe, UltrasoundImagesAreWrittenListedAndTheSameEachRun) {
  palpate::SceneDef s = cvc();
  s.duration = 0.6;
  const fs::path out1 = fs::temp_directory_path() / "palpate_test_run_us_1";
  const fs::path out2 = fs::temp_directory_path() / "palpate_test_run_us_2";
  fs::remove_all(out1), fs::remove_all(out2);
  palpate::RunOptions o;
  o.plots = false;
  o.ultrasound = 3;
  o.out = out1;
  auto r1 = palpate::run_scene(s, o);
  ASSERT_TRUE(r1.ok()) << r1.error().message;
  o.out = out2;
  auto r2 = palpate::run_scene(s, o);
  ASSERT_TRUE(r2.ok()) << r2.error().message;
  EXPECT_EQ(r1->ultrasound_error, "");
  ASSERT_EQ(r1->ultrasound.size(), 3u);
  const double expect[3] = {0.001, 0.301, 0.6};  // after ticks 1, 1 + round(599 / 2), 600
  const auto j = summary(out1);
  ASSERT_EQ(j["outputs"]["ultrasound"].size(), 3u);
  for (size_t k = 0; k < 3; ++k) {
    const std::string name = "us_00" + std::to_string(k) + ".png";
    EXPECT_EQ(r1->ultrasound[k].file, out1 / name);
    EXPECT_NEAR(r1->ultrasound[k].time, expect[k], 1e-9) << k;
    EXPECT_EQ(j["outputs"]["ultrasound"][k]["file"], name);
    EXPECT_NEAR(j["outputs"]["ultrasound"][k]["time_s"].get<double>(), expect[k], 1e-9);
    const palpate::test::Png png = palpate::test::load_png(out1 / name);
    EXPECT_EQ(png.width, s.probe->image_width) << name;
    EXPECT_EQ(png.height, s.probe->image_height) << name;
    // Same run, same images, byte for byte.
    const std::string b1 = bytes(out1 / name), b2 = bytes(out2 / name);
    ASSERT_FALSE(b1.empty());
    EXPECT_TRUE(b1 == b2) << name << " differs between two runs";
  }
  // The image is of the neck: the skin line is bright, the vein's lumen dark (the probe at rest).
  const palpate::test::Png img = palpate::test::load_png(out1 / "us_002.png");
  ASSERT_GT(img.width, 0);
  long bright = 0;
  for (int x = 0; x < img.width; ++x)
    for (int y = 0; y < img.height / 16; ++y) bright += img.at(x, y)[0] > 100 ? 1 : 0;
  EXPECT_GT(bright, img.width / 4) << "a bright skin line near the face";
  fs::remove_all(out1), fs::remove_all(out2);
}

TEST(RunProbe, UltrasoundWithoutAProbeIsAClearError) {
  palpate::SceneDef s = cvc();
  s.probe.reset();
  palpate::RunOptions o;
  o.out = fs::temp_directory_path() / "palpate_test_run_us_none";
  o.ultrasound = 2;
  auto r = palpate::run_scene(s, o);
  ASSERT_FALSE(r.ok());
  const std::string& m = r.error().message;
  EXPECT_NE(m.find("cvc.yaml: ultrasound images need a 'probe' section in the scene"), std::string::npos) << m;
  o.ultrasound = -1;
  s = cvc();
  r = palpate::run_scene(s, o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("ultrasound images must be between 0 and"), std::string::npos);
  fs::remove_all(o.out);
}
