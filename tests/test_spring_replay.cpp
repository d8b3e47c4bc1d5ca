// test_spring_replay.cpp — recording and replaying a cut (issue 37 item 6; cut.cpp's install schedule,
// tissue.cpp's cut_installed figure, load_recording_counts, the replay run): a run whose corrections
// took effect at other ticks than the replay's own latency (a real-time run; a fixed latency of 9) is
// replayed through its recorded schedule with the same wound and the same forces, tick for tick, bit
// for bit; without the schedule the same replay differs; a schedule the replay cannot follow is
// counted and never hangs; a malformed recording is refused naming the file and line.
#include <palpate/device.h>
#include <palpate/scene.h>
#include <palpate/spring.h>
#include <palpate/tissue.h>
#include <palpate/tissue_files.h>

#include "components.h"
#include "run_csv_rows.h"
#include "shell_run.h"
#include "spring_fixtures.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>
#include <unistd.h>

namespace {

using namespace palpate;
using namespace spring_test;
namespace fs = std::filesystem;

// ---- the cutter: removals scripted, installs at a latency of 9, replayed at the default 2 ----

// A 6 x 5 x 4 block, 2 mm spacing, held at its base, with the volume term; stirred, so every step
// moves (a fixed seed).
SpringModel stirred_block(SpringState& s) {
  SpringModelOptions o;
  o.solver = SpringSolver::sparse;
  o.gravity = true;
  SpringModel model = must_build(tissue_network(spring::make_block(6, 5, 4, 0.002), 0.4, 1000, 0.02, Held::bottom), o);
  s = make_state(model);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  for (Eigen::Index i = 0; i < s.x.rows(); ++i) {
    if (model.anchored[static_cast<size_t>(i)]) continue;
    for (int c = 0; c < 3; ++c) {
      s.x(i, c) += 2e-4 * u(rng);
      s.v(i, c) = 0.05 * u(rng);
    }
  }
  return model;
}

struct CutterRun {
  std::vector<std::int32_t> installed;  // status().installed after each install()
  std::vector<RowMat3d> x;              // positions after each step
  int factors = 0, mismatches = 0;
};

// 60 ticks; at ticks 3, 4, 20 and 35 springs crossing planes of the block are removed (with their
// tetrahedra). refactor_rank 30: the second cut brings a new factor, the others corrections.
CutterRun cut_block(int latency, const std::vector<std::int32_t>* schedule) {
  SpringState s;
  SpringModel model = stirred_block(s);
  SpringCutOptions co;
  co.fixed_latency = latency;
  co.refactor_rank = 30;
  auto cutter = SpringCutter::create(model, co);
  EXPECT_TRUE(cutter.ok()) << cutter.error().message;
  if (schedule) {
    EXPECT_TRUE((*cutter)->set_install_schedule(*schedule).ok());
  }
  auto crossing = [&](double at, size_t most) {
    std::vector<int> out;
    const SpringNetwork& net = model.network;
    for (size_t e = 0; e < net.springs.size() && out.size() < most; ++e) {
      const double a = net.rest(net.springs[e][0], 0) - at, b = net.rest(net.springs[e][1], 0) - at;
      if (a * b < 0) out.push_back(static_cast<int>(e));
    }
    return out;
  };
  CutterRun run;
  for (int k = 0; k < 60; ++k) {
    (*cutter)->install();
    run.installed.push_back((*cutter)->status().installed);
    if (k == 3) (*cutter)->remove_springs(crossing(0.003, 3));
    if (k == 4) (*cutter)->remove_springs(crossing(0.005, 100));
    if (k == 20) (*cutter)->remove_springs(crossing(0.007, 2));
    if (k == 35) (*cutter)->remove_springs(crossing(0.009, 4));
    EXPECT_TRUE(step(model, s, nullptr));
    run.x.push_back(s.x);
  }
  run.factors = (*cutter)->status().factors;
  run.mismatches = (*cutter)->status().replay_mismatches;
  return run;
}

TEST(SpringCutReplay, AScheduleInstallsEachCorrectionAndFactorAtTheRecordedTickBitForBit) {
  const CutterRun late = cut_block(9, nullptr);  // a run whose corrections came late
  ASSERT_GE(late.factors, 1);
  ASSERT_GT(late.installed.back(), 0);
  // Its first correction took effect 9 calls after the cut (tick 3 + 9), not 2.
  EXPECT_EQ(late.installed[11], 0);
  EXPECT_GT(late.installed[12], 0);

  const CutterRun replay = cut_block(2, &late.installed);
  EXPECT_EQ(replay.installed, late.installed);
  EXPECT_EQ(replay.factors, late.factors);
  EXPECT_EQ(replay.mismatches, 0);
  for (size_t k = 0; k < late.x.size(); ++k) ASSERT_TRUE(replay.x[k] == late.x[k]) << "tick " << k;

  // The same replay without the schedule installs 7 ticks sooner, and the steps differ: the schedule
  // is what makes the replay repeat the run.
  const CutterRun plain = cut_block(2, nullptr);
  EXPECT_NE(plain.installed, late.installed);
  double most = 0;
  for (size_t k = 0; k < late.x.size(); ++k) most = std::max(most, (plain.x[k] - late.x[k]).cwiseAbs().maxCoeff());
  EXPECT_GT(most, 1e-12);
}

TEST(SpringCutReplay, AScheduleAskingForRemovalsNeverLoggedIsCountedAndDoesNotWait) {
  SpringState s;
  SpringModel model = stirred_block(s);
  SpringCutOptions co;
  co.fixed_latency = 2;
  auto cutter = SpringCutter::create(model, co);
  ASSERT_TRUE(cutter.ok());
  // Removals the run will never log: 1000 from the second call on.
  const std::vector<std::int32_t> schedule = {0, 1000, 1000, 1000, 1000};
  ASSERT_TRUE((*cutter)->set_install_schedule(schedule).ok());
  (*cutter)->install();
  (*cutter)->remove_springs(std::vector<int>{0, 1, 2});
  const int logged = (*cutter)->status().removed_springs + (*cutter)->status().removed_tets;
  ASSERT_GT(logged, 0);
  for (int k = 0; k < 4; ++k) (*cutter)->install();  // (a wait for 1000 would hang here)
  EXPECT_EQ((*cutter)->status().installed, logged);  // what was logged is installed
  EXPECT_EQ((*cutter)->status().replay_mismatches, 4);
  // Past the schedule's end the fixed latency goes on.
  (*cutter)->remove_springs(std::vector<int>{40});
  for (int k = 0; k < 3; ++k) (*cutter)->install();
  EXPECT_EQ((*cutter)->status().pending, 0);
  EXPECT_EQ((*cutter)->status().replay_mismatches, 4);
}

TEST(SpringCutReplay, AScheduleThatFallsOrIsNegativeIsRefused) {
  SpringState s;
  SpringModel model = stirred_block(s);
  auto cutter = SpringCutter::create(model, {});
  ASSERT_TRUE(cutter.ok());
  const auto falls = (*cutter)->set_install_schedule(std::vector<std::int32_t>{0, 3, 2});
  ASSERT_FALSE(falls.ok());
  EXPECT_NE(falls.error().message.find("value 2 (2) is below the one before (3)"), std::string::npos) << falls.error().message;
  const auto negative = (*cutter)->set_install_schedule(std::vector<std::int32_t>{0, -1});
  ASSERT_FALSE(negative.ok());
  EXPECT_NE(negative.error().message.find("value 1 is -1"), std::string::npos) << negative.error().message;
}

// ---- the scene tissue: a blade through a ball, recorded in real time, replayed headless ----

const char* kBall = R"(
dt: 0.001
duration: 1.0
tool: {kind: blade, radius: 0.0005, length: 0.01, axis: [0, -1, 0]}
tissues:
  - name: ball
    model: mass_spring
    patch: {shape: sphere, radius: 0.01, spacing: 0.0015, center: [0, 0, 0]}
    material:
      topology: tet_edges
      solver: sparse
      youngs_modulus: 150000
      poisson_ratio: 0.4
      density: 1000
      spring_damping: 0.02
      contact_stiffness: 5000
      cutting_force: 1.0
      cutting_drag_per_length: 170
)";

