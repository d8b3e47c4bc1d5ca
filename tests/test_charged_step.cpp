// test_charged_step.cpp — the charged-particle step: contact, invariants, continuity, monotonicity,
// symmetry, release, puncture at its threshold, and the force laws (after puncture: test_charged_puncture.cpp).
#include "charged_fixtures.h"

using namespace palpate;
using namespace charged_test;

TEST(ChargedStep, NoForceNoDisplacementOutsideEverySphereOfInfluence) {
  ChargedModel m = flat(0.02);
  ChargedState s = make_charged_state(m);
  const double R = m.material.particle_radius, D = m.material.max_displacement;  // a HIP of radius 0
  // Above the surface by R or more, beside the patch, and under it deeper than D (a tool that
  // starts there is under the layer, not pressing it).
  for (const Vec3& p : {Vec3(0, R * 1.0001, 0), Vec3(0.0105 + R, 0, 0), Vec3(0, -D - R * 1.001, 0.003),
                        Vec3(0.02, 0.02, 0.02), Vec3(-0.004, 0.0041, 0.002)}) {
    for (int t = 0; t < 50; ++t) {
      const Vec3 f = step(m, s, hip_at(p), kDt);
      ASSERT_EQ(f, Vec3::Zero()) << p.transpose();
    }
    EXPECT_EQ(s.active_count, 0u);
    EXPECT_EQ(max_displacement(m, s), 0.0);
    EXPECT_EQ(s.stats.contacts, 0);
  }
  // Just inside: a contact, a push, a repulsive (upward) force.
  const int c = central_particle(m);
  const Vec3 f = step(m, s, hip_at(m.origin(size_t(c)) + Vec3(0, 0.999 * R, 0)), kDt);
  EXPECT_GT(f.y(), 0.0);
  EXPECT_GT(s.active_count, 0u);
}

TEST(ChargedStep, DisplacementAndSeparationBoundsHoldAfterEveryTick) {
  ChargedMaterialDef mat;
  mat.puncture_force = 2.5;
  for (const char* shape : {"flat", "sphere"}) {
    PatchDef p;
    p.shape = shape, p.width = p.height = 0.024, p.radius = 0.03;
    auto built = build_charged_patch(p, mat);
    ASSERT_TRUE(built.ok());
    const ChargedModel& m = *built;
    ChargedState s = make_charged_state(m);
    const double D = mat.max_displacement, S = m.max_separation;
    double worst_d = 0, worst_s = 0;
    int punctures = 0;
    // Press in, sweep sideways in a circle at depth, press deeper, withdraw: 3000 ticks.
    for (int t = 0; t < 3000; ++t) {
      // A continuous path (the tool drags the particles along; a jump would land it under them).
      const double a = std::clamp(t - 1000, 0, 1000) * 0.004;
      Vec3 h(0.003 * std::sin(a), -0.002, 0.003 * (1 - std::cos(a)));
      if (t < 1000) h = Vec3(0, 0.004 - t * 6e-6, 0);
      else if (t >= 2000) h.y() = -0.002 - (t - 2000) * 4e-6;
      ChargedHip blunt = hip_at(h);
      blunt.sharp = false;  // pressed past max_displacement without puncturing: every bound is met
      step(m, s, blunt, kDt);
      TissueEvent ev[4];
      for (size_t k = drain_events(s, ev), j = 0; j < k; ++j) punctures += std::strcmp(ev[j].kind, "puncture") == 0;
      worst_d = std::max(worst_d, max_displacement(m, s));
      worst_s = std::max(worst_s, max_neighbour_distance(m, s));
      ASSERT_LE(worst_d, D * (1 + 1e-5)) << shape << " tick " << t;
      ASSERT_LE(worst_s, S * (1 + 2e-5)) << shape << " tick " << t;
      ASSERT_EQ(s.stats.propagation_overflows, 0);
    }
    EXPECT_GT(worst_d, 0.99 * D * std::exp(-mat.elasticity * kDt)) << shape << ": the path never reached max_displacement";
    EXPECT_GT(worst_s, 0.99 * S) << shape << ": the separation rule was never exercised";
    EXPECT_EQ(punctures, 0) << shape << ": a blunt tool never punctures";
  }
}

