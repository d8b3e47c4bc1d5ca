// test_charged_puncture.cpp — the charged step after puncture: the track, shaft friction, stacked
// layers and vessel walls, holes, tilting, and the step's determinism and cost.
#include "charged_fixtures.h"

using namespace palpate;
using namespace charged_test;

TEST(ChargedStep, AfterPunctureTheToolIsPulledTowardTheTrackAndFrictionResistsBothWays) {
  ChargedMaterialDef mat;
  mat.thickness = 0.01;  // a thick layer: the shaft inside it grows over the whole insertion below
  ChargedModel m = flat(0.03, 0.001, mat);
  ChargedState s = make_charged_state(m);
  const Vec3 at = m.origin(size_t(central_particle(m)));
  ChargedHip needle;
  needle.shaft_length = 0.05;
  needle.velocity = Vec3(0, -0.002, 0);
  std::vector<TissueEvent> events;
  double y = 0.005;
  for (; y > -0.006 && events.empty(); y -= 2e-6) {
    needle.position = Vec3(at.x(), y, at.z());
    step(m, s, needle, kDt);
    TissueEvent ev[4];
    events.insert(events.end(), ev, ev + drain_events(s, ev));
  }
  ASSERT_EQ(events.size(), 1u);
  // The tip goes on through, past the pop; the shaft stays in the hole.
  for (int k = 0; k < 1000; ++k) needle.position.y() -= 2e-6, step(m, s, needle, kDt);
  // Pushed sideways, the shaft is pulled back toward the track, either side, with the track's
  // law F_p·tanh(offset/R), and nothing else sideways.
  const double R = mat.particle_radius;
  for (double side : {+1.0, -1.0}) {
    ChargedState moved = s;
    ChargedHip off = needle;
    off.position.x() = at.x() + side * 0.0005;
    const Vec3 f = step(m, moved, off, kDt);
    EXPECT_NEAR(f.x() * side, -mat.puncture_force * std::tanh(0.0005 / R), 1e-9) << "side " << side;
  }
  // Moving along the track at steady speed: Dahl friction saturates at friction_per_length times
  // the shaft inside the layer, against the motion, in both directions.
  for (double v : {-0.01, 0.01}) {
    ChargedState moving = s;
    ChargedHip n2 = needle;
    n2.velocity = Vec3(0, v, 0);
    Vec3 f;
    for (int k = 0; k < 300; ++k) f = step(m, moving, n2, kDt);  // 3 mm of travel: ten presliding lengths
    const double inside = moving.stats.shaft_in_layer;
    EXPECT_NEAR(inside, at.y() - needle.position.y(), 1e-9);
    // Saturated to within 2e^(−10) of the kinetic value after ten presliding lengths.
    EXPECT_NEAR(f.y(), -std::copysign(mat.friction_per_length * inside, v), 1e-4 * mat.friction_per_length * inside) << v;
  }
}

