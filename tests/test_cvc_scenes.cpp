// test_cvc_scenes.cpp — the shipped CVC scenes (a neck generated from published figures): each
// anatomical variant runs, the needle meets every layer in order, and the scripted passes come out
// as the procedure's outcomes — in the vein, through its back wall, into the carotid — with the
// needle-feel properties (no rate limiting, punctures at their set forces) on the neck too.
#include <palpate/anatomy.h>
#include <palpate/outcome.h>
#include <palpate/run.h>
#include <palpate/scene.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

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
    Outcome outcome;
  } cases[] = {{"cvc.yaml", 1, 0, Outcome::vein}, {"cvc-deep-vein.yaml", 1, 0, Outcome::vein},
               {"cvc-small-vein.yaml", 2, 0, Outcome::posterior_wall}, {"cvc-overlap.yaml", 2, 1, Outcome::artery}};
  for (const Case& c : cases) {
    const Shipped s = run_shipped(c.file);
    EXPECT_EQ(s.run.metrics.outcome, c.outcome) << c.file;
    EXPECT_TRUE(s.run.metrics.flashback) << c.file << ": every pass here enters the vein first";
    EXPECT_EQ(punctures(s.run, "skin"), 1) << c.file;
    EXPECT_EQ(punctures(s.run, "fat"), 1) << c.file;
    EXPECT_EQ(punctures(s.run, "ijv"), c.ijv) << c.file << ": the vein (2 = through its back wall)";
    EXPECT_EQ(punctures(s.run, "cca"), c.cca) << c.file << ": the carotid";
    EXPECT_EQ(s.run.safety.rate_limited, 0u) << c.file;
    EXPECT_EQ(s.run.safety.clamped, 0u) << c.file;
    EXPECT_GT(s.run.max_force, 1.0) << c.file << ": the needle is felt";
    for (const RunEvent& e : s.run.events) {
      if (e.kind == "puncture") {
        EXPECT_NEAR(e.force, puncture_force(s.scene, e.tissue), 0.05 * puncture_force(s.scene, e.tissue))
            << c.file << " " << e.tissue;
      }
    }
    // Skin first (the fat under it gives in the same tick), then the vessels.
    const auto first = std::find_if(s.run.events.begin(), s.run.events.end(),
                                    [](const RunEvent& e) { return e.kind == "puncture"; });
    ASSERT_NE(first, s.run.events.end());
    EXPECT_TRUE(first->tissue == "skin" || first->tissue == "fat") << c.file;
  }
}

namespace {

// run.csv as columns by name.
std::map<std::string, std::vector<double>> read_csv(const std::filesystem::path& file) {
  std::ifstream in(file);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> names;
  for (std::stringstream ss(line); std::getline(ss, line, ',');) names.push_back(line);
  std::map<std::string, std::vector<double>> cols;
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string cell;
    for (size_t i = 0; i < names.size() && std::getline(ss, cell, ','); ++i)
      cols[names[i]].push_back(cell.empty() ? 0.0 : std::strtod(cell.c_str(), nullptr));
  }
  return cols;
}

}  // namespace

// The calibration table of docs/validation.md, held: each figure against its published target.
TEST(CvcScenes, TheCalibratedSceneReproducesThePublishedFigures) {
  auto scene = load_scene(PALPATE_SOURCE_DIR "/data/scenes/cvc.yaml");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  RunOptions o;
  o.out = std::filesystem::temp_directory_path() / "palpate_cvc_calibration";
  o.plots = false;
  auto r = run_scene(*scene, o);
  ASSERT_TRUE(r.ok()) << r.error().message;
  auto cols = read_csv(o.out / "run.csv");
  std::filesystem::remove_all(o.out);
  const auto& t = cols["t"];
  ASSERT_GT(t.size(), 1000u);
  auto event = [&](const char* kind, const char* tissue) {
    for (const RunEvent& e : r->events)
      if (e.kind == kind && e.tissue == tissue) return e;
    ADD_FAILURE() << "no " << kind << " of " << tissue;
    return RunEvent{};
  };
  auto row_at = [&](double time) {
    return size_t(std::lower_bound(t.begin(), t.end(), time - 1e-9) - t.begin());
  };
  auto tip = [&](size_t k) { return Vec3(cols["tool_x"][k], cols["tool_y"][k], cols["tool_z"][k]); };
  // Skin: the median puncture force over 24 studies, 1.22 N (van Gerwen et al. 2012).
  EXPECT_NEAR(event("puncture", "skin").force, 1.22, 0.05 * 1.22);
  // The vein's anterior wall: the design value 0.5 N (a second, smaller pop).
  EXPECT_NEAR(event("puncture", "ijv").force, 0.5, 0.05 * 0.5);
  // Needle path from the skin to blood at 45°: 15.0–21.5 mm (Maruyama et al. 1997).
  size_t skin = 0;
  while (skin < t.size() && tip(skin).y() > neck_skin_height(*scene->anatomy, tip(skin).x())) ++skin;
  const size_t flash = row_at(event("flashback", "ijv").time);
  ASSERT_LT(skin, flash);
  const double path = (tip(flash) - tip(skin)).norm();
  EXPECT_GE(path, 0.0150);
  EXPECT_LE(path, 0.0215);
  // Shaft friction ≈ 21 % of the insertion force (Barnett et al. 2015): the friction at the vein,
  // against the peak force of the insertion.
  const size_t before = row_at(event("puncture", "ijv").time) - 1;
  const double friction = cols["force_N"][before] - cols["ijv.force_N"][before];
  const double share = friction / r->max_force;
  EXPECT_GT(share, 0.15);
  EXPECT_LT(share, 0.27);
  // Within what a Geomagic Touch renders (3.3 N peak).
  EXPECT_LE(r->max_force, 3.3);
  EXPECT_EQ(r->metrics.outcome, Outcome::vein);
  EXPECT_EQ(r->metrics.skin_punctures, 1);
  EXPECT_EQ(r->metrics.passes, 1);
}