TEST(ChargedStep, ForceIsContinuousAlongAPathIntoAndAcrossThePatch) {
  ChargedMaterialDef mat;
  mat.puncture_force = 100;  // a stiff patch; the path stays shallower than max_displacement
  ChargedModel m = flat(0.03, 0.001, mat);
  ChargedState s = make_charged_state(m);
  // The force is Φ(δ) along the normal, δ a 1-Lipschitz function of the HIP: no step may change
  // it by more than the law's steepest slope on the path times the step's length.
  const double max_slope = (charged_contact_force(mat, 0.0035) - charged_contact_force(mat, 0.0035 - 1e-7)) / 1e-7;
  double worst = 0, peak = 0, longest = 0;
  Vec3 prev = Vec3::Zero(), prev_h = Vec3::Zero();
  const Vec3 a(-0.008, 0.006, 0.001), b(-0.004, -0.002, 0.001), c(0.008, -0.002, -0.002);
  const int n = 4000;
  for (int t = 0; t <= 2 * n; ++t) {
    const Vec3 h = t <= n ? a + (b - a) * (double(t) / n) : b + (c - b) * (double(t - n) / n);
    const Vec3 f = step(m, s, hip_at(h), kDt);
    if (t > 0) worst = std::max(worst, (f - prev).norm()), longest = std::max(longest, (h - prev_h).norm());
    peak = std::max(peak, f.norm());
    prev = f, prev_h = h;
  }
  EXPECT_GT(peak, 10.0) << "the path must press into the patch";
  EXPECT_LT(worst, 1.001 * max_slope * longest) << "largest change of force in one 2-3 µm step";
}

// Before puncture the force may never fall while the needle presses on (grit), at any spacing;
// the test allows no tolerance at all.
TEST(ChargedStep, ForceGrowsMonotonicallyWithIndentationUntilPuncture) {
  for (double spacing : {0.0005, 0.001, 0.002}) {
    ChargedModel m = flat(0.03, spacing);
    ChargedState s = make_charged_state(m);
    const Vec3 at = m.origin(size_t(central_particle(m))) + Vec3(0.00013, 0, 0.00029);
    std::vector<TissueEvent> events;
    std::vector<double> fy;
    for (const Vec3& f : press(m, s, at, 0.005, -0.006, 2e-6, &events)) fy.push_back(f.y());
    ASSERT_FALSE(events.empty());
    const size_t puncture_tick = size_t(std::lround(events[0].time / kDt)) - 1;
    ASSERT_LT(puncture_tick, fy.size());
    for (size_t t = 1; t <= puncture_tick; ++t) ASSERT_GE(fy[t], fy[t - 1]) << "spacing " << spacing << " tick " << t;
    EXPECT_NEAR(fy[puncture_tick], m.material.puncture_force, 0.01 * m.material.puncture_force);
  }
}

TEST(ChargedStep, CentredProbeOnSymmetricPatchFeelsNoLateralForce) {
  ChargedMaterialDef mat;
  mat.puncture_force = 100;
  ChargedModel m = flat(0.03, 0.001, mat);
  ChargedState s = make_charged_state(m);
  const Vec3 at = m.origin(size_t(central_particle(m)));
  double worst_ratio = 0, max_fy = 0;
  for (double y = 0.004; y >= -0.0025; y -= 5e-6) {
    const Vec3 f = step(m, s, hip_at(Vec3(at.x(), y, at.z())), kDt);
    max_fy = std::max(max_fy, f.y());
    if (f.y() > 0.05) worst_ratio = std::max(worst_ratio, std::hypot(f.x(), f.z()) / f.y());
  }
  EXPECT_GT(max_fy, 0.5);
  // The force is along the surface's normal: a probe pressed straight in is not pushed aside,
  // whatever order the separation rule met the particles in.
  EXPECT_EQ(worst_ratio, 0.0);
}