std::unique_ptr<Tissue> ball() {
  auto scene = parse_scene(kBall, "ball.yaml", ".");
  EXPECT_TRUE(scene.ok()) << scene.error().message;
  auto t = make_tissue(*scene, 0);
  EXPECT_TRUE(t.ok()) << t.error().message;
  return std::move(*t);
}

struct BladeRun {
  std::vector<Vec3> force;
  std::vector<std::int32_t> installed;
  std::vector<double> cut_springs, cut_tets, factors, mismatches;
  std::vector<std::array<int, 2>> links;  // the springs left at the end
  std::vector<std::string> events;
};

// Down onto the ball at 20 mm/s, drawn 8 mm along +x, lifted out (test_spring_blade.cpp's hand).
BladeRun drive(Tissue& tissue) {
  const auto names = tissue.figure_names();
  const auto col = [&](const char* n) {
    const auto it = std::find(names.begin(), names.end(), n);
    EXPECT_NE(it, names.end()) << n;
    return static_cast<size_t>(it - names.begin());
  };
  std::vector<double> fig(names.size());
  BladeRun run;
  ToolState tool;
  tool.blade = true;
  tool.length = 0.01;
  tool.radius = 0.0005;
  tool.axis = Vec3(0, -1, 0);
  const double dt = 0.001, v = 0.02;
  Vec3 at(0.0004, 0.0115, 0.0002);
  std::array<TissueEvent, 16> ev;
  for (int k = 0; k < 1100; ++k) {
    const double t = k * dt;
    const Vec3 vel = t < 0.45 ? Vec3(0, -v, 0) : t < 0.85 ? Vec3(v, 0, 0) : Vec3(0, v, 0);
    at += vel * dt;
    tool.time = t;
    tool.tip = at;
    tool.velocity = vel;
    run.force.push_back(tissue.step(tool, dt));
    tissue.figures(fig);
    run.installed.push_back(static_cast<std::int32_t>(fig[col("cut_installed")]));
    run.cut_springs.push_back(fig[col("cut_springs")]);
    run.cut_tets.push_back(fig[col("cut_tets")]);
    run.factors.push_back(fig[col("cut_factors")]);
    run.mismatches.push_back(fig[col("cut_replay_mismatches")]);
    for (size_t n = tissue.drain_events(ev), i = 0; i < n; ++i)
      if (std::strcmp(ev[i].kind, "cut") != 0) run.events.push_back(ev[i].kind);
  }
  TissueSnapshot snap;
  tissue.snapshot(snap);
  run.links = snap.links;
  return run;
}

