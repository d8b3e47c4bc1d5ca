// test_charged_step.cpp — the charged-particle step: contact, invariants, continuity, monotonicity,
// symmetry, release, puncture, tracks, stacked layers, determinism, ChainMail cost, scale.
#include <palpate/charged.h>

#include <gtest/gtest.h>

#include <cmath>
#include <algorithm>
#include <cstring>
#include <string>
#include <vector>

using namespace palpate;

namespace {

constexpr double kDt = 0.001;

ChargedModel flat(double w, double spacing = 0.001, ChargedMaterialDef mat = {}, double y = 0) {
  PatchDef p;
  p.width = p.height = w, p.spacing = spacing, p.center = Vec3(0, y, 0);
  auto m = build_charged_patch(p, mat);
  EXPECT_TRUE(m.ok()) << m.error().message;
  return std::move(*m);
}

// The particle whose origin is nearest the patch centre's (x, z).
int central_particle(const ChargedModel& m) {
  int best = 0;
  double bd = 1e9;
  for (size_t i = 0; i < m.size(); ++i) {
    const Vec3 o = m.origin(i);
    const double d = std::hypot(o.x() - m.center.x(), o.z() - m.center.z());
    if (d < bd) bd = d, best = int(i);
  }
  return best;
}

ChargedHip hip_at(const Vec3& p) {
  ChargedHip h;
  h.position = p;
  return h;
}

double max_displacement(const ChargedModel& m, const ChargedState& s) {
  double d = 0;
  for (size_t i = 0; i < m.size(); ++i) d = std::max(d, (s.position(i) - m.origin(i)).norm());
  return d;
}

double max_neighbour_distance(const ChargedModel& m, const ChargedState& s) {
  double d = 0;
  std::array<int, 6> nb{};
  for (int i = 0; i < int(m.size()); ++i)
    for (int a = 0, k = m.neighbours_of(i, nb); a < k; ++a)
      d = std::max(d, (s.position(size_t(i)) - s.position(size_t(nb[size_t(a)]))).norm());
  return d;
}

// Press straight down above `at` from `y0` to `y1` in steps of `dy`; the force of every tick.
std::vector<Vec3> press(const ChargedModel& m, ChargedState& s, const Vec3& at, double y0, double y1,
                          double dy, std::vector<TissueEvent>* events = nullptr) {
  std::vector<Vec3> fy;
  for (double y = y0; y >= y1; y -= dy) {
    fy.push_back(step(m, s, hip_at(Vec3(at.x(), y, at.z())), kDt, 0));
    TissueEvent ev[8];
    const size_t n = drain_events(s, ev);
    if (events) events->insert(events->end(), ev, ev + n);
  }
  return fy;
}

}  // namespace

