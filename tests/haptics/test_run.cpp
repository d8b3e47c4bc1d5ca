// test_run.cpp — run_scene: fixed ticks, the force path through safety, outputs written atomically;
// scripted needle directions reach the tissues and the plots; scenes without them run as before.
#include <palpate/device.h>
#include <palpate/run.h>
#include <palpate/scene.h>
#include <palpate/tissue.h>
#include <palpate/tissue_files.h>

#include "haptics/doubles.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace fs = std::filesystem;
using palpate::Vec3;

namespace {

// A test double: a rigid floor at y = 0 pushing back with k·penetration, and a "puncture" event
// the first time the force passes a threshold.
class Floor final : public palpate::Tissue {
 public:
  explicit Floor(double k) : k_(k) {}
  const std::string& name() const override { return name_; }
  Vec3 step(const palpate::ToolState& tool, double) noexcept override {
    const double pen = std::max(0.0, tool.radius - tool.tip.y());
    force_ = k_ * pen;
    if (!fired_ && force_ > 1.0 && pending_ == 0) {
      fired_ = true;
      event_ = {tool.time, "puncture", 0, pen, force_};
      pending_ = 1;
    }
    return Vec3(0, force_, 0);
  }
  std::span<const std::string> figure_names() const override { return names_; }
  void figures(std::span<double> out) const noexcept override { out[0] = force_; }
  size_t drain_events(std::span<palpate::TissueEvent> out) noexcept override {
    if (pending_ == 0 || out.empty()) return 0;
    out[0] = event_;
    pending_ = 0;
    return 1;
  }
  void snapshot(palpate::TissueSnapshot&) const override {}
  void reset() noexcept override { force_ = 0; }