TEST(SpringBladeReplay, AReplayOfARealTimeRunRepeatsItsWoundAndForcesTickForTick) {
  // The recorded run: real time, installs as the worker has them ready (ticks here run as fast as
  // they step, so a correction lands some ticks after its cut, however many the worker takes).
  auto live = ball();
  live->set_real_time(true);
  const BladeRun rec = drive(*live);
  ASSERT_GT(rec.cut_springs.back(), 0) << "the blade never cut";
  ASSERT_GT(rec.installed.back(), 0);
  for (size_t k = 1; k < rec.installed.size(); ++k) ASSERT_GE(rec.installed[k], rec.installed[k - 1]);

  auto again = ball();
  ASSERT_TRUE(again->set_install_schedule(rec.installed).ok());
  const BladeRun rep = drive(*again);
  EXPECT_EQ(rep.installed, rec.installed);
  EXPECT_EQ(rep.mismatches.back(), 0);
  EXPECT_EQ(rep.factors.back(), rec.factors.back());
  for (size_t k = 0; k < rec.force.size(); ++k) {
    ASSERT_EQ(rep.force[k], rec.force[k]) << "tick " << k;  // bit for bit
    ASSERT_EQ(rep.cut_springs[k], rec.cut_springs[k]) << "tick " << k;
    ASSERT_EQ(rep.cut_tets[k], rec.cut_tets[k]) << "tick " << k;
  }
  EXPECT_EQ(rep.links, rec.links);  // the same springs left: the same wound
  EXPECT_TRUE(rep.events.empty());

  // Without the schedule the replay installs at its own latency (2 ticks). Where that is not when
  // the real-time run's corrections came, the forces differ: the schedule is what repeats the run.
  auto plain = ball();
  const BladeRun own = drive(*plain);
  size_t other = 0;
  for (size_t k = 0; k < rec.installed.size(); ++k) other += own.installed[k] != rec.installed[k];
  std::printf("the real-time run installed otherwise than a latency of 2 at %zu of %zu ticks (%d removals, %g factors)\n",
              other, rec.installed.size(), rec.installed.back(), rec.factors.back());
  if (own.installed != rec.installed) {
    double most = 0;
    for (size_t k = 0; k < rec.force.size(); ++k) most = std::max(most, (own.force[k] - rec.force[k]).norm());
    EXPECT_GT(most, 0.0);
  } else {
    std::printf("(the real-time run's corrections all came 2 ticks after their cuts, as the replay's own)\n");
  }
}

