// test_one_neck.cpp — one neck under both tools (issue 35, item 4): the probe's press deforms the
// tissue the needle meets. The needle's layers are built at rest and meet the needle mapped through
// the inverse of the deformation the image draws (NeckCompression::rest_point), so the vein the
// needle finds is the compressed one, a firm press closes it to a slit in the image and in the
// needle's tissue alike, and the run's outcome follows what the image shows.
#include <palpate/anatomy.h>
#include <palpate/outcome.h>
#include <palpate/run.h>
#include <palpate/scene.h>
#include <palpate/ultrasound.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

using namespace palpate;

namespace {

constexpr double kPi = 3.14159265358979323846;

// The probe across the neck over the vein, pressed until it carries `force` newtons.
ProbePose pressed_with(const NeckCompression& model, const NeckDef& neck, double force) {
  auto at = [&](double press) {
    ProbePose pose;
    pose.position = Vec3(neck_vein(neck).axis_point.x(), neck_skin_height(neck, neck_vein(neck).axis_point.x()) - press, 0);
    return pose;
  };
  double lo = 0, hi = 0.03;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (model.probe_force(at(mid)).norm() < force ? lo : hi) = mid;
  }
  return at(0.5 * (lo + hi));
}

// Whether the rest point X lies in the vessel's rest lumen.
bool in_rest_lumen(const VesselGeometry& g, const Vec3& X) {
  Vec3 d = X - g.axis_point;
  d -= d.dot(g.axis) * g.axis;
  return d.norm() < g.radius;
}

}  // namespace

// Away from the vessels the map is the half-space's displacement inverted: a rest point moved by
// it comes back to itself.
TEST(OneNeck, RestPointInvertsTheHalfSpacesDisplacementAwayFromTheVessels) {
  const NeckDef neck;
  NeckCompression model(neck, ProbeDef{});
  const auto s = model.state(pressed_with(model, neck, 3.0), 0);
  ASSERT_GT(s.indentation, 0.005);
  int checked = 0;
  for (double x : {0.027, 0.03})
    for (double depth : {0.002, 0.005, 0.008})
      for (double z : {-0.006, 0.0, 0.006}) {
        const Vec3 X(x, neck_skin_height(neck, x) - depth, z);
        const Vec3 u = model.displacement(s, X);
        const Vec3 back = model.rest_point(s, X + u);
        EXPECT_LT((back - X).norm(), 1e-6) << X.transpose() << ", moved " << u.norm() * 1e3 << " mm";
        ++checked;
      }
  EXPECT_EQ(checked, 18);
  // No press: nothing moves.
  const auto rest = model.state(ProbePose{Vec3(0, 0.01, 0), Quat::Identity()}, 0);
  EXPECT_EQ(model.rest_point(rest, Vec3(0.001, -0.012, 0.002)), Vec3(0.001, -0.012, 0.002));
}

// The image and the needle's tissue agree on every vessel: the wall the image draws maps onto the
// wall the needle's layer has at rest, and a point is in the lumen the image shows exactly when it
// is in the layer's lumen — at a light touch and at a firm press, for the vein and the carotid.
TEST(OneNeck, TheImagesVesselsAreTheNeedlesTissuesVessels) {
  const NeckDef neck;
  NeckCompression model(neck, ProbeDef{});
  for (double force : {0.4, 1.0, 3.0}) {
    const auto s = model.state(pressed_with(model, neck, force), 0.3);
    for (const bool vein : {true, false}) {
      const VesselGeometry g = vein ? neck_vein(neck) : neck_artery(neck);
      const VesselSection v = vein ? s.vein : s.artery;
      const Vec3 across = v.axis.cross(v.minor_dir);
      for (int k = 0; k < 24; ++k) {
        const double th = 2 * kPi * k / 24;
        const Vec3 wall = v.centre + v.a * std::cos(th) * across + v.b * std::sin(th) * v.minor_dir;
        Vec3 d = model.rest_point(s, wall) - g.axis_point;
        d -= d.dot(g.axis) * g.axis;
        EXPECT_NEAR(d.norm(), g.radius, 1e-9) << force << " N, " << (vein ? "vein" : "artery") << ", " << k;
      }
      int disagree = 0, inside = 0;
      for (double du = -1.6; du <= 1.6; du += 0.05)
        for (double dv = -1.6; dv <= 1.6; dv += 0.05) {
          const Vec3 p = v.centre + dv * g.radius * across + du * g.radius * v.minor_dir;
          const bool image = v.contains(p), tissue = in_rest_lumen(g, model.rest_point(s, p));
          disagree += image != tissue;
          inside += image;
        }
      EXPECT_EQ(disagree, 0) << force << " N, " << (vein ? "vein" : "artery");
      EXPECT_GT(inside, 0);
    }
  }
}