 private:
  double k_;
  double force_ = 0;
  bool fired_ = false;
  int pending_ = 0;
  palpate::TissueEvent event_;
  std::string name_ = "floor";
  std::vector<std::string> names_ = {"force_N"};
};

palpate::SceneDef press_scene(const fs::path& out) {
  palpate::SceneDef s;
  s.name = "press";
  s.duration = 1.0;
  s.dt = 0.001;
  s.output = out;
  s.tool.radius = 0.001;
  s.device.ramp_in = 0.0;
  s.device.waypoints = {{0.0, Vec3(0, 0.002, 0)}, {1.0, Vec3(0, -0.008, 0)}};
  return s;
}

std::vector<std::unique_ptr<palpate::Tissue>> floor_of(double k) {
  std::vector<std::unique_ptr<palpate::Tissue>> v;
  v.push_back(std::make_unique<Floor>(k));
  return v;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace

TEST(Run, FixedTicksCsvAndSummary) {
  const fs::path out = fs::temp_directory_path() / "palpate_test_run";
  fs::remove_all(out);
  auto r = palpate::run_scene(press_scene(out), floor_of(300.0));
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->ticks, 1000u);
  EXPECT_TRUE(fs::exists(out / "run.csv"));
  EXPECT_TRUE(fs::exists(out / "summary.json"));
  for (const auto& e : fs::directory_iterator(out))  // no temporary files left behind
    EXPECT_EQ(e.path().string().find(".tmp"), std::string::npos) << e.path();

  std::istringstream csv(slurp(out / "run.csv"));
  std::string header;
  std::getline(csv, header);
  EXPECT_EQ(header,
            "t,tool_x,tool_y,tool_z,force_x,force_y,force_z,force_N,tick,tool_qw,tool_qx,tool_qy,"
            "tool_qz,buttons,events,passivity_energy,passivity_damping,floor.force_N");
  size_t rows = 0;
  std::string line;
  double last_t = 0, last_f = 0;
  while (std::getline(csv, line)) {
    ++rows;
    double v[9];
    ASSERT_EQ(std::sscanf(line.c_str(), "%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf", &v[0], &v[1], &v[2],
                          &v[3], &v[4], &v[5], &v[6], &v[7], &v[8]), 9) << line;
    EXPECT_EQ(v[8], double(rows - 1)) << "tick numbers are consecutive from 0";
    EXPECT_NEAR(v[0] - last_t, 0.001, 1e-9);
    last_t = v[0];
    EXPECT_LE(v[7], 3.3 + 1e-9);                        // never above the device maximum
    EXPECT_LE(std::abs(v[7] - last_f), 0.2 + 1e-9);     // rate limit: 200 N/s · 1 ms
    last_f = v[7];
  }
  EXPECT_EQ(rows, 1000u);
  EXPECT_NEAR(last_f, 2.7, 1e-6);  // pressed 9 mm into 300 N/m, below the 3.3 N maximum
  auto j = nlohmann::json::parse(slurp(out / "summary.json"));
  EXPECT_EQ(j["ticks"], 1000);
  EXPECT_EQ(j["events"].size(), 1u);
  EXPECT_EQ(j["events"][0]["kind"], "puncture");
  EXPECT_EQ(j["events"][0]["tissue"], "floor");
  EXPECT_GT(j["step_time_s"]["p99"].get<double>(), 0.0);
  EXPECT_GE(j["step_time_s"]["max"].get<double>(), j["step_time_s"]["median"].get<double>());

  // Plots: both PNGs exist and are PNGs, and the script marks the one event on each plot.
  ASSERT_EQ(j["outputs"]["plots"].size(), 2u) << j.dump(2);
  for (const char* png : {"force_time.png", "force_depth.png"}) {
    const std::string bytes = slurp(out / png);
    ASSERT_GT(bytes.size(), 1000u) << png;
    EXPECT_EQ(bytes.substr(1, 3), "PNG") << png;
  }
  const std::string gp = slurp(out / "plots.gp");
  size_t marks = 0;
  for (size_t at = gp.find("'puncture floor'"); at != std::string::npos; at = gp.find("'puncture floor'", at + 1)) ++marks;
  EXPECT_EQ(marks, 2u);
}

TEST(Run, SummaryReportsTheTissuesOnTheirOwnThread) {
  // summary.json's "physics": each multi-rate tissue's steps, step time and late steps (here
  // headless: inline every 10 ticks), and an empty list when every tissue steps every tick.
  const fs::path out = fs::temp_directory_path() / "palpate_test_run_physics";
  fs::remove_all(out);
  palpate::RunOptions o;
  o.physics_dt = {0.010};
  auto r = palpate::run_scene(press_scene(out), floor_of(300.0), o);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->physics.size(), 1u);
  EXPECT_EQ(r->physics[0].steps, 100u);
  auto j = nlohmann::json::parse(slurp(out / "summary.json"));
  ASSERT_EQ(j["physics"].size(), 1u) << j.dump(2);
  const auto& p = j["physics"][0];
  EXPECT_EQ(p["tissue"], "floor");
  EXPECT_DOUBLE_EQ(p["rate_hz"].get<double>(), 100.0);
  EXPECT_EQ(p["steps"], 100);
  EXPECT_EQ(p["late_steps"], 0);
  EXPECT_EQ(p["patch_ticks"], 0);
  EXPECT_GT(p["step_time_s"]["max"].get<double>(), 0.0);
  EXPECT_GE(p["step_time_s"]["max"].get<double>(), p["step_time_s"]["median"].get<double>());
  fs::remove_all(out);
  auto plain = palpate::run_scene(press_scene(out), floor_of(300.0));
  ASSERT_TRUE(plain.ok()) << plain.error().message;
  EXPECT_TRUE(plain->physics.empty());
  EXPECT_EQ(nlohmann::json::parse(slurp(out / "summary.json"))["physics"].size(), 0u);
  fs::remove_all(out);
}

TEST(Run, ForceClampedToDeviceMaximum) {
  const fs::path out = fs::temp_directory_path() / "palpate_test_run_clamp";
  auto r = palpate::run_scene(press_scene(out), floor_of(1e5));
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_NEAR(r->max_force, 3.3, 1e-9);
  auto j = nlohmann::json::parse(slurp(out / "summary.json"));
  EXPECT_GT(j["safety"]["clamped"].get<int>(), 0);
}

TEST(Run, AtomicWriteReplacesWholeFileAndReportsBadDirectory) {
  const fs::path dir = fs::temp_directory_path() / "palpate_test_atomic";
  fs::create_directories(dir);
  ASSERT_TRUE(palpate::write_file_atomic(dir / "a.txt", "first"));
  ASSERT_TRUE(palpate::write_file_atomic(dir / "a.txt", "second"));
  EXPECT_EQ(slurp(dir / "a.txt"), "second");
  auto s = palpate::write_file_atomic("/proc/palpate_no/x.txt", "x");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("/proc/palpate_no"), std::string::npos) << s.error().message;
}