TEST(SpringBladeReplay, AScheduleTheReplayCannotFollowIsAnEventOnceAndAFigure) {
  auto tissue = ball();
  // Asks for 5 removals from tick 10 on, long before the blade reaches the ball (about tick 75).
  std::vector<std::int32_t> schedule(200, 0);
  std::fill(schedule.begin() + 10, schedule.end(), 5);
  ASSERT_TRUE(tissue->set_install_schedule(schedule).ok());
  const BladeRun run = drive(*tissue);
  EXPECT_GE(run.mismatches[20], 11);  // ticks 10..20
  EXPECT_EQ(std::count(run.events.begin(), run.events.end(), std::string("cut_replay_mismatch")), 1);
  EXPECT_GT(run.cut_springs.back(), 0);  // the run went on, and cut
}

// ---- the recording's column: load_recording_counts ----

fs::path temp_file(const std::string& name, const std::string& text) {
  const fs::path p = fs::temp_directory_path() / ("palpate_test_replay_" + std::to_string(::getpid()) + "_" + name);
  std::ofstream(p) << text;
  return p;
}

TEST(RecordingCountsReplay, TheColumnIsReadByTickAndAMalformedOneIsRefusedNamingTheLine) {
  const std::string head = "t,tool_x,tool_y,tool_z,tick,b.cut_installed\n";
  {
    // Ticks 2 and 3 dropped (a real-time recorder's full ring): held at the value before.
    const auto p = temp_file("ok.csv", head + "0.001,0,0,0,0,0\n0.002,0,0,0,1,2\n0.005,0,0,0,4,7\n");
    auto c = load_recording_counts(p, "b.cut_installed");
    ASSERT_TRUE(c.ok()) << c.error().message;
    EXPECT_EQ(*c, (std::vector<std::int32_t>{0, 2, 2, 2, 7}));
    auto none = load_recording_counts(p, "other.cut_installed");
    ASSERT_TRUE(none.ok());
    EXPECT_TRUE(none->empty());
  }
  const struct {
    const char* name;
    std::string rows;
    const char* says;
  } bad[] = {
      {"falls.csv", "0.001,0,0,0,0,3\n0.002,0,0,0,1,2\n", ":3: column 'b.cut_installed': 2 is below the row before (3): what took effect is never taken back"},
      {"fraction.csv", "0.001,0,0,0,0,1.5\n", ":2: column 'b.cut_installed': expected a whole number >= 0, got '1.5'"},
      {"negative.csv", "0.001,0,0,0,0,-1\n", ":2: column 'b.cut_installed': expected a whole number >= 0, got '-1'"},
      {"word.csv", "0.001,0,0,0,0,x\n", ":2: column 'b.cut_installed': expected a whole number >= 0, got 'x'"},
      {"short.csv", "0.001,0,0,0,0\n", ":2: row has 5 fields, column 'b.cut_installed' is number 6"},
      {"ticks.csv", "0.001,0,0,0,1,0\n0.002,0,0,0,1,0\n", ":3: column 'tick': 1 does not follow tick 1 (a recording's ticks rise)"},
  };
  for (const auto& b : bad) {
    const auto p = temp_file(b.name, head + b.rows);
    auto c = load_recording_counts(p, "b.cut_installed");
    ASSERT_FALSE(c.ok()) << b.name;
    EXPECT_EQ(c.error().message, p.string() + b.says) << b.name;
  }
}

// ---- the run: `palpate run --replay` installs by the recording's column ----

const std::string kBlock = PALPATE_TEST_DATA_DIR "/scenes/blade-block.yaml";

fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("palpate_test_replay_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

size_t column_of(const fs::path& csv, const std::string& name) {
  std::ifstream in(csv);
  std::string header;
  std::getline(in, header);
  const auto cells = palpate::test::csv_cells_of(header);
  const auto it = std::find(cells.begin(), cells.end(), name);
  EXPECT_NE(it, cells.end()) << name << " in " << csv;
  return static_cast<size_t>(it - cells.begin());
}

// Every row's cells of a run.csv, as printed.
std::vector<std::vector<std::string>> cells_of(const fs::path& csv) {
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  std::vector<std::vector<std::string>> rows;
  while (std::getline(in, line)) rows.push_back(palpate::test::csv_cells_of(line));
  return rows;
}

TEST(RunReplay, AReplayedRunInstallsItsCutsAtTheRecordedTicksAndRepeatsItsForces) {
  PALPATE_NEEDS_CLI();
  const fs::path dir = fresh_dir("run");
  const std::string cache = " --cache " + (dir / "cache").string();
  auto cli = [&](const std::string& args) {
    const palpate::test::Ran r = palpate::test::run_cli("run " + kBlock + " -q --no-report" + cache + " " + args);
    EXPECT_EQ(r.code, 0) << args << "\n" << r.out;
  };
  // The scene's own headless run (corrections 2 ticks after their cuts).
  cli("-o " + (dir / "a").string());
  const fs::path a = dir / "a" / "run.csv";
  const size_t inst = column_of(a, "block.cut_installed");
  // A recording of the same hand whose corrections came 7 ticks later (as a loaded real-time run's
  // may): its column delayed by 7 rows. The replay plays its poses and installs by its column.
  std::vector<std::vector<std::string>> rows = cells_of(a);
  ASSERT_GT(rows.size(), 1000u);
  ASSERT_NE(rows.back()[inst], "0") << "the blade never cut";
  std::vector<std::string> delayed(rows.size(), "0");
  for (size_t k = 7; k < rows.size(); ++k) delayed[k] = rows[k - 7][inst];
  {
    std::ifstream in(a);
    std::string header;
    std::getline(in, header);
    std::ofstream out(dir / "late.csv");
    out << header << "\n";
    for (size_t k = 0; k < rows.size(); ++k) {
      rows[k][inst] = delayed[k];
      for (size_t c = 0; c < rows[k].size(); ++c) out << (c ? "," : "") << rows[k][c];
      out << "\n";
    }
  }
  cli("--replay " + (dir / "late.csv").string() + " -o " + (dir / "b").string());
  const fs::path b = dir / "b" / "run.csv";
  const auto rb = cells_of(b);
  ASSERT_EQ(rb.size(), rows.size());
  const size_t mism = column_of(b, "block.cut_replay_mismatches");
  for (size_t k = 0; k < rb.size(); ++k) {
    ASSERT_EQ(rb[k][inst], delayed[k]) << "tick " << k;  // installed when the recording says
    ASSERT_EQ(rb[k][mism], "0") << "tick " << k;
  }
  // Replaying the replay repeats it: every force and cut column, as printed, tick for tick.
  cli("--replay " + b.string() + " -o " + (dir / "c").string());
  const auto rc = cells_of(dir / "c" / "run.csv");
  ASSERT_EQ(rc.size(), rb.size());
  const std::vector<std::string> same = {"force_x",          "force_y",          "force_z",
                                         "force_N",          "block.force_x_N",  "block.force_y_N",
                                         "block.force_z_N",  "block.max_displacement_m",
                                         "block.kinetic_energy_J", "block.anchor_force_N",
                                         "block.cut_springs", "block.cut_tets",  "block.cut_factors",
                                         "block.cut_installed"};
  for (const std::string& name : same) {
    const size_t c = column_of(b, name);
    for (size_t k = 0; k < rb.size(); ++k) ASSERT_EQ(rc[k][c], rb[k][c]) << name << ", tick " << k;
  }
  // The same poses replayed without the late column (the scene's own recording) install sooner, and
  // the organ moves otherwise: the column is what repeats the run. (Here the hand feels the same:
  // this blade's felt force while it cuts is the parting and the drag, of the edge's geometry; the
  // organ's own figures differ, by up to 5 µm of displacement and 7 mN at its anchors, measured.)
  cli("--replay " + a.string() + " -o " + (dir / "d").string());
  const auto rd = cells_of(dir / "d" / "run.csv");
  ASSERT_EQ(rd.size(), rb.size());
  size_t differ = 0;
  for (const char* name : {"block.max_displacement_m", "block.kinetic_energy_J", "block.anchor_force_N"}) {
    const size_t c = column_of(b, name);
    for (size_t k = 0; k < rb.size(); ++k) differ += rd[k][c] != rb[k][c];
  }
  EXPECT_GT(differ, 0u);
  fs::remove_all(dir);
}

TEST(RunReplay, AMalformedInstallColumnIsRefusedNamingTheFileAndLine) {
  PALPATE_NEEDS_CLI();
  const fs::path dir = fresh_dir("bad");
  const fs::path rec = dir / "bad.csv";
  std::ofstream(rec) << "t,tool_x,tool_y,tool_z,tick,block.cut_installed\n0.001,-0.005,0.004,0,0,4\n0.002,-0.005,0.004,0,1,3\n";
  const palpate::test::Ran r = palpate::test::run_cli("run " + kBlock + " -q --no-report --cache " + (dir / "cache").string() +
                                                      " --replay " + rec.string() + " -o " + (dir / "o").string());
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find(rec.string() + ":3: column 'block.cut_installed': 3 is below the row before (4)"), std::string::npos)
      << r.out;
  fs::remove_all(dir);
}

}  // namespace