// A firm press (3 N) closes the vein to a slit — at most 10 % of its rest area, in the image's
// section and in the needle's tissue (the area of the points whose rest point is in the rest
// lumen) — while the carotid stays round.
TEST(OneNeck, AFirmPressClosesTheVeinToASlitInTheImageAndInTheNeedlesTissue) {
  const NeckDef neck;
  NeckCompression model(neck, ProbeDef{});
  const auto s = model.state(pressed_with(model, neck, 3.0), 0);
  EXPECT_LE(s.vein.area_ratio, 0.10);
  const VesselGeometry g = neck_vein(neck);
  const Vec3 across = s.vein.axis.cross(s.vein.minor_dir);
  const double h = 0.00005;  // m, a 50 µm grid over the section
  double area = 0;
  for (double du = -0.01; du <= 0.01; du += h)
    for (double dv = -0.012; dv <= 0.012; dv += h)
      if (in_rest_lumen(g, model.rest_point(s, s.vein.centre + dv * across + du * s.vein.minor_dir))) area += h * h;
  EXPECT_LE(area, 0.10 * kPi * g.radius * g.radius);
  EXPECT_NEAR(area, s.vein.area_ratio * kPi * g.radius * g.radius, 0.01 * kPi * g.radius * g.radius);
  EXPECT_GT(s.artery.a / s.artery.b, 0.999);
  EXPECT_LT(s.artery.a / s.artery.b, 1.001);
}

namespace {

struct NeckRun {
  RunSummary summary;
  std::vector<std::array<double, 4>> needle;  // t, tip x, y, z
};

// cvc.yaml with its probe held at `probe_force` newtons over the vein (after 0.3 s to get there)
// from the start, or pressed to it only at `press_at` s (the needle already in).
NeckRun run_with_probe(double probe_force, double press_at = 0) {
  auto loaded = load_scene(PALPATE_SOURCE_DIR "/data/scenes/cvc.yaml");
  EXPECT_TRUE(loaded.ok()) << loaded.error().message;
  SceneDef scene = *loaded;
  NeckCompression model(*scene.anatomy, *scene.probe);
  const ProbePose light = pressed_with(model, *scene.anatomy, 0.4), firm = pressed_with(model, *scene.anatomy, probe_force);
  std::vector<Waypoint>& w = scene.probe->device.waypoints;
  if (press_at > 0)
    w = {{0.0, light.position}, {press_at, light.position}, {press_at + 1.0, firm.position}};
  else
    w = {{0.0, light.position}, {0.3, firm.position}};
  RunOptions o;
  o.out = std::filesystem::temp_directory_path() / ("palpate_one_neck_" + std::to_string(int(probe_force * 10)));
  o.plots = false;
  NeckRun r;
  o.series_row = [&](std::span<const double> row) { r.needle.push_back({row[0], row[1], row[2], row[3]}); };
  auto s = run_scene(scene, o);
  EXPECT_TRUE(s.ok()) << s.error().message;
  std::filesystem::remove_all(o.out);
  r.summary = *s;
  return r;
}

long count(const RunSummary& r, const std::string& kind, const std::string& tissue) {
  return std::count_if(r.events.begin(), r.events.end(),
                       [&](const RunEvent& e) { return e.kind == kind && e.tissue == tissue; });
}

}  // namespace

// The outcome follows the image: cvc.yaml's needle, aimed at the vein's centre, enters it under a
// light probe; with the probe pressing the vein to a slit, the same needle meets the compressed
// vein — its wall where the image shows it — and never has its tip in a lumen the image shows.
TEST(OneNeck, TheNeedleMeetsTheVeinTheProbeHasCompressed) {
  const NeckRun light = run_with_probe(0.4), firm = run_with_probe(3.0);
  EXPECT_EQ(light.summary.metrics.outcome, Outcome::vein);
  EXPECT_EQ(count(light.summary, "puncture", "ijv"), 1);
  EXPECT_EQ(firm.summary.safety.rate_limited, 0u);
  EXPECT_EQ(light.summary.safety.rate_limited, 0u);
  EXPECT_FALSE(firm.summary.metrics.flashback) << "the tip ends above the slit the image shows";
  EXPECT_NE(firm.summary.metrics.outcome, Outcome::vein);
  // What the image shows at the needle's deepest point: the tip inside the light press's vein, and
  // outside the firm press's slit.
  const auto scene = load_scene(PALPATE_SOURCE_DIR "/data/scenes/cvc.yaml");
  ASSERT_TRUE(scene.ok());
  NeckCompression model(*scene->anatomy, *scene->probe);
  auto deepest = [](const NeckRun& r) {
    const auto it = std::min_element(r.needle.begin(), r.needle.end(),
                                     [](const auto& a, const auto& b) { return a[2] < b[2]; });
    return Vec3((*it)[1], (*it)[2], (*it)[3]);
  };
  EXPECT_TRUE(model.state(pressed_with(model, *scene->anatomy, 0.4), 0).vein.contains(deepest(light)));
  EXPECT_FALSE(model.state(pressed_with(model, *scene->anatomy, 3.0), 0).vein.contains(deepest(firm)));
}

// A probe pressed firmly while the needle is in the vein moves the vein around the tip: the wall
// comes to the needle and the run stays smooth — no force the safety filter has to limit.
TEST(OneNeck, PressingTheProbeWhileTheNeedleIsInStaysSmooth) {
  const NeckRun r = run_with_probe(3.0, 7.2);  // the needle holds in the vein from 6.96 to 9.46 s
  EXPECT_TRUE(r.summary.metrics.flashback);
  EXPECT_EQ(r.summary.safety.rate_limited, 0u);
  EXPECT_EQ(r.summary.safety.clamped, 0u);
  EXPECT_LE(r.summary.max_force, 3.3);
}