// --- the needle's direction from scripted waypoints, through run_scene.
namespace {

// Rows of a CSV of numbers (after one header line), split on ',' or ' '; '#' lines skipped.
std::vector<std::vector<double>> numbers_of(const fs::path& p) {
  std::istringstream in(slurp(p));
  std::string line;
  std::getline(in, line);
  std::vector<std::vector<double>> rows;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    for (char& c : line)
      if (c == ',') c = ' ';
    std::istringstream ls(line);
    std::vector<double> r;
    for (std::string cell; ls >> cell;) r.push_back(std::strtod(cell.c_str(), nullptr));
    rows.push_back(r);
  }
  return rows;
}

}  // namespace

TEST(Run, ScriptedDirectionsTiltTheNeedleTheTissueSeesAndThePlotsMeasureAlongIt) {
  const fs::path out = fs::temp_directory_path() / "palpate_test_run_directions";
  fs::remove_all(out);
  palpate::SceneDef scene = press_scene(out);
  scene.tool.kind = "needle";
  scene.tool.length = 0.05;
  const Vec3 down(0, -1, 0), tilted = Vec3(1, -1, 0).normalized();
  scene.device.waypoints = {{0.0, Vec3(0, 0.002, 0), down},
                            {0.5, Vec3(0.004, -0.004, 0), tilted},
                            {1.0, Vec3(0.004, -0.008, 0)}};  // no direction: holds the last
  std::vector<palpate::ToolState> seen;  // what the tissue was handed, tick by tick
  seen.reserve(1000);
  std::vector<std::unique_ptr<palpate::Tissue>> tissues;
  tissues.push_back(std::make_unique<palpate::test::ToolRecorder>(seen, std::make_unique<Floor>(300.0)));
  auto r = palpate::run_scene(scene, std::move(tissues));
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(seen.size(), 1000u);
  for (size_t k = 0; k < 1000; ++k) {
    const palpate::ToolState& tool = seen[k];
    ASSERT_NEAR(tool.axis.norm(), 1.0, 1e-15) << k;
    if (tool.time <= 0.5) {
      // In the plane of the two directions, on the arc between them at the segment's fraction.
      const double frac = tool.time / 0.5, angle = std::atan2(tool.axis.x(), -tool.axis.y());
      ASSERT_NEAR(tool.axis.z(), 0.0, 1e-15) << k;
      ASSERT_NEAR(angle, frac * M_PI / 4, 1e-12) << k;
    } else {
      ASSERT_NEAR((tool.axis - tilted).norm(), 0.0, 1e-15) << k;
    }
  }
  EXPECT_NEAR((seen[499].axis - tilted).norm(), 0.0, 1e-15);  // t = 0.5 s exactly at the waypoint

  // run.csv records the orientation that gives this axis; force.dat measures depth and the axial
  // force along the needle as it pointed at each tick, from the first contact.
  const auto rows = numbers_of(out / "run.csv");
  const auto dat = numbers_of(out / "force.dat");
  ASSERT_EQ(rows.size(), 1000u);
  ASSERT_EQ(dat.size(), 1000u);
  size_t contact = 0;
  while (contact < rows.size() && !(rows[contact][7] > 1e-9)) ++contact;
  ASSERT_LT(contact, 200u);
  const Vec3 tip0(rows[contact][1], rows[contact][2], rows[contact][3]);
  for (size_t k = 0; k < rows.size(); ++k) {
    const auto& row = rows[k];
    const Vec3 axis = seen[k].axis;
    const palpate::Quat q(row[9], row[10], row[11], row[12]);
    ASSERT_NEAR((palpate::needle_axis(down, q.normalized()) - axis).norm(), 0.0, 1e-8) << k;
    const Vec3 tip(row[1], row[2], row[3]), force(row[4], row[5], row[6]);
    ASSERT_NEAR(dat[k][1], (tip - tip0).dot(axis) * 1e3, 2e-6) << k;  // mm, 6 decimals
    ASSERT_NEAR(dat[k][3], -force.dot(axis), 2e-6) << k;
  }
}

