// test_needle_feel.cpp — what a hand feels from a needle through stacked charged-particle layers,
// on the shipped needle scene and variants of it: no grit before a puncture at any speed, the same
// force–depth curve at any tick and any particle spacing, punctures at their set forces, withdrawal
// that is friction and no catch, no rate limiting in a normal run while a fault still trips it.
#include <palpate/anatomy.h>
#include <palpate/run.h>
#include <palpate/scene.h>
#include <palpate/tissue.h>
#include <palpate/tissue_files.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <span>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

using namespace palpate;

namespace {

SceneDef shipped() {
  auto s = load_scene(PALPATE_SOURCE_DIR "/data/scenes/default.yaml");
  EXPECT_TRUE(s.ok()) << s.error().message;
  return *s;
}

// The scene's tissues, built and linked as a run links them.
struct Stack {
  std::vector<std::unique_ptr<Tissue>> tissues;
  std::vector<size_t> inside_col;  // index of "shaft_in_layer_m" in each tissue's figures
  explicit Stack(const SceneDef& scene) {
    std::vector<Tissue*> raw;
    for (int i = 0; i < int(scene.tissues.size()); ++i) {
      auto t = make_tissue(scene, i);
      EXPECT_TRUE(t.ok()) << t.error().message;
      tissues.push_back(std::move(*t));
      raw.push_back(tissues.back().get());
      const auto names = raw.back()->figure_names();
      inside_col.push_back(size_t(std::find(names.begin(), names.end(), "shaft_in_layer_m") - names.begin()));
    }
    link_layers(raw);
  }
};

struct Tick {
  double t = 0, depth = 0;   // s; m, tip travel along the axis from the start
  double axial = 0;          // N, −F·axis: the force resisting the needle (> 0 pushing back)
  double norm = 0;           // N
  double friction_bound = 0; // N, Σ friction_per_length × shaft inside, over the layers
};

struct Insertion {
  std::vector<Tick> ticks;
  std::vector<TissueEvent> events;
};

// The scene's needle moved along its axis from `start` at constant `speed` (m/s) for `travel`
// metres, then (if `back`) back out at the same speed: every tissue stepped each tick of `dt`.
Insertion insert(const SceneDef& scene, double speed, double dt, const Vec3& start, double travel, bool back) {
  Stack stack(scene);
  ToolState tool;
  tool.needle = true, tool.radius = scene.tool.radius, tool.length = scene.tool.length;
  tool.axis = scene.tool.axis.normalized();
  Insertion run;
  const int in_ticks = int(std::lround(travel / speed / dt)), out_ticks = back ? in_ticks : 0;
  for (int k = 1; k <= in_ticks + out_ticks; ++k) {
    const double s = k <= in_ticks ? speed * dt * k : speed * dt * (2 * in_ticks - k);
    tool.time = k * dt;
    tool.tip = start + s * tool.axis;
    tool.velocity = (k <= in_ticks ? speed : -speed) * tool.axis;
    Vec3 f = Vec3::Zero();
    Tick tick;
    tick.t = tool.time, tick.depth = s;
    for (size_t i = 0; i < stack.tissues.size(); ++i) {
      Tissue& t = *stack.tissues[i];
      f += t.step(tool, dt);
      std::vector<double> fig(t.figure_names().size());
      t.figures(fig);
      tick.friction_bound += scene.tissues[i].charged.friction_per_length * fig[stack.inside_col[i]];
      TissueEvent ev[8];
      for (size_t n = t.drain_events(ev), j = 0; j < n; ++j) run.events.push_back(ev[j]);
    }
    tick.axial = -f.dot(tool.axis), tick.norm = f.norm();
    run.ticks.push_back(tick);
  }
  return run;
}

std::vector<TissueEvent> punctures(const Insertion& r) {
  std::vector<TissueEvent> p;
  for (const auto& e : r.events)
    if (std::strcmp(e.kind, "puncture") == 0) p.push_back(e);
  return p;
}

const Vec3 kStart(0.00013, 0.004, 0.00021);  // 4 mm above the skin, off the lattice points
constexpr double kTravel = 0.02;             // down to 8 mm past the vessel wall

// The windows in which the force may not fall: from first contact to the first puncture, and
// from the end of each puncture's pop (the give and the snap, 2 × puncture_time) to the next.
std::vector<std::pair<double, double>> windows(const SceneDef& scene, const Insertion& r) {
  std::vector<std::pair<double, double>> w;
  double from = -1;
  for (const Tick& t : r.ticks)
    if (t.norm > 0) { from = t.t; break; }
  for (const TissueEvent& p : punctures(r)) {
    w.push_back({from, p.time});
    from = p.time + 2 * scene.tissues[size_t(p.tissue)].charged.puncture_time + 1e-9;
  }
  return w;
}

// Within every window the force along the needle never falls by more than 1 % from one tick to the
// next; returns how many tick pairs were checked.
int expect_no_grit(const SceneDef& scene, const Insertion& r, double speed) {
  int checked = 0;
  for (auto [from, to] : windows(scene, r))
    for (size_t k = 1; k < r.ticks.size(); ++k) {
      if (r.ticks[k - 1].t < from || r.ticks[k].t > to) continue;
      ++checked;
      EXPECT_GE(r.ticks[k].axial, r.ticks[k - 1].axial * (1 - 0.01))
          << "speed " << speed << " m/s, t " << r.ticks[k].t << " s: the force fell by more than 1 %";
      if (r.ticks[k].axial < r.ticks[k - 1].axial * (1 - 0.01)) return checked;  // one report is enough
    }
  return checked;
}

// Pulling out (the second half of an insertion made with `back`): the tissue holds the needle back
// by at most the friction of the shaft still inside, plus at most 10 % of a layer's puncture force
// for a catch, and nothing once out of the skin. Returns the largest force of the withdrawal.
double expect_withdrawal_is_friction(const SceneDef& scene, const Insertion& r, double speed) {
  double smallest_puncture = 1e9, largest = 0;
  for (const auto& t : scene.tissues) smallest_puncture = std::min(smallest_puncture, t.charged.puncture_force);
  for (size_t k = r.ticks.size() / 2 + 1; k < r.ticks.size(); ++k) {
    const Tick& t = r.ticks[k];
    EXPECT_LE(t.norm, t.friction_bound * (1 + 1e-9) + 0.1 * smallest_puncture) << "speed " << speed << ", t " << t.t;
    if (t.norm > t.friction_bound * (1 + 1e-9) + 0.1 * smallest_puncture) break;  // one report is enough
    largest = std::max(largest, t.norm);
  }
  EXPECT_EQ(r.ticks.back().norm, 0.0) << "out of the skin, nothing holds the needle";
  return largest;
}

// The axial force on the depth grid `grid` (linear interpolation of the ticks' samples), up to
// the first puncture.
std::vector<double> curve(const Insertion& r, const std::vector<double>& grid) {
  std::vector<double> out;
  const double end = punctures(r).front().time;
  size_t k = 1;
  for (double d : grid) {
    while (k < r.ticks.size() && r.ticks[k].depth < d) ++k;
    if (k >= r.ticks.size() || r.ticks[k].t > end) break;
    const Tick &a = r.ticks[k - 1], &b = r.ticks[k];
    out.push_back(a.axial + (b.axial - a.axial) * (d - a.depth) / (b.depth - a.depth));
  }
  return out;
}

}  // namespace

