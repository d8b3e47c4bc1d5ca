// test_run.cpp — run_scene: fixed ticks, the force path through safety, outputs written atomically.
#include <palpate/run.h>
#include <palpate/tissue.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

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
            "tool_qz,buttons,events,floor.force_N");
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