// A scene without directions runs exactly as the loop did before the needle followed the device:
// every column of run.csv, bit for bit, against the same run whose tissues are handed the scene's
// fixed axis. The needle is tilted (a non-unit tool.axis) and punctures a charged-particle patch.
TEST(Run, ScenesWithoutDirectionsGiveTheFixedAxisRunBitForBit) {
  const std::string yaml = R"(
name: fixed-axis
duration: 1.0
tool: {kind: needle, radius: 0.0004, length: 0.05, axis: [0.2, -1, 0.1]}
device:
  kind: scripted
  waypoints:
    - {t: 0.0, position: [0, 0.006, 0]}
    - {t: 0.8, position: [0.0012, -0.006, 0.0006]}
    - {t: 1.0, position: [0.0003, 0.0, 0.0001]}
tissues:
  - name: skin
    model: charged_particles
    patch: {width: 0.02, height: 0.02, spacing: 0.001}
    material: {max_displacement: 0.004, puncture_force: 1.0}
)";
  auto scene = palpate::parse_scene(yaml, "fixed-axis.yaml");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  std::string csv[2];
  for (int fixed = 0; fixed < 2; ++fixed) {
    auto tissue = palpate::make_tissue(*scene, 0);
    ASSERT_TRUE(tissue.ok()) << tissue.error().message;
    std::vector<std::unique_ptr<palpate::Tissue>> tissues;
    if (fixed)
      tissues.push_back(std::make_unique<palpate::test::FixedAxis>(std::move(*tissue), scene->tool.axis.normalized()));
    else
      tissues.push_back(std::move(*tissue));
    palpate::RunOptions o;
    o.out = fs::temp_directory_path() / ("palpate_test_run_fixed_axis_" + std::to_string(fixed));
    o.plots = false;
    auto r = palpate::run_scene(*scene, std::move(tissues), o);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_GT(r->max_force, 0.1);  // the needle pressed on the tissue
    csv[fixed] = slurp(o.out / "run.csv");
  }
  ASSERT_GT(csv[0].size(), 10000u);
  EXPECT_TRUE(csv[0] == csv[1]) << "run.csv differs from the fixed-axis run";
}

// RunOptions::interrupt ends a run early at a tick boundary (headless or realtime) with complete
// outputs: run.csv to the last tick run, summary.json with "interrupted": true; no .part left.
TEST(Run, InterruptStopsAtATickWithCompleteOutputs) {
  for (const bool realtime : {false, true}) {
    const fs::path out = fs::temp_directory_path() / "palpate_test_run_interrupt";
    fs::remove_all(out);
    palpate::SceneDef scene = press_scene(out);
    scene.duration = realtime ? 20.0 : 100.0;
    std::atomic<bool> stop{false};
    palpate::RunOptions opt;
    opt.realtime = realtime;
    opt.realtime_priority = false;
    opt.interrupt = &stop;
    opt.progress = [&](double f) {
      if (f >= (realtime ? 0.01 : 0.3)) stop.store(true);
    };
    auto r = palpate::run_scene(scene, floor_of(300.0), opt);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_TRUE(r->interrupted);
    const size_t asked = size_t(std::llround(scene.duration / scene.dt));
    EXPECT_GE(r->ticks, realtime ? 100u : asked * 3 / 10);
    EXPECT_LT(r->ticks, asked);
    std::istringstream csv(slurp(out / "run.csv"));
    std::string line;
    std::getline(csv, line);
    size_t rows = 0;
    while (std::getline(csv, line)) {
      double v[9];
      ASSERT_EQ(std::sscanf(line.c_str(), "%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf", &v[0], &v[1], &v[2], &v[3],
                            &v[4], &v[5], &v[6], &v[7], &v[8]), 9) << line;
      ASSERT_EQ(v[8], double(rows)) << line;
      ++rows;
    }
    EXPECT_EQ(rows, r->ticks);
    auto j = nlohmann::json::parse(slurp(out / "summary.json"));
    EXPECT_EQ(j["interrupted"], true);
    EXPECT_EQ(j["ticks"], r->ticks);
    for (const auto& e : fs::directory_iterator(out)) EXPECT_NE(e.path().extension(), ".part") << e.path();
  }
  // A run not interrupted says so.
  const fs::path out = fs::temp_directory_path() / "palpate_test_run_not_interrupted";
  auto r = palpate::run_scene(press_scene(out), floor_of(300.0));
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_FALSE(r->interrupted);
  EXPECT_EQ(nlohmann::json::parse(slurp(out / "summary.json"))["interrupted"], false);
}

// The OpenHaptics device is driven at the wall clock's 1 kHz only: a headless run (ticks as fast
// as they go) is refused before the device is opened.
TEST(Run, OpenHapticsWithoutRealtimeIsRefused) {
  palpate::SceneDef scene = press_scene(fs::temp_directory_path() / "palpate_test_run_ohd");
  scene.file = "hand.yaml";
  scene.device.kind = "openhaptics";
  scene.device.hd_library = "/nonexistent/libHD.so";
  auto r = palpate::run_scene(scene, floor_of(300.0));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("hand.yaml: device kind 'openhaptics' needs a realtime run"), std::string::npos)
      << r.error().message;
  EXPECT_EQ(r.error().message.find("cannot load the HD library"), std::string::npos);  // never opened
  palpate::RunOptions opt;
  opt.realtime = true;
  r = palpate::run_scene(scene, floor_of(300.0), opt);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("cannot load the HD library"), std::string::npos) << r.error().message;
}