TEST(ChargedStep, ReleasedParticlesReturnToOriginsAtTheElasticityRate) {
  ChargedModel m = flat(0.02);
  ChargedState s = make_charged_state(m);
  const Vec3 at = m.origin(size_t(central_particle(m)));
  press(m, s, at, 0.004, -0.003, 1e-5);  // 4.1 mm dimple (D = 5 mm), no puncture
  ASSERT_TRUE(drain_events(s, std::span<TissueEvent>()) == 0 && s.event_count == 0);
  step(m, s, hip_at(Vec3(0, 0.05, 0)), kDt);  // the HIP leaves
  const double d0 = max_displacement(m, s);
  ASSERT_GT(d0, 0.003);
  const double lambda = m.material.elasticity, alpha = std::exp(-lambda * kDt);
  // dp/dt = −λ (p − o): after k ticks every displacement is the released one times α^k.
  for (int k = 1; k <= 100; ++k) {
    step(m, s, hip_at(Vec3(0, 0.05, 0)), kDt);
    ASSERT_NEAR(max_displacement(m, s), d0 * std::pow(alpha, k), 1e-6 * d0 + 1e-9) << "tick " << k;
  }
  // All home (settled to within 1e-4 spacing, then snapped) by t = ln(d0 / settle) / λ, not long before.
  const double settle = 1e-4 * m.spacing;
  const int home_ticks = int(std::ceil(std::log(d0 / settle) / (lambda * kDt)));
  for (int k = 101; k < int(0.9 * home_ticks); ++k) step(m, s, hip_at(Vec3(0, 0.05, 0)), kDt);
  EXPECT_GT(s.active_count, 0u);
  for (int k = int(0.9 * home_ticks); k <= home_ticks + 1; ++k) step(m, s, hip_at(Vec3(0, 0.05, 0)), kDt);
  EXPECT_EQ(s.active_count, 0u);
  EXPECT_EQ(max_displacement(m, s), 0.0);
}

TEST(ChargedStep, ZeroElasticityStaysWherePushed) {
  ChargedMaterialDef mat;
  mat.elasticity = 0;
  ChargedModel m = flat(0.02, 0.001, mat);
  ChargedState s = make_charged_state(m);
  press(m, s, m.origin(size_t(central_particle(m))), 0.004, -0.0035, 1e-5);
  step(m, s, hip_at(Vec3(0, 0.05, 0)), kDt);
  const ChargedState before = s;
  for (int k = 0; k < 500; ++k) step(m, s, hip_at(Vec3(0, 0.05, 0)), kDt);
  EXPECT_EQ(s.x, before.x);
  EXPECT_EQ(s.y, before.y);
  EXPECT_GT(max_displacement(m, s), 0.004);
}

TEST(ChargedStep, PunctureHappensAtTheThresholdAndNotBefore) {
  for (double threshold : {0.8, 1.5, 2.2}) {
    ChargedMaterialDef mat;
    mat.puncture_force = threshold;
    ChargedModel m = flat(0.03, 0.001, mat);
    ChargedState s = make_charged_state(m);
    std::vector<TissueEvent> events;
    std::vector<double> fy;  // |force| per tick
    const std::vector<Vec3> f = press(m, s, m.origin(size_t(central_particle(m))), 0.005, -0.006, 2e-6, &events);
    for (const Vec3& v : f) fy.push_back(v.norm());
    ASSERT_GE(events.size(), 1u);
    EXPECT_STREQ(events[0].kind, "puncture");
    EXPECT_EQ(events[0].tissue, 0);
    const size_t tick = size_t(std::lround(events[0].time / kDt)) - 1;
    for (size_t t = 0; t < tick; ++t) ASSERT_LT(fy[t], threshold) << "tick " << t;
    EXPECT_GE(fy[tick], threshold * 0.995);
    EXPECT_LT(fy[tick], threshold * 1.01);  // slow press: the peak is the threshold, give or take a step
    EXPECT_DOUBLE_EQ(events[0].force, fy[tick]);
    // The HIP is D − R below the rest surface (an indentation of D).
    EXPECT_NEAR(events[0].depth, mat.max_displacement - mat.particle_radius, 3e-6);
    // The give: the layer lets go over puncture_time, never faster than a smoothstep of it; the
    // reversed charges then pull the tool on into the tissue (the snap) over as long, and let go.
    const size_t give_ticks = size_t(std::lround(mat.puncture_time / kDt));
    double steepest = 0;
    for (size_t t = tick + 1; t <= tick + give_ticks; ++t) steepest = std::max(steepest, fy[t - 1] - fy[t]);
    EXPECT_LE(steepest, 1.5 * threshold * kDt / mat.puncture_time * 1.01);
    ASSERT_GT(f.size(), tick + 3 * give_ticks);
    double snap = 0;
    for (size_t t = tick + give_ticks; t <= tick + 2 * give_ticks; ++t) snap = std::min(snap, f[t].y());
    EXPECT_NEAR(snap, -mat.snap_share * threshold, 0.01 * mat.snap_share * threshold);
    EXPECT_EQ(f[tick + 2 * give_ticks + 2], Vec3::Zero());  // no friction: the press has no velocity
  }
}