// Friction along the shaft grows with the length inside each layer (Okamura 2004), reverses
// smoothly with direction over the presliding length, and is a function of travel, not of time.
TEST(ChargedStep, ShaftFrictionGrowsWithTheLengthInsideAndReversesSmoothly) {
  ChargedMaterialDef mat;
  mat.thickness = 0.008, mat.friction_per_length = 80, mat.max_displacement = 0.003;
  for (double dt : {0.0005, 0.001, 0.002}) {
    ChargedModel m = flat(0.03, 0.001, mat);
    ChargedState s = make_charged_state(m);
    ChargedHip needle;
    needle.shaft_length = 0.06;
    const double v = 0.01;
    needle.velocity = Vec3(0, -v, 0);
    std::vector<double> inside, fy;
    bool punctured = false;
    double t_puncture = 0;
    const int ticks = int(std::lround(1.6 / dt));
    for (int k = 0; k < ticks; ++k) {
      const double t = k * dt;
      needle.position = Vec3(0.0002, 0.004 - v * t, 0.0001);
      const Vec3 f = step(m, s, needle, dt);
      TissueEvent ev[4];
      if (!punctured && drain_events(s, ev) > 0) punctured = true, t_puncture = t;
      // After the give and once the bristle has saturated (10 presliding lengths of travel).
      if (punctured && t > t_puncture + mat.puncture_time + 10 * mat.friction_presliding / v)
        inside.push_back(s.stats.shaft_in_layer), fy.push_back(f.y());
    }
    ASSERT_TRUE(punctured);
    ASSERT_GT(inside.size(), 100u);
    for (size_t k = 0; k < inside.size(); ++k)
      ASSERT_NEAR(fy[k], mat.friction_per_length * inside[k], 1e-4 * mat.friction_per_length * inside[k] + 1e-9)
          << "dt " << dt << " k " << k;
    EXPECT_NEAR(inside.back(), mat.thickness, 1e-9);
    EXPECT_LT(inside.front(), inside.back() - 0.002);  // it grew over the window
    // Reversal: pulled back out at the same speed, the friction goes from +F to −F smoothly over
    // a few presliding lengths of travel (the same travel at every dt), never jumping.
    const double F = fy.back();
    needle.velocity = Vec3(0, v, 0);
    double prev = F, worst = 0, travel_to_zero = -1;
    const double y0 = needle.position.y();
    for (int k = 0; k < int(std::lround(0.003 / (v * dt))); ++k) {
      needle.position.y() += v * dt;
      const double f = step(m, s, needle, dt).y();
      worst = std::max(worst, std::abs(f - prev));
      if (travel_to_zero < 0 && f <= 0) travel_to_zero = needle.position.y() - y0;
      prev = f;
    }
    EXPECT_NEAR(prev, -F, 0.01 * F) << dt;
    // z: +z0 → −z0 as z0(2e^(−x/z0) − 1): zero at x = z0·ln 2.
    EXPECT_NEAR(travel_to_zero, mat.friction_presliding * std::log(2.0), v * dt + 1e-9) << dt;
    EXPECT_LT(worst, 2 * F * v * dt / mat.friction_presliding * 1.01) << dt;
  }
}