TEST(NeedleFeel, NoGritFromFirstContactToEachPunctureAtEverySpeed) {
  const SceneDef scene = shipped();
  for (double speed : {0.001, 0.01, 0.02}) {
    const Insertion r = insert(scene, speed, scene.dt, kStart, kTravel, false);
    ASSERT_EQ(punctures(r).size(), 3u) << speed;
    const int checked = expect_no_grit(scene, r, speed);
    EXPECT_GT(checked, int(0.5 * r.ticks.size() * 0.012 / kTravel)) << "the windows must cover the approach";
  }
}

TEST(NeedleFeel, ForceDepthCurveIsTheSameAtEveryTickAndParticleSpacing) {
  const SceneDef base = shipped();
  std::vector<double> grid;
  for (double d = 0; d < kTravel; d += 2e-5) grid.push_back(d);
  auto check = [&](const SceneDef& scene, const std::vector<double>& ref, double tol, const std::string& what) {
    const Insertion r = insert(scene, 0.01, scene.dt, kStart, kTravel, false);
    const auto p = punctures(r);
    ASSERT_EQ(p.size(), 3u) << what;
    for (const TissueEvent& e : p) {
      const ChargedMaterialDef& mat = scene.tissues[size_t(e.tissue)].charged;
      EXPECT_NEAR(e.force, mat.puncture_force, 0.05 * mat.puncture_force) << what << ", layer " << e.tissue;
    }
    for (const Tick& t : r.ticks) ASSERT_LE(t.norm, scene.device.max_force) << what << ", t " << t.t;
    const std::vector<double> c = curve(r, grid);
    ASSERT_GT(c.size(), 100u) << what;
    size_t n = std::min(c.size(), ref.size());
    EXPECT_GT(n, 0.9 * std::max(c.size(), ref.size())) << what << ": the punctures moved";
    for (size_t k = 0; k < n; ++k)
      ASSERT_NEAR(c[k], ref[k], tol * std::abs(ref[k]) + 1e-6) << what << ", depth " << grid[k];
  };
  SceneDef fine = base;
  fine.dt = 0.0005;
  const std::vector<double> ref_dt = curve(insert(fine, 0.01, fine.dt, kStart, kTravel, false), grid);
  for (double dt : {0.0005, 0.001, 0.002}) {
    SceneDef s = base;
    s.dt = dt;
    check(s, ref_dt, 0.02, "dt " + std::to_string(dt));
  }
  SceneDef coarse = base;  // spacing 0.5 mm as the reference
  for (auto& t : coarse.tissues) t.patch->spacing = 0.0005;
  const std::vector<double> ref_spacing = curve(insert(coarse, 0.01, coarse.dt, kStart, kTravel, false), grid);
  for (double spacing : {0.0005, 0.001, 0.002}) {
    SceneDef s = base;
    for (auto& t : s.tissues) t.patch->spacing = spacing;
    check(s, ref_spacing, 0.10, "spacing " + std::to_string(spacing));
  }
}

