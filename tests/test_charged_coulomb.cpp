// test_charged_coulomb.cpp — the seed paper's own contact force, `force_model: coulomb` (issue 35):
// the Coulomb sum over the particles in the sphere of influence, with the artefacts it is kept to
// show (∝ 1/spacing², a stiffness that depends on the tick), the seed's puncture rule, and the same
// safety filter on the way to a device. docs/models/charged-particles.md, "The seed's Coulomb force".
#include "charged_fixtures.h"

#include <palpate/run.h>
#include <palpate/scene.h>

#include <filesystem>
#include <fstream>

using namespace palpate;
using namespace charged_test;

namespace {

ChargedMaterialDef coulomb_material() {
  ChargedMaterialDef mat;
  mat.force_model = "coulomb";
  return mat;
}

// A sphere probe appearing `height` above the rest plane of an untouched patch, over its central
// particle offset by (0.3, 0.2) mm: the force of that first tick.
Vec3 first_touch(double spacing, double height) {
  const ChargedModel m = flat(0.03, spacing, coulomb_material());
  ChargedState s = make_charged_state(m);
  const Vec3 at = m.origin(size_t(central_particle(m))) + Vec3(0.0003, height, 0.0002);
  return step(m, s, hip_at(at), kDt, 0);
}

}  // namespace

// The force is the seed's sum: k_e·q_hip·q_particle·(1/r² − 1/R²) over every particle within the
// sphere of influence R of the HIP, pushing the HIP away from each — computed here by hand from
// the particles' rest positions (an untouched patch: nothing has moved yet).
TEST(ChargedCoulomb, TheForceIsTheSeedsSumOverTheParticlesInTheSphereOfInfluence) {
  const ChargedMaterialDef mat = coulomb_material();
  const ChargedModel m = flat(0.03, 0.001, mat);
  ChargedState s = make_charged_state(m);
  const Vec3 h = m.origin(size_t(central_particle(m))) + Vec3(0.0003, 0.0004, 0.0002);
  const Vec3 f = step(m, s, hip_at(h), kDt, 0);
  const double R = ChargedHip{}.radius + mat.particle_radius;
  const double kqq = 8.9875517923e9 * mat.hip_charge * mat.particle_charge;
  Vec3 expected = Vec3::Zero();
  int inside = 0;
  for (size_t i = 0; i < m.size(); ++i) {
    const Vec3 d = h - m.origin(i);
    const double r = d.norm();
    if (r >= R) continue;
    ++inside;
    expected += kqq * (1 / (r * r) - 1 / (R * R)) * d / r;
  }
  ASSERT_GE(inside, 3);
  EXPECT_GT(f.y(), 0.0) << "like charges: the HIP is pushed back out";
  EXPECT_NEAR((f - expected).norm(), 0.0, 1e-6 * expected.norm()) << f.transpose() << " vs " << expected.transpose();
  // Outside the sphere of influence of every particle: nothing.
  ChargedState t = make_charged_state(m);
  EXPECT_EQ(step(m, t, hip_at(h + Vec3(0, R, 0)), kDt, 0), Vec3::Zero());
  // The law itself: zero at the sphere's edge, bounded at the centre by r_c = R/10.
  EXPECT_EQ(charged_coulomb_force(kqq, R, R), 0.0);
  EXPECT_EQ(charged_coulomb_force(kqq, 0.0, R), charged_coulomb_force(kqq, 0.1 * R, R));
  EXPECT_GT(charged_coulomb_force(kqq, 0.5 * R, R), charged_coulomb_force(kqq, 0.6 * R, R));
}

// The artefact the indentation law removed, kept visible in the seed's model: the same touch on a
// patch of half the spacing meets four times the particles, and the force grows with them.
TEST(ChargedCoulomb, TheSeedsForceGrowsAsOneOverTheSpacingSquared) {
  const double coarse = first_touch(0.001, 0.0004).norm(), fine = first_touch(0.0005, 0.0004).norm();
  ASSERT_GT(coarse, 0.0);
  EXPECT_GT(fine / coarse, 3.0);
  EXPECT_LT(fine / coarse, 5.0);
  // The indentation law at the same touch: the same force at both spacings.
  auto law = [](double spacing) {
    const ChargedModel m = flat(0.03, spacing);
    ChargedState s = make_charged_state(m);
    return step(m, s, hip_at(m.origin(size_t(central_particle(m))) + Vec3(0.0003, 0.0004, 0.0002)), kDt, 0).norm();
  };
  EXPECT_NEAR(law(0.0005), law(0.001), 1e-9);
}

// The other: the force comes from how far the particles are inside the sphere when the tool finds
// them, which is how far the tool moved and they relaxed in one tick — so the same press at the
// same speed is stiffer at a longer tick (the indentation law: the same at every tick).
TEST(ChargedCoulomb, TheSeedsStiffnessDependsOnTheTick) {
  auto force_at_depth = [](double dt, const ChargedMaterialDef& mat) {
    const ChargedModel m = flat(0.03, 0.001, mat);
    ChargedState s = make_charged_state(m);
    const Vec3 at = m.origin(size_t(central_particle(m))) + Vec3(0.0003, 0, 0.0002);
    const double v = 0.005, R = ChargedHip{}.radius + mat.particle_radius;
    Vec3 f = Vec3::Zero();
    const int ticks = int(std::lround(0.002 / v / dt));  // 2 mm of travel from first touch
    for (int k = 0; k <= ticks; ++k) {
      ChargedHip hip = hip_at(at + Vec3(0, R - v * dt * k, 0));
      hip.velocity = Vec3(0, -v, 0);
      f = step(m, s, hip, dt, 0);
    }
    return f.norm();
  };
  const double short_tick = force_at_depth(0.0005, coulomb_material()), long_tick = force_at_depth(0.002, coulomb_material());
  ASSERT_GT(short_tick, 0.0);
  EXPECT_GT(long_tick / short_tick, 2.0) << short_tick << " N at 0.5 ms, " << long_tick << " N at 2 ms";
  const ChargedMaterialDef law;
  EXPECT_NEAR(force_at_depth(0.002, law), force_at_depth(0.0005, law), 1e-9);
}

