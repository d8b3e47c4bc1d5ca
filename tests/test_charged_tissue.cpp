// test_charged_tissue.cpp — the charged-particle model as a scene tissue: build from a scene (patch
// or mesh), figures, events, snapshot, reset, errors.
#include <palpate/scene.h>
#include <palpate/tissue.h>
#include <palpate/tissue_files.h>

#include "components.h"
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

using namespace palpate;

namespace {

SceneDef scene_of(const std::string& yaml) {
  auto s = parse_scene(yaml, "t.yaml", PALPATE_DATA_DIR);
  EXPECT_TRUE(s.ok()) << s.error().message;
  return *s;
}

}  // namespace

TEST(ChargedTissue, PatchSceneStepsReportsFiguresEventsSnapshotAndResets) {
  const SceneDef scene = scene_of(R"(tissues:
  - name: skin
    patch: {width: 0.02, height: 0.02, spacing: 0.001}
    material: {puncture_force: 1.0}
)");
  auto made = make_tissue(scene, 0);
  ASSERT_TRUE(made.ok()) << made.error().message;
  Tissue& t = **made;
  EXPECT_EQ(t.name(), "skin");
  const auto names = t.figure_names();
  ASSERT_GE(names.size(), 4u);
  EXPECT_EQ(names[0], "force_N");
  EXPECT_EQ(names[1], "max_displacement_m");
  EXPECT_EQ(names[2], "active_particles");
  const auto punctured_at = std::find(names.begin(), names.end(), "punctured") - names.begin();
  ASSERT_LT(size_t(punctured_at), names.size());

  TissueSnapshot rest;
  t.snapshot(rest);
  ASSERT_EQ(rest.rows_cols.size(), 2u);
  const int rows = rest.rows_cols[0], cols = rest.rows_cols[1];
  ASSERT_EQ(rest.points.size(), size_t(rows * cols));
  EXPECT_EQ(rest.links.size(), size_t(rows * (cols - 1) + (rows - 1) * (2 * cols - 1)));
  EXPECT_EQ(rest.triangles.size(), size_t((rows - 1) * 2 * (cols - 1)));

  // A needle pressed down through the middle: force up, then a puncture event, then 'punctured'.
  ToolState tool;
  tool.needle = true, tool.length = 0.05;
  std::vector<double> figures(names.size());
  std::vector<TissueEvent> events;
  double peak = 0;
  for (int k = 0; k < 5000 && events.empty(); ++k) {
    tool.time = k * 0.001;
    tool.tip = Vec3(0.00025, 0.005 - k * 2e-6, 0);
    peak = std::max(peak, t.step(tool, 0.001).y());
    TissueEvent ev[4];
    const size_t n = t.drain_events(ev);
    events.insert(events.end(), ev, ev + n);
  }
  ASSERT_EQ(events.size(), 1u);
  EXPECT_STREQ(events[0].kind, "puncture");
  EXPECT_EQ(events[0].tissue, 0);
  EXPECT_NEAR(events[0].force, 1.0, 1e-9);  // the material's puncture force, at any spacing
  EXPECT_GE(peak, 0.99);
  t.step(tool, 0.001);
  t.figures(figures);
  EXPECT_EQ(figures[size_t(punctured_at)], 1.0);
  EXPECT_GT(figures[2], 0.0);
  TissueEvent none[1];
  EXPECT_EQ(t.drain_events(none), 0u);

  TissueSnapshot pressed;
  t.snapshot(pressed);
  double moved = 0;
  for (size_t i = 0; i < pressed.points.size(); ++i) moved = std::max(moved, double((pressed.points[i] - rest.points[i]).norm()));
  EXPECT_GT(moved, 0.004);

  t.reset();
  TissueSnapshot after;
  t.snapshot(after);
  EXPECT_EQ(after.points, rest.points);
  t.figures(figures);
  EXPECT_EQ(figures[0], 0.0);
  EXPECT_EQ(figures[size_t(punctured_at)], 0.0);
}