TEST(NeedleFeel, WithdrawalIsFrictionOfTheShaftInsideAndNoCatch) {
  const SceneDef scene = shipped();
  for (double speed : {0.001, 0.01, 0.02}) {
    const Insertion r = insert(scene, speed, scene.dt, kStart, kTravel, true);
    ASSERT_EQ(punctures(r).size(), 3u);
    EXPECT_GT(expect_withdrawal_is_friction(scene, r, speed), 0.1) << "the withdrawal must be felt";
  }
}

TEST(NeedleFeel, TheShippedRunIsNeverRateLimitedWhileAFaultStillIs) {
  const std::filesystem::path out = std::filesystem::temp_directory_path() / "palpate_needle_feel";
  RunOptions o;
  o.out = out;
  o.plots = false;
  const SceneDef scene = shipped();
  auto r = run_scene(scene, o);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->safety.rate_limited, 0u);
  EXPECT_EQ(r->safety.clamped, 0u);
  auto count = [&](const char* kind) {
    return std::count_if(r->events.begin(), r->events.end(), [&](const RunEvent& e) { return e.kind == kind; });
  };
  EXPECT_EQ(count("puncture"), 3);  // three punctures in, three exits out
  EXPECT_EQ(count("exit"), 3);
  // A fault: the device jumps 3 mm into the skin within one tick. The tissue's force jumps; the
  // safety filter limits its rate.
  SceneDef jump = scene;
  jump.device.waypoints = {{0.0, Vec3(0, 0.002, 0)}, {0.5, Vec3(0, 0.002, 0)}, {0.501, Vec3(0, -0.0035, 0)},
                           {1.0, Vec3(0, -0.0035, 0)}};
  jump.duration = 1.0;
  auto f = run_scene(jump, o);
  ASSERT_TRUE(f.ok()) << f.error().message;
  EXPECT_GT(f->safety.rate_limited, 0u);
  std::filesystem::remove_all(out);
}