TEST(ChargedStep, NoForceNoDisplacementOutsideEverySphereOfInfluence) {
  ChargedModel m = flat(0.02);
  ChargedState s = make_charged_state(m);
  const double R = m.material.sphere_of_influence;
  // Above, beside and below the patch, each point at least R from every particle.
  for (const Vec3& p : {Vec3(0, R * 1.0001, 0), Vec3(0.0105 + R, 0, 0), Vec3(0, -R * 1.001, 0.003),
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
  mat.puncture_force = 2.5;  // strong enough that the path below also punctures once, late
  for (const char* shape : {"flat", "sphere"}) {
    PatchDef p;
    p.shape = shape, p.width = p.height = 0.024, p.radius = 0.03;
    auto built = build_charged_patch(p, mat);
    ASSERT_TRUE(built.ok());
    const ChargedModel& m = *built;
    ChargedState s = make_charged_state(m);
    const double D = mat.max_displacement, S = mat.max_separation;
    double worst_d = 0, worst_s = 0;
    int punctures = 0;
    // Press in, sweep sideways in a circle at depth, press deeper, withdraw: 3000 ticks.
    for (int t = 0; t < 3000; ++t) {
      const double a = t * 0.004;
      Vec3 h;
      if (t < 1000) h = Vec3(0, 0.004 - t * 6e-6, 0);
      else if (t < 2000) h = Vec3(0.003 * std::sin(a), -0.002, 0.003 * (1 - std::cos(a)));
      else h = Vec3(0.002, -0.002 - (t - 2000) * 4e-6, -0.001);
      step(m, s, hip_at(h), kDt);
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
    EXPECT_GE(punctures, 1) << shape;
  }
}

TEST(ChargedStep, ForceIsContinuousAlongAPathIntoAndAcrossThePatch) {
  ChargedMaterialDef mat;
  mat.puncture_force = 100;  // no puncture on this path
  ChargedModel m = flat(0.03, 0.001, mat);
  ChargedState s = make_charged_state(m);
  const double R = mat.sphere_of_influence;
  // A plain 1/r² law cut off at R jumps by k q q / R² (0.056 N here) when a particle enters.
  const double cutoff_jump = m.coulomb_kqq / (R * R);
  double worst = 0, peak = 0;
  Vec3 prev = Vec3::Zero();
  const Vec3 a(-0.008, 0.006, 0.001), b(-0.004, -0.002, 0.001), c(0.008, -0.002, -0.002);
  const int n = 4000;
  for (int t = 0; t <= 2 * n; ++t) {
    const Vec3 h = t <= n ? a + (b - a) * (double(t) / n) : b + (c - b) * (double(t - n) / n);
    const Vec3 f = step(m, s, hip_at(h), kDt);
    if (t > 0) worst = std::max(worst, (f - prev).norm());
    peak = std::max(peak, f.norm());
    prev = f;
  }
  EXPECT_GT(peak, 5 * cutoff_jump) << "the path must press into the patch";
  EXPECT_LT(worst, 0.1 * cutoff_jump) << "largest change of force in one 2-3 µm step";
}

TEST(ChargedStep, ForceGrowsMonotonicallyWithIndentationUntilPuncture) {
  ChargedModel m = flat(0.03);
  ChargedState s = make_charged_state(m);
  const Vec3 at = m.origin(size_t(central_particle(m)));
  std::vector<TissueEvent> events;
  std::vector<double> fy;
  for (const Vec3& f : press(m, s, at, 0.005, -0.006, 2e-6, &events)) fy.push_back(f.y());
  ASSERT_FALSE(events.empty());
  const size_t puncture_tick = size_t(std::lround(events[0].time / kDt)) - 1;
  ASSERT_LT(puncture_tick, fy.size());
  double prev = 0;
  for (size_t t = 0; t <= puncture_tick; ++t) {
    EXPECT_GE(fy[t], prev * (1 - 0.01) - 1e-9) << "tick " << t;  // within 1%: queue-order jitter
    prev = std::max(prev, fy[t]);
  }
  EXPECT_GE(fy[puncture_tick], m.material.puncture_force);
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
  // The lattice is six-fold symmetric about the probed particle; the separation rule's sequential
  // queue order breaks that only at the percent level.
  EXPECT_LT(worst_ratio, 0.03);
}

TEST(ChargedStep, ReleasedParticlesReturnToOriginsAtTheElasticityRate) {
  ChargedModel m = flat(0.02);
  ChargedState s = make_charged_state(m);
  const Vec3 at = m.origin(size_t(central_particle(m)));
  press(m, s, at, 0.004, -0.0005, 1e-5);  // 4.5 mm dimple, no puncture
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
  press(m, s, m.origin(size_t(central_particle(m))), 0.004, -0.0005, 1e-5);
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
    EXPECT_GE(fy[tick], threshold);
    EXPECT_LT(fy[tick], threshold * 1.05);  // slow press: the peak is the threshold, give or take a step
    EXPECT_DOUBLE_EQ(events[0].force, fy[tick]);
    EXPECT_GT(events[0].depth, 0.0);
    // The drop and snap: right after the puncture the patch no longer pushes back; the reversed
    // charges pull the tool on into the tissue.
    EXPECT_GT(f[tick].y(), 0.0);
    EXPECT_LT(f[tick + 1].y(), 0.0);
  }
}

TEST(ChargedStep, AfterPunctureTheToolIsPulledTowardTheTrackAndFrictionResistsBothWays) {
  ChargedModel m = flat(0.03);
  ChargedState s = make_charged_state(m);
  const Vec3 at = m.origin(size_t(central_particle(m)));
  ChargedHip needle;
  needle.shaft_length = 0.05;
  std::vector<TissueEvent> events;
  double y = 0.005;
  for (; y > -0.006 && events.empty(); y -= 2e-6) {
    needle.position = Vec3(at.x(), y, at.z());
    step(m, s, needle, kDt);
    TissueEvent ev[4];
    events.insert(events.end(), ev, ev + drain_events(s, ev));
  }
  ASSERT_EQ(events.size(), 1u);
  // The snap: the next tick the reversed charges below pull the tip on, into the tissue.
  needle.position.y() -= 2e-6;
  const Vec3 snap = step(m, s, needle, kDt);
  EXPECT_LT(snap.y(), 0.0);
  // The tip goes through and on; the shaft stays in the hole and the particles settle back.
  for (int k = 0; k < 400; ++k) needle.position.y() -= 2e-5, step(m, s, needle, kDt);
  EXPECT_LT(needle.position.y(), -0.008);
  // Pushed sideways, the shaft is pulled back toward the track, either side.
  for (double side : {+1.0, -1.0}) {
    ChargedState moved = s;
    needle.position.x() = at.x() + side * 0.0005;
    const Vec3 f = step(m, moved, needle, kDt);
    EXPECT_LT(f.x() * side, -1e-4) << "side " << side;
  }
  needle.position.x() = at.x();
  // Moving along the track: friction opposes the motion, in both directions.
  for (double v : {-0.01, 0.01}) {
    ChargedState moving = s;
    needle.velocity = Vec3(0, v, 0);
    const Vec3 f = step(m, moving, needle, kDt);
    EXPECT_NEAR(f.y(), -std::copysign(m.material.track_friction * std::tanh(0.01 / 0.001), v), 0.02) << v;
  }
}

TEST(ChargedStep, StackedLayersPunctureInOrderEachWithItsOwnPeak) {
  // Skin, fat, vessel wall: 8 mm apart, different thresholds; one needle pressed slowly through all.
  const double thresholds[3] = {1.6, 0.7, 1.1};
  std::vector<ChargedModel> layers;
  for (int k = 0; k < 3; ++k) {
    ChargedMaterialDef mat;
    mat.puncture_force = thresholds[k];
    layers.push_back(flat(0.03, 0.001, mat, -0.008 * k));
  }
  std::vector<ChargedState> states;
  for (auto& l : layers) states.push_back(make_charged_state(l));
  const Vec3 at = layers[0].origin(size_t(central_particle(layers[0])));
  ChargedHip needle;
  needle.shaft_length = 0.08;
  std::vector<TissueEvent> events;
  std::vector<double> fy;
  for (double y = 0.005; y > -0.025; y -= 4e-6) {
    needle.position = Vec3(at.x(), y, at.z());
    Vec3 f = Vec3::Zero();
    for (int k = 0; k < 3; ++k) {
      f += step(layers[size_t(k)], states[size_t(k)], needle, kDt, k);
      TissueEvent ev[4];
      events.insert(events.end(), ev, ev + drain_events(states[size_t(k)], ev));
    }
    fy.push_back(f.y());
  }
  std::vector<TissueEvent> punctures;
  for (auto& e : events) if (std::strcmp(e.kind, "puncture") == 0) punctures.push_back(e);
  ASSERT_EQ(punctures.size(), 3u);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(punctures[size_t(k)].tissue, k);
    if (k > 0) {
      EXPECT_GT(punctures[size_t(k)].time, punctures[size_t(k - 1)].time);
    }
    EXPECT_GE(punctures[size_t(k)].force, thresholds[k]);
    EXPECT_LT(punctures[size_t(k)].force, thresholds[k] * 1.05);
    // Each peak is followed by a drop.
    const size_t tick = size_t(std::lround(punctures[size_t(k)].time / kDt)) - 1;
    EXPECT_LT(fy[tick + 1], fy[tick] - 0.5 * thresholds[k]) << "layer " << k;
  }
}

TEST(ChargedStep, SameInputGivesBitIdenticalResults) {
  ChargedModel m = flat(0.03);
  auto run = [&](ChargedState& s) {
    std::vector<double> out;
    ChargedHip h;
    h.shaft_length = 0.04;
    for (int t = 0; t < 3000; ++t) {
      h.position = Vec3(0.002 * std::sin(t * 0.003), 0.004 - t * 3e-6, 0.001 * std::cos(t * 0.005));
      h.velocity = Vec3(0, -0.003, 0);
      const Vec3 f = step(m, s, h, kDt, 0);
      out.insert(out.end(), {f.x(), f.y(), f.z()});
    }
    return out;
  };
  ChargedState a = make_charged_state(m), b = make_charged_state(m);
  const auto fa = run(a), fb = run(b);
  ASSERT_EQ(fa.size(), fb.size());
  EXPECT_EQ(std::memcmp(fa.data(), fb.data(), fa.size() * sizeof(double)), 0);
  EXPECT_EQ(a.x, b.x);
  EXPECT_EQ(a.y, b.y);
  EXPECT_EQ(a.z, b.z);
  EXPECT_EQ(a.flags, b.flags);
  reset(m, a);
  const auto fr = run(a);
  EXPECT_EQ(std::memcmp(fa.data(), fr.data(), fa.size() * sizeof(double)), 0);
}

TEST(ChargedStep, ChainMailCostFollowsTheDisturbanceNotThePatch) {
  ChargedMaterialDef mat;
  mat.puncture_force = 100;
  // Patches of 101 x 117 and 1001 x 1157 particles: both with an odd column count and rows ≡ 1
  // (mod 4), so the lattice around the centre is the same site for site, with bit-identical
  // coordinates (model.cpp lays particles by integer offsets from the centre).
  auto cost = [&](int cols, int rows) {
    PatchDef p;
    p.spacing = 0.001;
    p.width = (cols - 1) * p.spacing + 1e-7;
    p.height = (rows - 1) * p.spacing * std::sqrt(3.0) / 2 + 1e-7;
    auto built = build_charged_patch(p, mat);
    EXPECT_TRUE(built.ok());
    const ChargedModel& m = *built;
    EXPECT_EQ(m.cols, cols);
    EXPECT_EQ(m.rows, rows);
    ChargedState s = make_charged_state(m);
    const Vec3 at = m.origin(size_t((rows / 2) * cols + cols / 2));
    long visits = 0, candidates = 0;
    for (double y = 0.005; y >= -0.002; y -= 1e-5) {  // from above contact to 2 mm below the rest surface
      step(m, s, hip_at(Vec3(at.x(), y, at.z())), kDt);
      visits += s.stats.propagation_visits;
      candidates += s.stats.candidates;
    }
    return std::tuple{m.size(), visits, candidates, s.active_count};
  };
  const auto [n_small, v_small, c_small, a_small] = cost(101, 117);
  const auto [n_large, v_large, c_large, a_large] = cost(1001, 1157);
  EXPECT_GT(n_small, 10000u);
  EXPECT_GT(n_large, 1000000u);
  EXPECT_GT(v_small, 1000);
  EXPECT_EQ(v_small, v_large);
  EXPECT_EQ(c_small, c_large);
  EXPECT_EQ(a_small, a_large);
}

TEST(ChargedStep, ScalingLengthsAndChargesTogetherLeavesForcesUnchanged) {
  // F = k q² (1/r² − 1/R²): lengths × s with charges × s keeps every force; nothing in the model
  // may depend on an absolute length.
  ChargedMaterialDef base;
  base.puncture_force = 100;
  std::vector<std::vector<double>> forces;
  // Powers of two scale every float and double exactly, so the forces must be bit-identical.
  for (double scale : {1.0 / 64, 1.0, 64.0}) {
    ChargedMaterialDef mat = base;
    mat.max_displacement *= scale, mat.sphere_of_influence *= scale, mat.max_separation *= scale;
    mat.particle_charge *= scale, mat.hip_charge *= scale, mat.friction_velocity *= scale;
    ChargedModel m = flat(0.02 * scale, 0.001 * scale, mat);
    ChargedState s = make_charged_state(m);
    const Vec3 at = m.origin(size_t(central_particle(m)));
    std::vector<double> f;
    for (int t = 0; t < 800; ++t)
      f.push_back(step(m, s, hip_at(Vec3(at.x(), (0.004 - t * 7e-6) * scale, at.z())), kDt).y());
    forces.push_back(f);
  }
  double peak = 0;
  for (double f : forces[1]) peak = std::max(peak, f);
  ASSERT_GT(peak, 0.15);
  EXPECT_EQ(forces[0], forces[1]);
  EXPECT_EQ(forces[2], forces[1]);
}

TEST(ChargedStep, NonFiniteInputIsRecoveredWithZeroForceAndAReset) {
  ChargedModel m = flat(0.02);
  ChargedState s = make_charged_state(m);
  press(m, s, m.origin(size_t(central_particle(m))), 0.004, 0.0, 1e-5);
  ASSERT_GT(s.active_count, 0u);
  const Vec3 f = step(m, s, hip_at(Vec3(std::nan(""), 0, 0)), kDt, 3);
  EXPECT_EQ(f, Vec3::Zero());
  EXPECT_EQ(s.active_count, 0u);
  EXPECT_EQ(s.stats.numeric_resets, 1);
  TissueEvent ev[2];
  ASSERT_EQ(drain_events(s, ev), 1u);
  EXPECT_STREQ(ev[0].kind, "reset");
  EXPECT_EQ(ev[0].tissue, 3);
}

TEST(ChargedStep, RepulsionAndAttractionLawsAreContinuous) {
  const double kqq = 1e-6, R = 0.004;
  EXPECT_EQ(charged_repulsion(kqq, R, R), 0.0);
  EXPECT_NEAR(charged_repulsion(kqq, R * (1 - 1e-9), R), 0.0, 1e-9);
  EXPECT_NEAR(charged_repulsion(kqq, R / 2, R), kqq * 3 / (R * R), 1e-12);
  EXPECT_EQ(charged_repulsion(kqq, 0.01 * R, R), charged_repulsion(kqq, 0.1 * R, R));  // saturates
  for (double r = 0.11 * R; r < R; r += 0.01 * R) EXPECT_GT(charged_repulsion(kqq, r - 0.005 * R, R), charged_repulsion(kqq, r, R));
  EXPECT_EQ(charged_attraction(kqq, 0, R), 0.0);
  EXPECT_NEAR(charged_attraction(kqq, 0.5 * R * (1 - 1e-9), R), charged_attraction(kqq, 0.5 * R, R), 1e-6);
  EXPECT_NEAR(charged_attraction(kqq, 0.25 * R, R), 0.5 * charged_attraction(kqq, 0.5 * R, R), 1e-9);
}

TEST(ChargedStep, AHoleStaysOpenOrClosesAsTheMaterialSays) {
  for (bool closes : {false, true}) {
    ChargedMaterialDef mat;
    mat.hole_closes = closes;
    ChargedModel m = flat(0.03, 0.001, mat);
    ChargedState s = make_charged_state(m);
    const Vec3 at = m.origin(size_t(central_particle(m)));
    ChargedHip needle;
    needle.shaft_length = 0.05;
    std::vector<std::string> kinds;
    double second_peak = 0;
    auto move = [&](double y, bool second) {
      needle.position = Vec3(at.x(), y, at.z());
      const Vec3 f = step(m, s, needle, kDt);
      if (second) second_peak = std::max(second_peak, f.y());
      TissueEvent ev[4];
      for (size_t k = drain_events(s, ev), j = 0; j < k; ++j) kinds.push_back(ev[j].kind);
    };
    for (double y = 0.005; y > -0.006; y -= 4e-6) move(y, false);   // in and through
    for (double y = -0.006; y < 0.010; y += 4e-6) move(y, false);   // all the way out
    for (int k = 0; k < 500; ++k) move(0.010, false);                // the patch relaxes
    for (double y = 0.005; y > -0.006; y -= 4e-6) move(y, true);    // the same track again
    ASSERT_GE(kinds.size(), 2u);
    EXPECT_EQ(kinds[0], "puncture");
    EXPECT_EQ(kinds[1], "exit");
    const long punctures = std::count(kinds.begin(), kinds.end(), std::string("puncture"));
    if (closes) {
      EXPECT_EQ(punctures, 2) << "a closed hole must be punctured again";
      EXPECT_GE(second_peak, mat.puncture_force);
    } else {
      EXPECT_EQ(punctures, 1) << "an open hole lets the needle through";
      EXPECT_LT(second_peak, 0.2 * mat.puncture_force);
    }
  }
}

// A needle pushed straight in off a lattice point (an irregular ring of reversed charges): once
// in the track, it feels the pull along its axis and friction, but no sideways force — a hand
// holding a needle on its line must not be pushed aside.
TEST(ChargedStep, NeedleOnItsTrackFeelsNoSidewaysForce) {
  ChargedModel m = flat(0.03);
  ChargedState s = make_charged_state(m);
  const Vec3 at = m.origin(size_t(central_particle(m))) + Vec3(0.00031, 0, 0.00017);
  ChargedHip needle;
  needle.shaft_length = 0.05;
  needle.velocity = Vec3(0, -0.01, 0);
  bool punctured = false;
  double worst_lateral = 0, largest = 0;
  for (double y = 0.005; y > -0.012; y -= 1e-5) {
    needle.position = Vec3(at.x(), y, at.z());
    const Vec3 f = step(m, s, needle, kDt);
    if (punctured) {  // from the tick after the puncture on
      worst_lateral = std::max(worst_lateral, std::hypot(f.x(), f.z()));
      largest = std::max(largest, f.norm());
    }
    TissueEvent ev[4];
    punctured = punctured || drain_events(s, ev) > 0;
  }
  ASSERT_TRUE(punctured);
  EXPECT_GT(largest, 0.05);
  EXPECT_LT(worst_lateral, 1e-9) << "largest force after puncture " << largest;
}