TEST(ChargedTissue, MeshSceneLaysParticlesOnTheLoadedSurface) {
  PALPATE_NEEDS(CGAL, "CGAL");
  const SceneDef scene = scene_of(R"(tissues:
  - name: liver
    mesh: {file: meshes/liver-smooth.obj, scale: 0.01, translate: [0, 0.1, 0]}
    material: {mesh_spacing: 0.004, max_separation: 0.0064}
)");
  auto made = make_tissue(scene, 0);
  ASSERT_TRUE(made.ok()) << made.error().message;
  TissueSnapshot snap;
  (*made)->snapshot(snap);
  EXPECT_TRUE(snap.rows_cols.empty());
  EXPECT_GT(snap.points.size(), 300u);
  EXPECT_FALSE(snap.triangles.empty());
  // Translated: every particle sits well above y = 0.1 - half the liver's height.
  for (const Vec3f& p : snap.points) EXPECT_GT(p.y(), 0.1 - 0.04);
  // Closed surface: each link is an edge of exactly two triangles, so links = 3/2 triangles at most.
  EXPECT_LE(snap.links.size(), snap.triangles.size() * 3 / 2);
}

TEST(ChargedTissue, BadDefinitionsAreErrorsNamingTheTissue) {
  // Built in memory (the scene parser already refuses this case with its own message).
  SceneDef scene;
  scene.file = "t.yaml";
  scene.tissues.resize(1);
  scene.tissues[0].name = "skin", scene.tissues[0].line = 2;
  scene.tissues[0].patch = PatchDef{};
  scene.tissues[0].charged.max_separation = 0.0009;
  auto tight = make_tissue(scene, 0);
  ASSERT_FALSE(tight.ok());
  EXPECT_EQ(tight.error().message,
            "t.yaml:2: tissue 'skin': material 'max_separation' (0.0009 m) must exceed the rest distance "
            "between neighbours (0.001 m), or the patch would violate the separation rule at rest");
  scene.tissues[0].patch.reset();
  auto neither = make_tissue(scene, 0);
  ASSERT_FALSE(neither.ok());
  EXPECT_EQ(neither.error().message, "t.yaml:2: tissue 'skin': expected exactly one of 'patch' and 'mesh'");
  SceneDef missing = scene;
  missing.tissues[0].name = "organ";
  missing.tissues[0].mesh = MeshRef{};
  missing.tissues[0].mesh->file = "/nonexistent/no-such.obj";
  auto no_file = make_tissue(missing, 0);
  ASSERT_FALSE(no_file.ok());
  EXPECT_NE(no_file.error().message.find("tissue 'organ'"), std::string::npos) << no_file.error().message;
  EXPECT_NE(no_file.error().message.find("no-such.obj"), std::string::npos) << no_file.error().message;
}

// An anchor must name a particle of the patch: one past it was accepted and ignored. A long list
// of anchors loads (duplicates are found through a hash set, not a search per anchor).
TEST(ChargedTissue, AnchorsOutsideThePatchAreRefused) {
  const SceneDef scene = scene_of(R"(tissues:
  - name: skin
    patch: {width: 0.02, height: 0.02, spacing: 0.001}
    anchors: [0, 5, 999999]
)");
  auto made = make_tissue(scene, 0);
  ASSERT_FALSE(made.ok());
  EXPECT_NE(made.error().message.find(":2: tissue 'skin': anchors[2]: 999999 is not a particle of the patch (it has 504: 0..503)"),
            std::string::npos)
      << made.error().message;
  std::string many = "tissues:\n  - name: skin\n    patch: {width: 0.02, height: 0.02, spacing: 0.001}\n    anchors: [";
  for (int i = 0; i < 200000; ++i) {
    if (i) many += ',';
    many += std::to_string(i);
  }
  many += "]\n";
  auto s = parse_scene(many, "t.yaml", PALPATE_DATA_DIR);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->tissues[0].anchors.size(), 200000u);
  EXPECT_EQ(s->tissues[0].anchors.back(), 199999);
}

// A step that recovers from numerical trouble (state reset, zero force) says so, so the haptic
// loop can count it as step_failed; the next good step does not.
TEST(ChargedTissue, AResetStepReportsItsFailure) {
  const SceneDef scene = scene_of(R"(tissues:
  - name: skin
    patch: {width: 0.02, height: 0.02, spacing: 0.001}
)");
  auto made = make_tissue(scene, 0);
  ASSERT_TRUE(made.ok()) << made.error().message;
  Tissue& t = **made;
  ToolState tool;
  tool.tip = Vec3(0, 0.0005, 0);
  (void)t.step(tool, 0.001);
  EXPECT_FALSE(t.last_step_failed());
  tool.tip = Vec3(std::nan(""), 0, 0);
  EXPECT_EQ(t.step(tool, 0.001), Vec3::Zero());
  EXPECT_TRUE(t.last_step_failed());
  tool.tip = Vec3(0, 0.0005, 0);
  (void)t.step(tool, 0.001);
  EXPECT_FALSE(t.last_step_failed());
}