// Issue 35: where the shipped needle turns from advance to withdrawal (default.yaml's waypoint at
// t = 3 s, 20 mm deep), the shaft's friction reversed on the waypoint's own tick, a 19 % drop in
// the force while the needle was still advancing into that tick. The force now holds through the
// deepest tick and falls from the first withdrawing one.
TEST(NeedleFeel, FrictionReversesOnTheFirstWithdrawingTickNotBefore) {
  const std::filesystem::path out = std::filesystem::temp_directory_path() / "palpate_needle_turn";
  RunOptions o;
  o.out = out;
  o.plots = false;
  std::vector<std::array<double, 3>> rows;  // t, tool_y, force_y
  o.series_row = [&](std::span<const double> row) { rows.push_back({row[0], row[2], row[5]}); };
  auto r = run_scene(shipped(), o);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->series_columns[0], "t");
  ASSERT_EQ(r->series_columns[2], "tool_y");
  ASSERT_EQ(r->series_columns[5], "force_y");
  size_t deepest = 0;
  for (size_t k = 0; k < rows.size(); ++k)
    if (rows[k][1] < rows[deepest][1]) deepest = k;
  ASSERT_GT(deepest, 10u);
  ASSERT_LT(deepest + 10, rows.size());
  EXPECT_NEAR(rows[deepest][0], 3.0, 1e-9);
  // Advancing into the deepest tick: the force there is the advancing force, as on the ticks before.
  EXPECT_NEAR(rows[deepest][2], rows[deepest - 1][2], 0.01 * rows[deepest - 1][2]) << "t = " << rows[deepest][0];
  // Withdrawing from the next tick on: the friction reverses there, and the force falls.
  EXPECT_LT(rows[deepest + 1][2], 0.9 * rows[deepest][2]);
  std::filesystem::remove_all(out);
}

// The same on the shipped CVC neck (data/scenes/cvc.yaml): an 18 G needle at 45° through skin and
// fat into the jugular vein and out again, at 1, 10 and 20 mm/s.
TEST(NeedleFeel, NoGritOnTheCvcNeckAtEverySpeed) {
  auto loaded = load_scene(PALPATE_SOURCE_DIR "/data/scenes/cvc.yaml");
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  auto expanded = expand_anatomy(*loaded);  // the neck's layers
  ASSERT_TRUE(expanded.ok()) << expanded.error().message;
  const SceneDef& scene = *expanded;
  const Vec3 start = scene.device.waypoints.front().position;
  const double travel = (scene.device.waypoints[2].position - start).norm();  // to the vein's centre
  for (double speed : {0.001, 0.01, 0.02}) {
    const Insertion r = insert(scene, speed, scene.dt, start, travel, true);
    ASSERT_GE(punctures(r).size(), 3u) << speed;  // skin, fat, the vein's anterior wall
    const int checked = expect_no_grit(scene, r, speed);
    EXPECT_GT(checked, int(0.15 * r.ticks.size())) << speed;
    for (const Tick& t : r.ticks) ASSERT_LE(t.norm, scene.device.max_force);
    expect_withdrawal_is_friction(scene, r, speed);  // out again: friction and no catch
  }
}