// A run into a directory an earlier run used (one killed while plotting) starts by clearing that
// run's outputs: no old summary.json or plots beside the new run.csv, no *.part left; other files
// in the directory stay.
TEST(Run, StaleOutputsAreClearedWhenARunStarts) {
  const fs::path out = fs::temp_directory_path() / "palpate_test_run_stale";
  fs::remove_all(out);
  fs::create_directories(out);
  for (const char* f : {"summary.json", "force_time.png", "force_depth.png", "force_time.png.part",
                        "run.csv.part", "frame_000.png", "frame_0042.png", "summary.json.tmp-1-2",
                        "us_000.png", "us_012.png", "us_003.png.tmp-7-1", "notes.txt", "frame_x.png",
                        "us_x.png", "mine.part"})
    std::ofstream(out / f) << "old";
  palpate::RunOptions opt;
  opt.plots = false;  // the new run writes no plots: the old ones must not pass for its own
  auto r = palpate::run_scene(press_scene(out), floor_of(300.0), opt);
  ASSERT_TRUE(r.ok()) << r.error().message;
  for (const char* gone : {"force_time.png", "force_depth.png", "force_time.png.part", "run.csv.part",
                           "frame_000.png", "frame_0042.png", "summary.json.tmp-1-2", "us_000.png", "us_012.png",
                           "us_003.png.tmp-7-1"})  // an earlier run's ultrasound images too
    EXPECT_FALSE(fs::exists(out / gone)) << gone;
  for (const char* kept : {"notes.txt", "frame_x.png", "us_x.png", "mine.part"}) EXPECT_EQ(slurp(out / kept), "old") << kept;
  EXPECT_NE(slurp(out / "summary.json"), "old");
  EXPECT_TRUE(fs::exists(out / "run.csv"));
}

// A camera larger than frames can be drawn is refused before the run, naming the scene's key (it
// was refused only after the whole run, naming frame_000.png).
TEST(Run, FramesCameraTooLargeIsRefusedBeforeTheRun) {
  const fs::path out = fs::temp_directory_path() / "palpate_test_run_big_camera";
  fs::remove_all(out);
  palpate::SceneDef scene = press_scene(out);
  scene.file = "big.yaml";
  scene.camera = palpate::CameraDef{};
  scene.camera->height = 8000;
  palpate::RunOptions opt;
  opt.frames = 2;
  auto r = palpate::run_scene(scene, floor_of(300.0), opt);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message,
            "big.yaml: camera.height: 8000 pixels is more than frames can be drawn off-screen (at most 4096); "
            "lower it to run with --frames");
  EXPECT_FALSE(fs::exists(out / "run.csv"));
  EXPECT_FALSE(fs::exists(out / "run.csv.part"));
}

// A run that cannot fit is refused before its first tick, naming duration and the numbers. Its
// memory is bounded (the plots' series are streamed through a file): the disk is what runs out.
TEST(Run, ARunTooLargeForTheDiskIsRefusedAtTheStart) {
  const fs::path out = fs::temp_directory_path() / "palpate_test_run_huge";
  fs::remove_all(out);
  palpate::SceneDef scene = press_scene(out);
  scene.file = "huge.yaml";
  scene.duration = 1e7;
  scene.dt = 1e-5;  // 1e12 ticks: ~96 TB of series, more than any machine
  auto r = palpate::run_scene(scene, floor_of(300.0));
  ASSERT_FALSE(r.ok());
  const std::string& m = r.error().message;
  EXPECT_EQ(m.rfind("huge.yaml: duration: duration 10000000 s at dt 1e-05 s is 1000000000000 ticks", 0), 0u) << m;
  EXPECT_FALSE(fs::exists(out / "run.csv.part"));
  EXPECT_NE(m.find("run.csv would be about 9.6e+04 GB and the plots' series beside it 9.6e+04 GB, more than the "),
            std::string::npos) << m;
  // The issue's 3.6e8-tick run: 34.6 GB of series on disk, 6.4 MB of plotted rows in memory.
  const palpate::RunFootprint fp = palpate::run_footprint(360000000, 16);
  EXPECT_NEAR(fp.series_bytes, 3.456e10, 1e6);
  EXPECT_NEAR(fp.memory_bytes, 6.4e6, 1.0);
}
