// test_cvc_scenes.cpp — the shipped CVC scenes (a neck generated from published figures): each
// anatomical variant runs, the needle meets every layer in order, and the scripted passes come out
// as the procedure's outcomes — in the vein, through its back wall, into the carotid — with the
// needle-feel properties (no rate limiting, punctures at their set forces) on the neck too.
#include <palpate/anatomy.h>
#include <palpate/run.h>
#include <palpate/scene.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>

using namespace palpate;

namespace {

struct Shipped {
  SceneDef scene;
  RunSummary run;
};

Shipped run_shipped(const std::string& name) {
  auto scene = load_scene(std::string(PALPATE_SOURCE_DIR) + "/data/scenes/" + name);
  EXPECT_TRUE(scene.ok()) << scene.error().message;
  RunOptions o;
  o.out = std::filesystem::temp_directory_path() / ("palpate_" + name);
  o.plots = false;
  auto r = run_scene(*scene, o);
  EXPECT_TRUE(r.ok()) << r.error().message;
  std::filesystem::remove_all(o.out);
  return {*scene, *r};
}

long punctures(const RunSummary& r, const std::string& tissue) {
  return std::count_if(r.events.begin(), r.events.end(),
                       [&](const RunEvent& e) { return e.kind == "puncture" && e.tissue == tissue; });
}

double puncture_force(const SceneDef& s, const std::string& tissue) {
  for (const TissueDef& t : s.tissues)
    if (t.name == tissue) return t.charged.puncture_force;
  return -1;
}

}  // namespace

TEST(CvcScenes, TheNeckIsGeneratedWithPublishedDefaults) {
  auto s = load_scene(PALPATE_SOURCE_DIR "/data/scenes/cvc.yaml");
  ASSERT_TRUE(s.ok()) << s.error().message;
  ASSERT_TRUE(s->anatomy.has_value());
  ASSERT_EQ(s->tissues.size(), 4u);
  const char* roles[] = {"skin", "fat", "vein", "artery"};
  for (size_t i = 0; i < 4; ++i) EXPECT_EQ(s->tissues[i].role, roles[i]);
  const NeckDef& n = *s->anatomy;
  const VesselGeometry v = neck_vein(n), a = neck_artery(n);
  // The vein's anterior wall 11.4 mm under the skin, 13 mm across; the carotid beside it, 1.3 mm
  // away wall to wall, deeper, 6.3 mm across.
  EXPECT_NEAR(neck_skin_height(n, v.axis_point.x()) - (v.axis_point.y() + v.radius), 0.0114, 1e-12);
  EXPECT_NEAR(2 * v.radius, 0.013, 1e-12);
  EXPECT_NEAR((a.axis_point - v.axis_point).norm() - v.radius - a.radius, 0.0013, 1e-12);
  EXPECT_LT(a.axis_point.x(), v.axis_point.x()) << "the carotid lies medial to the vein";
  EXPECT_LT(a.axis_point.y(), v.axis_point.y()) << "and deeper";
  EXPECT_NEAR(2 * a.radius, 0.0063, 1e-12);
  // The tubes' patches lie on their vessels.
  EXPECT_NEAR(s->tissues[2].patch->radius, v.radius, 1e-15);
  EXPECT_NEAR((s->tissues[2].patch->center - v.axis_point).norm(), v.radius, 1e-12);
  EXPECT_NEAR((s->tissues[3].patch->center - a.axis_point).norm(), a.radius, 1e-12);
  // A bad variant is refused with what is wrong.
  auto bad = parse_scene("anatomy: {kind: neck, skin_thickness: 0.005, ijv_depth: 0.004}\n", "v.yaml");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().message,
            "v.yaml:1: anatomy: skin_thickness (0.005 m) must be less than ijv_depth (0.004 m): the vein lies under "
            "the skin");
}

TEST(CvcScenes, EachVariantGivesItsOutcomeWithTheNeedleFeelIntact) {
  struct Case {
    const char* file;
    long ijv, cca;  // punctures expected
  } cases[] = {{"cvc.yaml", 1, 0}, {"cvc-deep-vein.yaml", 1, 0}, {"cvc-small-vein.yaml", 2, 0},
               {"cvc-overlap.yaml", 2, 1}};
  for (const Case& c : cases) {
    const Shipped s = run_shipped(c.file);
    EXPECT_EQ(punctures(s.run, "skin"), 1) << c.file;
    EXPECT_EQ(punctures(s.run, "fat"), 1) << c.file;
    EXPECT_EQ(punctures(s.run, "ijv"), c.ijv) << c.file << ": the vein (2 = through its back wall)";
    EXPECT_EQ(punctures(s.run, "cca"), c.cca) << c.file << ": the carotid";
    EXPECT_EQ(s.run.safety.rate_limited, 0u) << c.file;
    EXPECT_EQ(s.run.safety.clamped, 0u) << c.file;
    EXPECT_GT(s.run.max_force, 1.0) << c.file << ": the needle is felt";
    for (const RunEvent& e : s.run.events)
      if (e.kind == "puncture")
        EXPECT_NEAR(e.force, puncture_force(s.scene, e.tissue), 0.05 * puncture_force(s.scene, e.tissue))
            << c.file << " " << e.tissue;
    // Skin first (the fat under it gives in the same tick), then the vessels.
    const auto first = std::find_if(s.run.events.begin(), s.run.events.end(),
                                    [](const RunEvent& e) { return e.kind == "puncture"; });
    ASSERT_NE(first, s.run.events.end());
    EXPECT_TRUE(first->tissue == "skin" || first->tissue == "fat") << c.file;
  }
}