// The seed's puncture: a needle punctures once a particle in its sphere is held at max_displacement
// and the sum reaches puncture_force; the hole then lets it through as with the indentation law.
TEST(ChargedCoulomb, ANeedlePuncturesWhenAParticleIsPinnedAndTheSumReachesThePunctureForce) {
  ChargedMaterialDef mat = coulomb_material();
  mat.puncture_force = 0.5;
  const ChargedModel m = flat(0.03, 0.001, mat);
  ChargedState s = make_charged_state(m);
  const Vec3 at = m.origin(size_t(central_particle(m))) + Vec3(0.0003, 0, 0.0002);
  ChargedHip needle;
  needle.shaft_length = 0.05;
  needle.velocity = Vec3(0, -0.005, 0);
  double peak = 0;
  std::vector<TissueEvent> events;
  int pinned_before = 0;
  for (double y = 0.003; y > -0.012 && events.empty(); y -= 5e-6) {
    needle.position = Vec3(at.x(), y, at.z());
    const Vec3 f = step(m, s, needle, kDt, 0);
    TissueEvent ev[4];
    events.insert(events.end(), ev, ev + drain_events(s, ev));
    if (events.empty()) peak = std::max(peak, f.norm()), pinned_before = s.stats.pinned;
    else pinned_before = std::max(pinned_before, s.stats.pinned);
  }
  ASSERT_EQ(events.size(), 1u);
  EXPECT_STREQ(events[0].kind, "puncture");
  EXPECT_GE(events[0].force, mat.puncture_force);
  EXPECT_GT(pinned_before, 0);
  EXPECT_LT(peak, mat.puncture_force) << "no tick before it reached the puncture force";
  // Through: pushed on, the patch no longer pushes back (friction and the pop only).
  for (int k = 0; k < 200; ++k) needle.position.y() -= 5e-6, step(m, s, needle, kDt, 0);
  const Vec3 through = step(m, s, needle, kDt, 0);
  EXPECT_LT(std::abs(through.y()), mat.friction_per_length * mat.thickness + 1e-9);
}

// From a scene: `force_model: coulomb` is read, a wrong value is refused naming the line and the
// choices, and a run through the safety filter sends only finite forces within the device's limits.
TEST(ChargedCoulomb, AScenesCoulombLayerRunsBehindTheSafetyFilter) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "palpate_coulomb_scene";
  std::filesystem::create_directories(dir);
  auto scene_text = [](const std::string& model) {
    return "name: coulomb\nduration: 2.0\ndt: 0.001\noutput: out/coulomb\n"
           "tool: {kind: needle, radius: 0.0004, length: 0.05}\n"
           "device:\n  kind: scripted\n  max_force: 3.3\n  waypoints:\n"
           "    - {t: 0.0, position: [0.0002, 0.004, 0.0001]}\n"
           "    - {t: 2.0, position: [0.0002, -0.006, 0.0001]}\n"
           "tissues:\n  - name: skin\n    model: charged_particles\n"
           "    patch: {shape: flat, width: 0.03, height: 0.03, spacing: 0.001, center: [0, 0, 0], normal: [0, 1, 0]}\n"
           "    material:\n      force_model: " + model + "\n      puncture_force: 1.0\n";
  };
  {
    std::ofstream(dir / "bad.yaml") << scene_text("coulombic");
    auto bad = load_scene(dir / "bad.yaml");
    ASSERT_FALSE(bad.ok());
    EXPECT_NE(bad.error().message.find("bad.yaml:17"), std::string::npos) << bad.error().message;
    EXPECT_NE(bad.error().message.find("force_model"), std::string::npos) << bad.error().message;
    EXPECT_NE(bad.error().message.find("indentation"), std::string::npos) << bad.error().message;
    EXPECT_NE(bad.error().message.find("coulomb"), std::string::npos) << bad.error().message;
  }
  std::ofstream(dir / "good.yaml") << scene_text("coulomb");
  auto scene = load_scene(dir / "good.yaml");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  ASSERT_EQ(scene->tissues.size(), 1u);
  EXPECT_EQ(scene->tissues[0].charged.force_model, "coulomb");
  RunOptions o;
  o.out = dir / "out";
  o.plots = false;
  double largest = 0;
  bool finite = true;
  o.series_row = [&](std::span<const double> row) {
    const Vec3 f(row[4], row[5], row[6]);
    finite = finite && f.allFinite();
    largest = std::max(largest, f.norm());
  };
  auto r = run_scene(*scene, o);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_TRUE(finite);
  EXPECT_GT(largest, 0.1) << "the layer is felt";
  EXPECT_LE(largest, 3.3 * (1 + 1e-12));
  EXPECT_EQ(std::count_if(r->events.begin(), r->events.end(), [](const RunEvent& e) { return e.kind == "puncture"; }), 1);
  std::filesystem::remove_all(dir);
}