// The laws are C¹ everywhere they act: value and slope continuous at every joint, checked with
// one-sided differences; the contact law is monotone and reaches the puncture force at D.
TEST(ChargedStep, ForceLawsAreC1AndTheContactLawIsMonotone) {
  ChargedMaterialDef mat;
  mat.max_displacement = 0.006, mat.puncture_force = 2.0, mat.linear_share = 0.3;
  const double D = mat.max_displacement, R = 0.0015, h = 1e-9;
  auto phi = [&](double x) { return charged_contact_force(mat, x); };
  auto snap = [&](double x) { return charged_snap_force(mat, x); };
  auto track = [&](double x) { return charged_track_force(mat, x, R); };
  auto check_c1 = [&](auto f, double x, double scale, const char* name) {
    const double left = (f(x) - f(x - h)) / h, right = (f(x + h) - f(x)) / h;
    const double slope = std::max(std::abs(left), std::abs(right));
    EXPECT_LE(std::abs(f(x + h) - f(x - h)), 2 * h * slope * 1.01 + 1e-15) << name << " value at " << x;
    EXPECT_NEAR(left, right, 1e-3 * slope + 1e-5 * scale / R) << name << " slope at " << x;
  };
  for (double x : {0.0, 0.1 * D, D, 0.5 * D}) check_c1(phi, x, mat.puncture_force, "contact");
  const double tau = mat.puncture_time;
  for (double x : {tau, 1.5 * tau, 2 * tau}) check_c1(snap, x, mat.puncture_force * R / tau, "snap");
  for (double x : {0.0, R}) check_c1(track, x, mat.puncture_force, "track");
  EXPECT_DOUBLE_EQ(phi(D), mat.puncture_force);
  EXPECT_EQ(phi(0), 0.0);
  EXPECT_EQ(phi(-0.001), 0.0);
  for (double x = 1e-6; x < 1.5 * D; x += 1e-6) ASSERT_GT(phi(x), phi(x - 1e-6)) << x;
  // The linear term's share at puncture is what the material says.
  mat.linear_share = 1.0;
  EXPECT_NEAR(phi(0.5 * D), 0.5 * mat.puncture_force * (0.5 * D - 0.05 * D) / (0.5 * D) / 0.95 * 0.5 / 0.5 * (0.45 / 0.475) / (0.45 / 0.475), 0.03);
  mat.linear_share = 0.3;
  // The snap: ≥ 0, at most snap_share × F_p, zero outside (τ, 2τ); the track force odd and bounded.
  for (double x = 0; x < 3 * tau; x += tau / 1000) {
    ASSERT_GE(snap(x), 0.0);
    ASSERT_LE(snap(x), mat.snap_share * mat.puncture_force * (1 + 1e-12));
  }
  EXPECT_DOUBLE_EQ(snap(1.5 * tau), mat.snap_share * mat.puncture_force);
  EXPECT_EQ(snap(tau), 0.0);
  EXPECT_EQ(snap(2 * tau), 0.0);
  EXPECT_DOUBLE_EQ(track(-0.0004), -track(0.0004));
  EXPECT_LT(track(1.0), mat.puncture_force * (1 + 1e-12));
  EXPECT_NEAR((track(1e-9) - track(0)) / 1e-9, mat.puncture_force / R, 1e-3 * mat.puncture_force / R);
}
