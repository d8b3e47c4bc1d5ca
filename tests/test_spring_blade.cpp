// test_spring_blade.cpp — a blade against a mass-spring organ as a scene tissue (tissue.cpp with
// blade.cpp and cut.cpp): it presses until the cutting force, then parts the organ; the hand feels
// the resistance, then the cut's drag, never a step; the wound is drawn closed; runs repeat exactly.
#include <palpate/scene.h>
#include <palpate/spring.h>
#include <palpate/tissue.h>
#include <palpate/tissue_files.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cmath>
#include <map>
#include <string>
#include <vector>

namespace {

using namespace palpate;

// A ball of tissue 20 mm across resting on its base, a scalpel (10 mm edge) held upright above it.
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

std::unique_ptr<Tissue> ball_tissue(const std::string& extra = "") {
  auto scene = parse_scene(std::string(kBall) + extra, "ball.yaml", ".");
  EXPECT_TRUE(scene.ok()) << scene.error().message;
  auto t = make_tissue(*scene, 0);
  EXPECT_TRUE(t.ok()) << t.error().message;
  return std::move(*t);
}

struct Tick {
  Vec3 tip, force;
  double cut_springs = 0, cutting = 0;
};

// The hand: down onto the ball's top at 20 mm/s (into it by up to 6 mm), then drawn 8 mm along +x at
// 20 mm/s, then lifted out.
std::vector<Tick> drive(Tissue& tissue) {
  const auto names = tissue.figure_names();
  const auto col = [&](const std::string& n) {
    return static_cast<size_t>(std::find(names.begin(), names.end(), n) - names.begin());
  };
  std::vector<double> fig(names.size());
  std::vector<Tick> out;
  ToolState tool;
  tool.blade = true;
  tool.length = 0.01;
  tool.radius = 0.0005;
  tool.axis = Vec3(0, -1, 0);
  const double dt = 0.001, v = 0.02;
  Vec3 at(0.0004, 0.0115, 0.0002);  // (off the ball's top vertex)
  for (int k = 0; k < 1100; ++k) {
    Vec3 vel = Vec3::Zero();
    const double t = k * dt;
    if (t < 0.45) vel = Vec3(0, -v, 0);      // press in (through 9 mm of travel: first contact at 1.5 mm)
    else if (t < 0.85) vel = Vec3(v, 0, 0);  // draw the cut along +x
    else vel = Vec3(0, v, 0);                // lift out
    at += vel * dt;
    tool.time = t;
    tool.tip = at;
    tool.velocity = vel;
    const Vec3 f = tissue.step(tool, dt);
    tissue.figures(fig);
    out.push_back({at, f, fig[col("cut_springs")], fig[col("cutting")]});
  }
  return out;
}

TEST(SpringBlade, ItPressesUntilTheCuttingForceThenPartsTheOrganWithoutAStep) {
  auto tissue = ball_tissue();
  ASSERT_TRUE(tissue);
  const auto names = tissue->figure_names();
  ASSERT_NE(std::find(names.begin(), names.end(), "cut_springs"), names.end());
  const std::vector<Tick> run = drive(*tissue);
  if (const char* dump = std::getenv("PALPATE_BLADE_TRACE")) {
    FILE* f = std::fopen(dump, "w");
    for (size_t k = 0; k < run.size(); ++k)
      std::fprintf(f, "%zu %.5f %.5f %.5f %.4f %.4f %.4f %.0f %.0f\n", k, run[k].tip.x(), run[k].tip.y(), run[k].tip.z(),
                   run[k].force.x(), run[k].force.y(), run[k].force.z(), run[k].cut_springs, run[k].cutting);
    std::fclose(f);
  }
  double peak_before = 0, max_step = 0;
  size_t first_cut = run.size();
  for (size_t k = 0; k < run.size(); ++k) {
    ASSERT_TRUE(run[k].force.allFinite()) << "tick " << k;
    if (run[k].cut_springs > 0 && first_cut == run.size()) first_cut = k;
    if (first_cut == run.size()) peak_before = std::max(peak_before, run[k].force.norm());
    if (k > 0) max_step = std::max(max_step, (run[k].force - run[k - 1].force).norm());
  }
  ASSERT_LT(first_cut, run.size()) << "the blade never cut";
  // The resistance before the tissue parts: the force reached the cutting force first.
  EXPECT_GE(peak_before, 0.95);
  // Never a step the safety filter (200 N/s, 0.2 N a tick) would have to clip.
  EXPECT_LE(max_step, 0.2);
  // It went on cutting while drawn: more springs cut at the end of the draw than when it began.
  const size_t draw_start = 450, draw_end = 849;
  EXPECT_GT(run[draw_end].cut_springs, run[draw_start].cut_springs);
  // While drawn along +x inside the cut the drag opposes the motion.
  double fx = 0;
  int n = 0;
  for (size_t k = draw_start + 50; k < draw_end; ++k)
    if (run[k].cutting > 0) {
      fx += run[k].force.x();
      ++n;
    }
  ASSERT_GT(n, 100);
  EXPECT_LT(fx / n, -0.05);
  // While cutting, the felt force stays within the cutting force plus the whole edge's drag.
  for (size_t k = first_cut; k < draw_end; ++k)
    if (run[k].cutting > 0) {
      EXPECT_LE(run[k].force.norm(), 1.0 + 170 * 0.01 + 1e-9) << "tick " << k;
    }
}

TEST(SpringBlade, TheWoundIsDrawnClosedAndRemovedSpringsAreNotDrawn) {
  auto tissue = ball_tissue();
  drive(*tissue);
  const SpringBody* body = tissue->spring_body();
  ASSERT_NE(body, nullptr);
  std::map<std::pair<int, int>, int> directed;
  for (const auto& t : body->model->network.triangles)
    for (int k = 0; k < 3; ++k) ++directed[{t[static_cast<size_t>(k)], t[static_cast<size_t>((k + 1) % 3)]}];
  int open = 0;
  for (const auto& [e, count] : directed)
    if (count != 1 || !directed.count({e.second, e.first})) ++open;
  EXPECT_EQ(open, 0);
  TissueSnapshot snap;
  tissue->snapshot(snap);
  EXPECT_LT(snap.links.size(), body->model->network.springs.size());
}

TEST(SpringBlade, AHeadlessRunRepeatsTickForTick) {
  auto a = ball_tissue();
  auto b = ball_tissue();
  const auto ra = drive(*a), rb = drive(*b);
  ASSERT_EQ(ra.size(), rb.size());
  for (size_t k = 0; k < ra.size(); ++k) {
    ASSERT_EQ(ra[k].force, rb[k].force) << "tick " << k;
    ASSERT_EQ(ra[k].cut_springs, rb[k].cut_springs) << "tick " << k;
  }
}

TEST(SpringBlade, ATeleportingOrBrokenBladeCutsNothing) {
  auto tissue = ball_tissue();
  ToolState tool;
  tool.blade = true;
  tool.length = 0.01;
  tool.radius = 0.0005;
  tool.axis = Vec3(0, -1, 0);
  std::vector<double> fig(tissue->figure_names().size());
  // Pressed in hard, then a pose 5 cm away and back: the jump sweeps nothing.
  tool.tip = Vec3(0, 0.0095, 0);
  for (int k = 0; k < 50; ++k) tissue->step(tool, 0.001);
  tissue->figures(fig);
  const double before = fig[9];
  tool.tip = Vec3(0.05, 0.0095, 0);
  tissue->step(tool, 0.001);
  tool.tip = Vec3(-0.002, 0.0095, 0);
  tissue->step(tool, 0.001);
  tissue->figures(fig);
  EXPECT_GE(fig[15], 1.0);  // blade_jumps
  // A NaN pose and a zero-length edge: nothing cut, the force finite.
  tool.tip = Vec3(std::nan(""), 0, 0);
  EXPECT_TRUE(tissue->step(tool, 0.001).allFinite());
  tool.tip = Vec3(0.002, 0.0095, 0);
  tool.length = 0;
  for (int k = 0; k < 5; ++k) EXPECT_TRUE(tissue->step(tool, 0.001).allFinite());
  tissue->figures(fig);
  // Whatever the tip parts where it presses, the jump's 5 cm path through the ball was not cut: at
  // most a tip's worth of springs more.
  EXPECT_LT(fig[9] - before, 30);
}

TEST(SpringBlade, AContactTooSoftToHoldTheBladeUntilItCutsIsRefusedAtLoad) {
  // 600 N/m on a 0.5 mm blade holds 0.3 N: the edge would slip through the surface before cutting.
  std::string yaml = kBall;
  yaml.replace(yaml.find("contact_stiffness: 5000"), 23, "contact_stiffness: 600");
  auto scene = parse_scene(yaml, "ball.yaml", ".");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  auto t = make_tissue(*scene, 0);
  ASSERT_FALSE(t.ok());
  EXPECT_NE(t.error().message.find(":6: tissue 'ball': material.contact_stiffness: 600 N/m holds the blade "
                                   "(radius 0.0005 m) to at most 0.3 N"),
            std::string::npos)
      << t.error().message;
}

TEST(SpringBlade, ABladeOnAMultiRateOrganOrTheExactSolverIsRefusedAtLoad) {
  auto scene = parse_scene(std::string(kBall) + "      physics_rate: 200\n", "ball.yaml", ".");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  auto t = make_tissue(*scene, 0);
  ASSERT_FALSE(t.ok());
  EXPECT_NE(t.error().message.find("material.physics_rate"), std::string::npos) << t.error().message;
  auto exact = parse_scene(std::string(kBall) + "      exact_iterations: 0\n", "ball.yaml", ".");
  ASSERT_TRUE(exact.ok());
  std::string yaml = kBall;
  yaml.replace(yaml.find("solver: sparse"), 14, "solver: exact");
  auto ex = parse_scene(yaml, "ball.yaml", ".");
  ASSERT_TRUE(ex.ok()) << ex.error().message;
  auto te = make_tissue(*ex, 0);
  ASSERT_FALSE(te.ok());
  EXPECT_NE(te.error().message.find("material.solver"), std::string::npos) << te.error().message;
}

}  // namespace