TEST(ChargedStep, StackedLayersPunctureInOrderEachWithItsOwnPeak) {
  // Skin, fat, vessel wall: 8 mm apart, different thresholds; one needle pressed slowly through all.
  const double thresholds[3] = {1.6, 0.7, 1.1};
  std::vector<ChargedModel> layers;
  for (int k = 0; k < 3; ++k) {
    ChargedMaterialDef mat;
    mat.puncture_force = thresholds[k];
    mat.friction_per_length = 0;  // the peaks and drops alone
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
    EXPECT_GE(punctures[size_t(k)].force, thresholds[k] * 0.995);
    EXPECT_LT(punctures[size_t(k)].force, thresholds[k] * 1.01);
    // Each peak is followed by a drop once the layer has given way.
    const size_t tick = size_t(std::lround(punctures[size_t(k)].time / kDt)) - 1;
    EXPECT_LT(fy[tick + 30], fy[tick] - 0.5 * thresholds[k]) << "layer " << k;
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
  // Φ depends on δ/D only: lengths × s (friction per length ÷ s) keeps every force; nothing in
  // the model may depend on an absolute length.
  ChargedMaterialDef base;
  base.puncture_force = 100;
  std::vector<std::vector<double>> forces;
  // Powers of two scale every float and double exactly, so the forces must be bit-identical.
  for (double scale : {1.0 / 64, 1.0, 64.0}) {
    ChargedMaterialDef mat = base;
    mat.max_displacement *= scale, mat.particle_radius *= scale, mat.thickness *= scale;
    mat.friction_per_length /= scale, mat.friction_presliding *= scale;
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
      EXPECT_GE(second_peak, mat.puncture_force * (1 - 1e-9));
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

// Layers press on each other: a skin-like layer pushed deep pushes the layer under it instead of
// passing through it, at equal and at different spacings; without the coupling it would cross.
TEST(ChargedStep, ALayerPushedDownPushesTheLayerBelowInsteadOfPassingThrough) {
  for (double lower_spacing : {0.001, 0.0005}) {
    for (bool coupled : {true, false}) {
      ChargedMaterialDef skin, fat;
      skin.max_displacement = 0.006, skin.puncture_force = 2.0;
      fat.max_displacement = 0.003, fat.puncture_force = 0.6, fat.max_strain = 0.8;
      const ChargedModel upper = flat(0.03, 0.001, skin, 0.0), lower = flat(0.03, lower_spacing, fat, -0.002);
      ChargedState su = make_charged_state(upper), sl = make_charged_state(lower);
      const ChargedLayer above[] = {{&upper, &su}};
      ChargedHip needle;
      needle.shaft_length = 0.05, needle.radius = 0.0004;
      const Vec3 at = upper.origin(size_t(central_particle(upper))) + Vec3(0.0001, 0, 0.0002);
      double worst_crossing = 0, lower_moved = 0;
      bool lower_punctured = false, upper_punctured = false;
      // Down until a layer punctures. Coupled, the lower one (3 mm) is covered by the upper one
      // (6 mm) and cannot be cut before it; uncoupled it goes first, under the intact upper layer.
      for (int t = 0; t <= 2000 && !lower_punctured && !upper_punctured; ++t) {
        needle.position = Vec3(at.x(), 0.0015 - t * 4e-6, at.z());
        step(upper, su, needle, kDt, 0);
        step(lower, sl, needle, kDt, 1, coupled ? std::span<const ChargedLayer>(above) : std::span<const ChargedLayer>());
        TissueEvent ev[4];
        upper_punctured = drain_events(su, ev) > 0;
        lower_punctured = drain_events(sl, ev) > 0;
        if (lower_punctured || upper_punctured) break;
        // Every lower particle against the upper particles above it (within half a spacing sideways).
        for (size_t a = 0; a < su.active_count; ++a) {
          const Vec3 p = su.position(size_t(su.active[a]));
          for (size_t j = 0; j < lower.size(); ++j) {
            const Vec3 q = sl.position(j);
            if (std::hypot(p.x() - q.x(), p.z() - q.z()) < 0.5 * lower_spacing)
              worst_crossing = std::max(worst_crossing, q.y() - p.y());
          }
        }
        lower_moved = std::max(lower_moved, max_displacement(lower, sl));
      }
      if (coupled) {
        EXPECT_TRUE(upper_punctured && lower_punctured) << "both give in the same tick: the lower was held at D";
      } else {
        EXPECT_TRUE(lower_punctured && !upper_punctured);
      }
      if (coupled) {
        // Within 5 % of the spacing: the separation rule, run after the press, may lift a pressed
        // particle slightly toward a neighbour the layer above does not reach.
        EXPECT_LT(worst_crossing, 0.05 * lower_spacing) << "spacing " << lower_spacing;
        EXPECT_GT(lower_moved, 0.002) << "the lower layer was pushed";
        // Carried past its own max_displacement by the layer above (never farther than that one's).
        EXPECT_LE(max_displacement(lower, sl), skin.max_displacement + 0.002);
        EXPECT_LE(max_neighbour_distance(lower, sl), lower.max_separation * (1 + 2e-5));
      } else {
        EXPECT_GT(worst_crossing, 0.0005) << "without the coupling the layers cross (the test can fail)";
      }
    }
  }
}

// Tilting the needle mid-insertion: the shaft leaves the skin's track, which pushes it back with
// the track's law; pushed on along the new axis, the needle punctures the next layer on its new
// line (the track moved). A Touch renders this as the force at the tip, without torque.
TEST(ChargedStep, TiltingTheNeedleMidInsertionPushesBackSidewaysAndMovesTheTrack) {
  ChargedMaterialDef skin_mat, wall_mat;
  wall_mat.puncture_force = 0.8;
  const ChargedModel skin = flat(0.03, 0.001, skin_mat, 0.0), wall = flat(0.03, 0.001, wall_mat, -0.012);
  ChargedState ss = make_charged_state(skin), sw = make_charged_state(wall);
  const ChargedLayer above[] = {{&skin, &ss}};
  ChargedHip needle;
  needle.radius = 0.0004, needle.shaft_length = 0.05;
  const Vec3 x0(0.0002, 0, 0.0001);
  const double v = 0.01, dt = kDt;
  auto tick = [&](const Vec3& tip, const Vec3& axis, const Vec3& vel) {
    needle.position = tip, needle.axis = axis, needle.velocity = vel;
    return Vec3(step(skin, ss, needle, dt, 0) + step(wall, sw, needle, dt, 1, above));
  };
  // Straight down through the skin to 7 mm below it (the wall's contact starts at 10.5 mm).
  Vec3 tip = x0 + Vec3(0, 0.004, 0);
  while (tip.y() > -0.007) tip.y() -= v * dt, tick(tip, Vec3(0, -1, 0), Vec3(0, -v, 0));
  ASSERT_TRUE(ss.holes[0].open);
  ASSERT_FALSE(sw.holes[0].open);
  const ChargedHole hole = ss.holes[0];
  // Tilt by 10° about the tip, held still, over 100 ms.
  const double theta = 10 * 3.14159265358979 / 180;
  Vec3 axis;
  Vec3 f;
  for (int k = 1; k <= 100; ++k) {
    const double a = theta * k / 100;
    axis = Vec3(std::sin(a), -std::cos(a), 0);
    f = tick(tip, axis, Vec3::Zero());
  }
  // Expected: F_p·tanh(e/R) back toward the track's line, e the shaft's offset from it at the hole;
  // the rest of the force (friction, held by the still needle) is along the needle.
  const Vec3 tail = tip - axis * needle.shaft_length, ab = tip - tail;
  const double s = std::clamp((hole.center - tail).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  Vec3 e = tail + s * ab - hole.center;
  e -= e.dot(hole.axis) * hole.axis;
  const double R = needle.radius + skin_mat.particle_radius;
  const Vec3 lateral = -skin_mat.puncture_force * std::tanh(e.norm() / R) * e.normalized();
  EXPECT_GT(lateral.norm(), 0.5) << "a 10° tilt 3.5 mm below the hole moves the shaft off its track";
  EXPECT_GT(lateral.x(), 0.0) << "the handle swung to −x: pushed back toward +x, to the track";
  EXPECT_LT((f - lateral).cross(axis).norm(), 1e-9) << "f " << f.transpose() << " expected lateral " << lateral.transpose();
  // On along the new axis: the wall is punctured on the new line, off the old one.
  for (int k = 0; k < 2000 && !sw.holes[0].open; ++k) tip += v * dt * axis, tick(tip, axis, v * axis);
  ASSERT_TRUE(sw.holes[0].open);
  const Vec3 c = sw.holes[0].center;
  EXPECT_LT(((c - tip) - (c - tip).dot(axis) * axis).norm(), 1e-9) << "on the new line";
  EXPECT_GT(std::hypot(c.x() - x0.x(), c.z() - x0.z()), 0.0008) << "off the old line";
  EXPECT_LT(sw.holes[0].axis.dot(axis), 1.0 + 1e-12);
  EXPECT_NEAR(sw.holes[0].axis.dot(axis), 1.0, 1e-12) << "the new track runs along the tilted needle";
}

// The seed's sphere of influence: the tool's radius plus the particle radius. A thicker tool meets
// the tissue earlier (by the difference in radius) and, at the same position, feels larger.
TEST(ChargedStep, AThickerToolMeetsTheTissueEarlierAndFeelsLarger) {
  ChargedMaterialDef mat;
  mat.puncture_force = 20;  // no puncture on this path
  const ChargedModel m = flat(0.03, 0.001, mat);
  std::vector<double> first_contact, force_at_2mm;
  for (double radius : {0.0004, 0.003}) {
    ChargedState s = make_charged_state(m);
    ChargedHip probe;
    probe.radius = radius, probe.sharp = false;
    double contact_y = 0, f2 = 0;
    for (double y = 0.01; y > -0.002; y -= 1e-6) {
      probe.position = Vec3(0.0002, y, 0.0001);
      const double f = step(m, s, probe, kDt).y();
      if (f > 0 && contact_y == 0) contact_y = y;
      if (std::abs(y - 0.002) < 5e-7) f2 = f;
    }
    first_contact.push_back(contact_y);
    force_at_2mm.push_back(f2);
    EXPECT_NEAR(contact_y, radius + mat.particle_radius, 2e-6) << radius;
  }
  EXPECT_NEAR(first_contact[1] - first_contact[0], 0.003 - 0.0004, 3e-6);
  EXPECT_EQ(force_at_2mm[0], 0.0) << "a thin needle 2 mm above the skin does not touch it";
  EXPECT_GT(force_at_2mm[1], 0.0);
  EXPECT_NEAR(force_at_2mm[1], charged_contact_force(mat, 0.003 + mat.particle_radius - 0.002), 1e-6);
}

// A vessel: a two-sided tube wall. A needle straight through it punctures the anterior wall from
// outside, crosses the lumen without resistance, is pushed back by the posterior wall from inside
// and punctures it too — each at the wall's puncture force.
TEST(ChargedStep, ATwoSidedVesselWallIsPuncturedInThenOut) {
  ChargedMaterialDef wall;
  wall.max_displacement = 0.002, wall.puncture_force = 0.8, wall.two_sided = true, wall.thickness = 0.0008;
  PatchDef tube;
  tube.shape = "cylinder", tube.radius = 0.006, tube.width = 0.95 * 2 * 3.14159265358979 * 0.006;
  // Axis along z through the origin; the patch's seam (5 % of the circumference) at the lower left,
  // away from the needle's path.
  tube.normal = Vec3(1, 1, 0).normalized();
  tube.height = 0.03, tube.spacing = 0.0005, tube.center = 0.006 * tube.normal;
  auto built = build_charged_patch(tube, wall);
  ASSERT_TRUE(built.ok()) << built.error().message;
  const ChargedModel& m = *built;  // walls at y = +6 mm and y = −6 mm above and below the axis
  ChargedState s = make_charged_state(m);
  ChargedHip needle;
  needle.radius = 0.00065, needle.shaft_length = 0.06, needle.velocity = Vec3(0, -0.01, 0);
  std::vector<TissueEvent> punctures;
  std::vector<std::pair<double, double>> fy;  // (tip y, force y)
  for (double y = 0.01; y > -0.011; y -= 1e-5) {
    needle.position = Vec3(0.0002, y, 0.0003);
    fy.push_back({y, step(m, s, needle, kDt).y()});
    TissueEvent ev[4];
    for (size_t n = drain_events(s, ev), j = 0; j < n; ++j)
      if (std::strcmp(ev[j].kind, "puncture") == 0) punctures.push_back(ev[j]);
  }
  ASSERT_EQ(punctures.size(), 2u) << "anterior, then posterior wall";
  for (const TissueEvent& e : punctures) EXPECT_NEAR(e.force, wall.puncture_force, 0.01 * wall.puncture_force);
  const double R = needle.radius + wall.particle_radius;
  EXPECT_NEAR(punctures[0].depth, wall.max_displacement - R, 2e-5);  // below the anterior wall
  EXPECT_NEAR(punctures[1].depth, wall.max_displacement - R, 2e-5);  // past the posterior wall, outward
  // In the lumen's middle nothing pushes sideways or back but the friction of the anterior wall.
  for (auto [y, f] : fy)
    if (std::abs(y) < 0.002) {
      ASSERT_LE(std::abs(f), wall.friction_per_length * wall.thickness * 1.001) << y;
    }
  // The posterior wall pushes back (up, against the needle) before it gives, and rises to F_p.
  double back = 0;
  for (auto [y, f] : fy)
    if (y < -0.004 && y > -(0.006 - R + wall.max_displacement) + 2e-5) back = std::max(back, f);
  EXPECT_GT(back, 0.9 * wall.puncture_force);
}