namespace {

TEST(SpringBlade, ANewAttemptHealsTheOrgan) {
  // Tissue::reset (the viewer's new attempt) puts the cut organ back whole: the same drawn surface
  // and springs, no cut counted, and it then presses exactly as an organ that was never cut.
  auto cut = ball_tissue();
  auto fresh = ball_tissue();
  const auto before = fresh->spring_body()->model->network.triangles.size();
  drive(*cut);
  ASSERT_NE(cut->spring_body()->model->network.triangles.size(), before);
  cut->reset();
  EXPECT_EQ(cut->spring_body()->model->network.triangles.size(), before);
  std::vector<double> fig(cut->figure_names().size());
  cut->figures(fig);
  EXPECT_EQ(fig[9], 0.0);  // cut_springs
  ToolState tool;
  tool.blade = true;
  tool.length = 0.01;
  tool.radius = 0.0005;
  tool.axis = Vec3(0, -1, 0);
  for (int k = 0; k < 120; ++k) {
    tool.tip = Vec3(0.0004, 0.0105 - 2e-5 * k, 0.0002);
    tool.velocity = Vec3(0, -0.02, 0);
    tool.time = k * 0.001;
    ASSERT_EQ(cut->step(tool, 0.001), fresh->step(tool, 0.001)) << "tick " << k;
  }
}

}  // namespace
