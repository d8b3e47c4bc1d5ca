// test_charged_cut.cpp — cutting the charged-particle layer (src/tissue/charged/cut.cpp, step.cpp;
// docs/models/cutting.md): which links a blade cuts, the separation rule across a cut, the wound
// opening, the drag, the force's continuity and the energy at a cut, crossing cuts, bad blade poses,
// what a probe feels over a wound, reset, and random blade paths.
#include "charged_fixtures.h"

#include "core/blade_sweep.h"

#include <palpate/scene.h>
#include <palpate/surface.h>
#include <palpate/tissue.h>
#include <palpate/tissue_files.h>

#include <random>
#include <set>

namespace {

using namespace charged_test;

constexpr double kRate = 200.0;  // N/s, the safety filter's default rate limit

// A scalpel: edge upright (axis down), 8 mm long, thin.
ChargedHip blade_at(const Vec3& tip, double length = 0.008, const Vec3& axis = Vec3(0, -1, 0)) {
  ChargedHip h;
  h.position = tip, h.axis = axis, h.blade = true, h.edge_length = length, h.sharp = false, h.radius = 0.0005;
  return h;
}

// A 20 mm flat patch at y = 0 and the z halfway between its two middle rows (a cut line there
// crosses diagonal links only, at their midpoints: no particle lies on it).
struct Patch {
  ChargedModel m;
  ChargedState s;
  double z0 = 0;
  explicit Patch(ChargedMaterialDef mat = {}, double width = 0.02) : m(flat(width, 0.001, mat)), s(make_charged_state(m)) {
    const int c = central_particle(m);
    z0 = m.origin(size_t(c)).z() + 0.5 * m.row_pitch;
  }
};

// Steps a blade along a path and remembers every tick's sweep that cut (prev edge → this edge).
struct Stroke {
  std::vector<BladeSweep> sweeps;
  std::vector<Vec3> forces;
  std::vector<TissueEvent> events;
  bool have_prev = false;
  Vec3 prev_tip, prev_heel;
  Vec3 step(Patch& p, const ChargedHip& hip) {
    const Vec3 f = palpate::step(p.m, p.s, hip, kDt, 0);
    const Vec3 heel = hip.position - hip.edge_length * hip.axis;
    if (p.s.stats.cutting && have_prev) sweeps.push_back({prev_heel, prev_tip, heel, hip.position});
    prev_tip = hip.position, prev_heel = heel, have_prev = true;
    forces.push_back(f);
    TissueEvent ev[8];
    const size_t n = drain_events(p.s, ev);
    events.insert(events.end(), ev, ev + n);
    return f;
  }
  // Straight from a to b at `speed` (m/s), one tick per dt.
  void move(Patch& p, const Vec3& a, const Vec3& b, double speed, double length = 0.008) {
    const int n = std::max(1, int(std::ceil((b - a).norm() / (speed * kDt))));
    for (int k = 1; k <= n; ++k) step(p, blade_at(a + (b - a) * (double(k) / n), length));
  }
};

// The scripted incision: down at x = x0 to 3 mm under the rest surface (1.3 N: past the 1 N
// cutting force), along +x to x1 at 20 mm/s, then up and away at 20 mm/s.
void incision(Patch& p, Stroke& r, double x0, double x1, double depth = -0.003, double z = NAN) {
  if (std::isnan(z)) z = p.z0;
  r.move(p, Vec3(x0, 0.004, z), Vec3(x0, depth, z), 0.02);
  r.move(p, Vec3(x0, depth, z), Vec3(x1, depth, z), 0.02);
  r.move(p, Vec3(x1, depth, z), Vec3(x1, 0.004, z), 0.02);
}

void rest_for(Patch& p, double seconds) {
  for (int k = 0; k < int(seconds / kDt); ++k) step(p.m, p.s, hip_at(Vec3(0, 0.05, 0)), kDt, 0);
}

// Every link (i < j) whose rest segment crosses one of the sweeps.
std::vector<std::pair<int, int>> crossed(const ChargedModel& m, const std::vector<BladeSweep>& sweeps) {
  std::vector<std::pair<int, int>> out;
  std::array<int, 6> nb{};
  for (int i = 0; i < int(m.size()); ++i)
    for (int a = 0, k = m.neighbours_of(i, nb); a < k; ++a) {
      const int j = nb[size_t(a)];
      if (j <= i) continue;
      for (const BladeSweep& s : sweeps)
        if (segment_crosses_sweep(m.origin(size_t(i)), m.origin(size_t(j)), s)) {
          out.push_back({i, j});
          break;
        }
    }
  return out;
}

std::vector<std::pair<int, int>> cut_set(const ChargedModel& m, const ChargedState& s) {
  std::vector<std::pair<int, int>> out;
  std::array<int, 6> nb{};
  for (int i = 0; i < int(m.size()); ++i) {
    m.neighbour_slots(i, nb);
    for (int k = 0; k < 6; ++k) {
      const int j = nb[size_t(k)];
      if (j < 0 || !link_cut(s, i, k)) continue;
      // Symmetric: j's slot for i is cut too.
      const int back = charged_slot_of(m, j, i);
      EXPECT_GE(back, 0);
      EXPECT_TRUE(back >= 0 && link_cut(s, j, back)) << "link " << i << "-" << j << " cut on one side only";
      if (j > i) out.push_back({i, j});
    }
  }
  return out;
}

double max_rate(const std::vector<Vec3>& f) {
  double r = 0;
  for (size_t k = 1; k < f.size(); ++k) r = std::max(r, (f[k] - f[k - 1]).norm() / kDt);
  return r;
}

TEST(ChargedCut, TheLinksTheSweptEdgeCrossesAreCutAndOnlyThose) {
  Patch p;
  Stroke r;
  incision(p, r, -0.006, 0.006);
  const auto expected = crossed(p.m, r.sweeps);
  const auto got = cut_set(p.m, p.s);
  // 12 mm of cut line crossing two diagonal links per millimetre (one per column).
  EXPECT_GE(expected.size(), 20u);
  EXPECT_EQ(got, expected);
  EXPECT_EQ(p.s.cut_link_count, long(got.size()));
  // Every cut link straddles the cut line; none runs more than a link beyond its ends.
  for (const auto& [i, j] : got) {
    const Vec3 a = p.m.origin(size_t(i)), b = p.m.origin(size_t(j));
    EXPECT_LT((a.z() - p.z0) * (b.z() - p.z0), 0);
    EXPECT_GT(std::max(a.x(), b.x()), -0.006 - 0.001);
    EXPECT_LT(std::min(a.x(), b.x()), 0.006 + 0.001);
  }
  // One "cut" event for the one stroke, with the force that started it (≥ cutting_force).
  int cuts = 0;
  for (const TissueEvent& e : r.events)
    if (std::string(e.kind) == "cut") {
      ++cuts;
      EXPECT_GE(e.force, p.m.material.cutting_force);
    }
  EXPECT_EQ(cuts, 1);
}

TEST(ChargedCut, BelowTheCuttingForceABladeOnlyPressesLikeAProbe) {
  Patch p, q;
  Stroke r;
  // 1.5 mm under the rest surface: about 0.67 N, under the 1 N cutting force.
  incision(p, r, -0.006, 0.006, -0.0015);
  EXPECT_EQ(p.s.cut_link_count, 0);
  for (const TissueEvent& e : r.events) EXPECT_STRNE(e.kind, "cut");
  // The same path with a probe of the same radius: the same forces and positions, bit for bit.
  Stroke probe;
  auto as_probe = [&](const Vec3& a, const Vec3& b) {
    const int n = std::max(1, int(std::ceil((b - a).norm() / (0.02 * kDt))));
    for (int k = 1; k <= n; ++k) {
      ChargedHip h = blade_at(a + (b - a) * (double(k) / n));
      h.blade = false, h.edge_length = 0;
      probe.forces.push_back(step(q.m, q.s, h, kDt, 0));
    }
  };
  as_probe(Vec3(-0.006, 0.004, p.z0), Vec3(-0.006, -0.0015, p.z0));
  as_probe(Vec3(-0.006, -0.0015, p.z0), Vec3(0.006, -0.0015, p.z0));
  as_probe(Vec3(0.006, -0.0015, p.z0), Vec3(0.006, 0.004, p.z0));
  ASSERT_EQ(probe.forces.size(), r.forces.size());
  for (size_t k = 0; k < r.forces.size(); ++k) ASSERT_EQ(probe.forces[k], r.forces[k]) << "tick " << k;
  EXPECT_EQ(p.s.x, q.s.x);
  EXPECT_EQ(p.s.z, q.s.z);
}

TEST(ChargedCut, TheSeparationRuleNoLongerPullsAcrossTheCut) {
  // A cut right across the patch, border to border; then a probe pressed 4 mm deep 2 mm beside it.
  for (bool cut : {false, true}) {
    Patch p;
    Stroke r;
    if (cut) incision(p, r, -0.014, 0.014);
    else r.move(p, Vec3(0, 0.004, p.z0), Vec3(0, 0.004, p.z0 + 0.001), 0.02);
    rest_for(p, 1.0);
    const ChargedState before = p.s;
    const Vec3 at(0, 0, p.z0 + 0.002);
    press(p.m, p.s, at, 0.004, -0.002, 0.00002);
    // How far the particles on the other side of the cut line moved.
    double other = 0;
    for (size_t i = 0; i < p.m.size(); ++i)
      if (p.m.origin(i).z() < p.z0) other = std::max(other, (p.s.position(i) - before.position(i)).norm());
    if (cut) {
      EXPECT_LT(other, 1e-6) << "the other side moved";
    } else {
      EXPECT_GT(other, 1e-4) << "an uncut patch carries the press across (the control)";
    }
  }
}

TEST(ChargedCut, TheWoundOpensToItsGapSmoothlyWithinItsDocumentedTime) {
  ChargedMaterialDef mat;
  Patch p(mat);
  Stroke r;
  // Pressed in at x = −9 mm, then drawn to +9 mm; every tick, how far each particle on a wound's
  // edge moved across the cut (z: the way the wound opens), among those more than 4 mm from the
  // blade (nearer, the blade itself pushes them; elsewhere they also return from the blade's dimple,
  // up and along the cut, as any pressed particle does).
  r.move(p, Vec3(-0.009, 0.004, p.z0), Vec3(-0.009, -0.003, p.z0), 0.02);
  std::vector<Vec3> last(p.m.size());
  for (size_t k = 0; k < p.m.size(); ++k) last[k] = p.s.position(k);
  double fastest = 0;
  const int ticks = 900;
  for (int t = 1; t <= ticks; ++t) {
    const Vec3 tip(-0.009 + 0.018 * t / ticks, -0.003, p.z0);
    r.step(p, blade_at(tip));
    for (size_t k = 0; k < p.m.size(); ++k) {
      const Vec3 o = p.m.origin(k);
      if (charged_wound_of(p.s, int(k)) && std::hypot(o.x() - tip.x(), o.z() - tip.z()) > 0.0025)
        fastest = std::max(fastest, std::abs(p.s.position(k).z() - last[k].z()));
      last[k] = p.s.position(k);
    }
  }
  ASSERT_GT(p.s.wound_count, 30u);
  // docs/models/cutting.md: an edge moves as w·(1 − e^(−λt)(1 + λt)), at most λ·w/e ≈ 7.4 mm/s
  // (7.4 µm a tick) at the defaults: no jump anywhere along the wound.
  EXPECT_LT(fastest, 8e-6);
  EXPECT_GT(fastest, 5e-7);  // they did move
  // The edges part by the gap: 95 % of it 4.74/λ (237 ms) after the cut. At x = −2 mm the cut is
  // 0.55 s old.
  int i = -1, j = -1;
  for (const auto& [a, b] : cut_set(p.m, p.s))
    if (std::abs(0.5 * (p.m.origin(size_t(a)).x() + p.m.origin(size_t(b)).x()) + 0.002) < 0.0005) i = a, j = b;
  ASSERT_GE(i, 0);
  const double rest_gap = std::abs(p.m.origin(size_t(i)).z() - p.m.origin(size_t(j)).z());
  const double gap = std::abs(p.s.position(size_t(i)).z() - p.s.position(size_t(j)).z()) - rest_gap;
  EXPECT_GT(gap, 0.95 * mat.wound_gap);
  EXPECT_LT(gap, 1.01 * mat.wound_gap);
  // At rest afterwards no link left uncut stretches past max_separation (the wound tapers to its
  // ends rather than tearing them).
  r.move(p, Vec3(0.009, -0.003, p.z0), Vec3(0.009, 0.004, p.z0), 0.02);
  rest_for(p, 1.0);
  std::array<int, 6> nb{};
  for (int a = 0; a < int(p.m.size()); ++a) {
    p.m.neighbour_slots(a, nb);
    for (int k = 0; k < 6; ++k) {
      if (nb[size_t(k)] < 0 || link_cut(p.s, a, k)) continue;
      EXPECT_LE((p.s.position(size_t(a)) - p.s.position(size_t(nb[size_t(k)]))).norm(),
                p.m.max_separation * (1 + 1e-4));
    }
  }
}

TEST(ChargedCut, TheWoundsEdgesStartFromRestWhereTheyAreCut) {
  // A blade laid back 60° from upright (heel trailing): its edge crosses the rest surface 5.2 mm
  // behind its tip, so the particles it cuts are clear of the tip's push and can be watched from
  // the tick they are cut: across the cut (z) none moves faster than the easing allows
  // (7.4 µm a tick at the defaults) — a rest offset set at once would move them 20 µm in the first
  // tick (elasticity × gap/2 × dt).
  Patch p;
  const Vec3 axis(std::sin(M_PI / 3), -std::cos(M_PI / 3), 0);
  auto tilted = [&](const Vec3& tip) { return blade_at(tip, 0.008, axis); };
  Stroke r;
  for (int t = 1; t <= 350; ++t) r.step(p, tilted(Vec3(-0.002, 0.004 - 0.007 * t / 350.0, p.z0)));
  std::vector<Vec3> last(p.m.size());
  for (size_t k = 0; k < p.m.size(); ++k) last[k] = p.s.position(k);
  double fastest = 0;
  for (int t = 1; t <= 500; ++t) {
    const Vec3 tip(-0.002 + 0.00002 * t, -0.003, p.z0);
    r.step(p, tilted(tip));
    for (size_t k = 0; k < p.m.size(); ++k) {
      const Vec3 o = p.m.origin(k);
      if (charged_wound_of(p.s, int(k)) && std::hypot(o.x() - tip.x(), o.z() - tip.z()) > 0.0025)
        fastest = std::max(fastest, std::abs(p.s.position(k).z() - last[k].z()));
      last[k] = p.s.position(k);
    }
  }
  ASSERT_GT(p.s.cut_link_count, 10);
  // The cut runs behind the tip, where the edge met the rest surface.
  for (const auto& [i, j] : cut_set(p.m, p.s)) EXPECT_LT(p.m.origin(size_t(i)).x(), 0.008 - 0.004);
  EXPECT_LT(fastest, 8e-6);
  EXPECT_GT(fastest, 4e-6);  // the easing's top speed was reached
}

TEST(ChargedCut, TheDragIsPerLengthOfEdgeInTheLayerAgainstTheMotion) {
  ChargedMaterialDef mat;
  mat.thickness = 0.004;
  Patch p(mat);
  Stroke r;
  r.move(p, Vec3(-0.008, 0.004, p.z0), Vec3(-0.008, -0.003, p.z0), 0.02);
  r.move(p, Vec3(-0.008, -0.003, p.z0), Vec3(0.002, -0.003, p.z0), 0.02);
  ASSERT_TRUE(p.s.stats.cutting);
  // The edge is upright, its tip 3 mm deep: 3 mm of it inside the 4 mm layer.
  EXPECT_NEAR(p.s.stats.edge_in_layer, 0.003, 1e-9);
  const double drag = mat.cutting_drag_per_length * 0.003;  // 0.51 N
  EXPECT_NEAR(-r.forces.back().x(), drag, 0.02 * drag);
  EXPECT_NEAR(r.forces.back().z(), 0, 0.02 * drag);
  // Turned to cut along −z into whole tissue: the drag turns with it (smoothly: within the rate
  // limit), out of the open wound and into the new cut.
  r.move(p, Vec3(0.002, -0.003, p.z0), Vec3(0.002, -0.003, p.z0 - 0.006), 0.02);
  ASSERT_TRUE(p.s.stats.cutting);
  EXPECT_NEAR(r.forces.back().z(), drag, 0.02 * drag);
  EXPECT_NEAR(r.forces.back().x(), 0, 0.02 * drag);
  EXPECT_LT(max_rate(r.forces), kRate);
}

TEST(ChargedCut, TheForceStaysWithinTheRateLimitAndTheEnergyDoesNotJumpAtACut) {
  ChargedMaterialDef mat, blunt;
  blunt.cutting_force = 1e9;  // the twin that never cuts
  Patch p(mat), q(blunt);
  Stroke r, rq;
  // E = Σ |p − rest|² about each particle's current rest position (its origin moved by its wound
  // offset now): the layer's elastic energy up to its stiffness.
  auto energy = [](const Patch& x) {
    double e = 0;
    for (size_t i = 0; i < x.m.size(); ++i) {
      Vec3 rest = x.m.origin(i);
      if (const ChargedWound* w = charged_wound_of(x.s, int(i))) {
        const ChargedWound& wd = *w;
        const double f = std::exp(-x.m.material.elasticity * (x.s.time - wd.since));
        for (int c = 0; c < 3; ++c) rest[c] += wd.to[c] + (wd.from[c] - wd.to[c]) * f;
      }
      e += (x.s.position(i) - rest).squaredNorm();
    }
    return e;
  };
  std::vector<double> ep, eq;
  auto both = [&](const Vec3& a, const Vec3& b) {
    const int n = std::max(1, int(std::ceil((b - a).norm() / (0.02 * kDt))));
    for (int k = 1; k <= n; ++k) {
      const ChargedHip h = blade_at(a + (b - a) * (double(k) / n));
      r.step(p, h), rq.step(q, h);
      ep.push_back(energy(p)), eq.push_back(energy(q));
    }
  };
  both(Vec3(-0.006, 0.004, p.z0), Vec3(-0.006, -0.003, p.z0));
  both(Vec3(-0.006, -0.003, p.z0), Vec3(0.006, -0.003, p.z0));
  both(Vec3(0.006, -0.003, p.z0), Vec3(0.006, 0.004, p.z0));
  ASSERT_GT(p.s.cut_link_count, 0);
  EXPECT_EQ(q.s.cut_link_count, 0);
  EXPECT_LT(max_rate(r.forces), kRate) << "the cut's force on the device steps faster than the filter allows";
  // The first tick that cut: the energy rose no more than the twin's, which did not cut.
  size_t first = 0;
  while (first < r.forces.size() && ep[first] == eq[first]) ++first;
  ASSERT_LT(first, ep.size());
  ASSERT_GT(first, 0u);
  EXPECT_LE(ep[first] - ep[first - 1], eq[first] - eq[first - 1] + 1e-15);
  // And no tick's rise is larger than the twin's largest.
  double rise_p = 0, rise_q = 0;
  for (size_t k = 1; k < ep.size(); ++k)
    rise_p = std::max(rise_p, ep[k] - ep[k - 1]), rise_q = std::max(rise_q, eq[k] - eq[k - 1]);
  EXPECT_LE(rise_p, rise_q * 1.01);
}

TEST(ChargedCut, CutsCrossEndInsideThePatchAndReachItsBorder) {
  Patch p;
  Stroke r;
  incision(p, r, -0.014, 0.014);  // border to border along x
  // A second cut along z at x = 0.3 mm, from z0 − 4 mm to z0 + 4 mm: it crosses the first and ends
  // inside the patch at both ends.
  const double x = 0.0003, depth = -0.003;
  r.move(p, Vec3(x, 0.004, p.z0 - 0.004), Vec3(x, depth, p.z0 - 0.004), 0.02);
  r.move(p, Vec3(x, depth, p.z0 - 0.004), Vec3(x, depth, p.z0 + 0.004), 0.02);
  r.move(p, Vec3(x, depth, p.z0 + 0.004), Vec3(x, 0.004, p.z0 + 0.004), 0.02);
  const auto got = cut_set(p.m, p.s);
  EXPECT_EQ(got, crossed(p.m, r.sweeps));
  // The first reaches both borders (a cut link at the first and the last column), the second ends
  // inside (no cut link along x = 0.3 mm beyond 5 mm of z0).
  bool left = false, right = false, beyond = false;
  for (const auto& [i, j] : got) {
    for (int k : {i, j}) {
      left = left || k % p.m.cols == 0;
      right = right || k % p.m.cols == p.m.cols - 1;
    }
    const Vec3 a = p.m.origin(size_t(i)), b = p.m.origin(size_t(j));
    if (std::abs(0.5 * (a.z() + b.z()) - p.z0) > 0.005) beyond = true;
  }
  EXPECT_TRUE(left);
  EXPECT_TRUE(right);
  EXPECT_FALSE(beyond);
  // Two cut events, one a stroke: the first, and the second, which goes on cutting across the first
  // wound's gap (open by then: nothing there to cut) because its tip stays under the rest surface —
  // a scalpel drawn on makes one incision (docs/models/cutting.md). Everything finite; uncut links
  // keep the separation rule at rest.
  int cuts = 0;
  for (const TissueEvent& e : r.events) cuts += std::string(e.kind) == "cut";
  EXPECT_EQ(cuts, 2);
  rest_for(p, 1.0);
  std::array<int, 6> nb{};
  for (int i = 0; i < int(p.m.size()); ++i) {
    ASSERT_TRUE(p.s.position(size_t(i)).allFinite());
    p.m.neighbour_slots(i, nb);
    for (int k = 0; k < 6; ++k) {
      if (nb[size_t(k)] < 0 || link_cut(p.s, i, k)) continue;
      EXPECT_LE((p.s.position(size_t(i)) - p.s.position(size_t(nb[size_t(k)]))).norm(), p.m.max_separation * (1 + 1e-4));
    }
  }
}

TEST(ChargedCut, BadBladePosesCutNothingAndLeaveTheTickSafe) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // Pressed in past the cutting force at x = −6 mm, not moving yet.
  auto pressed = [](Patch& p, Stroke& r) { r.move(p, Vec3(-0.006, 0.004, p.z0), Vec3(-0.006, -0.003, p.z0), 0.02); };
  {  // A NaN pose: zero force, a reset; the next pose, elsewhere, does not sweep from the old one.
    Patch p;
    Stroke r;
    pressed(p, r);
    EXPECT_EQ(r.step(p, blade_at(Vec3(nan, -0.003, p.z0))), Vec3::Zero());
    EXPECT_EQ(p.s.stats.numeric_resets, 1);
    r.step(p, blade_at(Vec3(-0.0059, -0.003, p.z0)));
    r.step(p, blade_at(Vec3(-0.0058, -0.003, p.z0)));
    EXPECT_EQ(p.s.cut_link_count, 0);
    EXPECT_TRUE(r.forces.back().allFinite());
  }
  {  // A teleport: 12 mm in one tick while pressed cuts nothing; counted.
    Patch p;
    Stroke r;
    pressed(p, r);
    const Vec3 f = r.step(p, blade_at(Vec3(0.006, -0.003, p.z0)));
    EXPECT_TRUE(f.allFinite());
    EXPECT_EQ(p.s.cut_link_count, 0);
    EXPECT_EQ(p.s.stats.blade_jumps, 1);
    // From there on it cuts again, from where it landed.
    r.move(p, Vec3(0.006, -0.003, p.z0), Vec3(0.008, -0.003, p.z0), 0.02);
    EXPECT_GT(p.s.cut_link_count, 0);
    for (const auto& [i, j] : cut_set(p.m, p.s)) EXPECT_GT(p.m.origin(size_t(i)).x() + p.m.origin(size_t(j)).x(), 2 * 0.005);
  }
  for (double length : {0.0, -0.01, nan}) {  // a zero, negative or NaN edge: a probe, nothing cut
    Patch p;
    Stroke r;
    r.move(p, Vec3(-0.006, 0.004, p.z0), Vec3(-0.006, -0.003, p.z0), 0.02, length);
    r.move(p, Vec3(-0.006, -0.003, p.z0), Vec3(0.006, -0.003, p.z0), 0.02, length);
    EXPECT_EQ(p.s.cut_link_count, 0) << length;
    for (const Vec3& f : r.forces) ASSERT_TRUE(f.allFinite());
  }
  {  // A path through no tissue: above the patch, and beside it.
    Patch p;
    Stroke r;
    r.move(p, Vec3(-0.006, 0.005, p.z0), Vec3(0.006, 0.005, p.z0), 0.02, 0.004);
    r.move(p, Vec3(0.02, -0.003, 0), Vec3(0.03, -0.003, 0), 0.02);
    EXPECT_EQ(p.s.cut_link_count, 0);
    for (const Vec3& f : r.forces) ASSERT_TRUE(f.allFinite());
  }
}

TEST(ChargedCut, AProbeDrawnAcrossAnOpenWoundFeelsTheGapAndItsEdgesWithoutASteps) {
  for (bool cut : {false, true}) {
    Patch p;
    Stroke r;
    if (cut) incision(p, r, -0.014, 0.014);
    rest_for(p, 1.0);
    // A point probe (sphere of influence 1.1 mm) 1.5 mm deep at x = 2 mm, drawn across the cut line from 5 mm before to 5 mm
    // beyond it at 10 mm/s.
    std::vector<Vec3> f;
    const double x = 0.002, y = -0.0015;
    for (double yy = 0.004; yy >= y; yy -= 0.00001) f.push_back(step(p.m, p.s, hip_at(Vec3(x, yy, p.z0 - 0.005)), kDt, 0));
    const size_t start = f.size();
    for (int k = 0; k <= 1000; ++k) {
      ChargedHip h = hip_at(Vec3(x, y, p.z0 - 0.005 + 0.00001 * k));
      f.push_back(step(p.m, p.s, h, kDt, 0));
    }
    double lo = 1e9, hi = 0;
    for (size_t k = start; k < f.size(); ++k) lo = std::min(lo, f[k].y()), hi = std::max(hi, f[k].y());
    EXPECT_LT(max_rate(f), kRate);
    if (cut) {
      EXPECT_LT(lo, 0.2 * hi) << "over the gap the layer is not there";
      EXPECT_GT(f.back().y(), 0.9 * f[start].y()) << "beyond the far edge it is whole again";
    } else {
      EXPECT_GT(lo, 0.9 * hi) << "an uncut layer feels the same all along (the control)";
    }
  }
}

TEST(ChargedCut, ANumericalResetKeepsTheWoundAndClearCutsHealsIt) {
  Patch p;
  Stroke r;
  incision(p, r, -0.006, 0.006);
  rest_for(p, 0.5);
  const auto cut = cut_set(p.m, p.s);
  const ChargedState open = p.s;
  reset(p.m, p.s);
  EXPECT_EQ(cut_set(p.m, p.s), cut);
  for (size_t i = 0; i < p.m.size(); ++i) EXPECT_LT((p.s.position(i) - open.position(i)).norm(), 1e-5);
  clear_cuts(p.m, p.s);
  EXPECT_TRUE(cut_set(p.m, p.s).empty());
  EXPECT_EQ(max_displacement(p.m, p.s), 0.0);
}

TEST(ChargedCut, TheDrawnSurfaceHasNoTriangleAcrossTheCutAndShowsItsWalls) {
  Patch p;
  Stroke r;
  incision(p, r, -0.014, 0.014);
  rest_for(p, 0.5);
  std::vector<Vec3f> control(p.m.size());
  for (size_t i = 0; i < p.m.size(); ++i) control[i] = p.s.position(i).cast<float>();
  std::vector<std::array<int, 2>> links;
  for (const auto& [i, j] : cut_set(p.m, p.s)) links.push_back({i, j});
  std::vector<std::uint8_t> cells(size_t(p.m.rows - 1) * size_t(p.m.cols - 1));
  ASSERT_TRUE(grid_cut_cells(p.m.rows, p.m.cols, links, cells));
  auto t = SurfaceTessellator::build(p.m.rows, p.m.cols);
  ASSERT_TRUE(t.ok());
  SurfaceBuffers out;
  ASSERT_TRUE(t->tessellate(control, out));
  const SurfaceBuffers whole = out;
  const float thickness = float(p.m.material.thickness);
  ASSERT_TRUE(t->cut(cells, thickness, out));
  const size_t n = t->point_count();
  ASSERT_GT(out.point_count(), n) << "walls were added";
  size_t surface = 0, walls = 0;
  for (size_t k = 0; k < out.triangle_count(); ++k) {
    const uint32_t* tri = &out.triangles[3 * k];
    if (tri[0] >= n) {  // a wall: at most the layer's thickness deep, finite
      ++walls;
      for (int c = 0; c < 3; ++c) {
        ASSERT_TRUE(std::isfinite(out.positions[3 * tri[c]]));
        EXPECT_GT(out.positions[3 * tri[c] + 1], -0.0035f - thickness);
      }
      continue;
    }
    ++surface;
    // No surface triangle has corners on both sides of the cut line.
    float zmin = 1e9f, zmax = -1e9f;
    for (int c = 0; c < 3; ++c) zmin = std::min(zmin, out.positions[3 * tri[c] + 2]), zmax = std::max(zmax, out.positions[3 * tri[c] + 2]);
    EXPECT_FALSE(zmin < float(p.z0) && zmax > float(p.z0)) << "triangle " << k << " bridges the wound";
  }
  EXPECT_GT(walls, 0u);
  EXPECT_LT(surface, whole.triangle_count());
  // Uncut: cut() leaves the tessellation exactly as it was.
  SurfaceBuffers again = whole;
  std::fill(cells.begin(), cells.end(), 0);
  ASSERT_TRUE(t->cut(cells, thickness, again));
  EXPECT_EQ(again.positions, whole.positions);
  EXPECT_EQ(again.triangles, whole.triangles);
  // And the next tessellate() starts from the whole surface again.
  ASSERT_TRUE(t->tessellate(control, out));
  EXPECT_EQ(out.triangles, whole.triangles);
  EXPECT_EQ(out.point_count(), n);
}

TEST(ChargedCut, AScenesBladeToolCutsThroughTissueStepAndTheSnapshotShowsTheCut) {
  auto scene = parse_scene(R"(tissues:
  - name: skin
    patch: {width: 0.02, height: 0.02, spacing: 0.001}
)", "t.yaml", PALPATE_DATA_DIR);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  auto made = make_tissue(*scene, 0);
  ASSERT_TRUE(made.ok()) << made.error().message;
  Tissue& t = **made;
  TissueSnapshot rest;
  t.snapshot(rest);
  EXPECT_TRUE(rest.cut_links.empty());
  ToolState tool;
  tool.blade = true, tool.length = 0.008, tool.radius = 0.0005, tool.axis = Vec3(0, -1, 0);
  std::vector<TissueEvent> events;
  auto go = [&](const Vec3& a, const Vec3& b) {
    const int n = int(std::ceil((b - a).norm() / 2e-5));
    for (int k = 1; k <= n; ++k) {
      tool.tip = a + (b - a) * (double(k) / n);
      ASSERT_TRUE(t.step(tool, kDt).allFinite());
      TissueEvent ev[8];
      const size_t got = t.drain_events(ev);
      events.insert(events.end(), ev, ev + got);
    }
  };
  go(Vec3(-0.005, 0.004, 0.0002), Vec3(-0.005, -0.003, 0.0002));
  go(Vec3(-0.005, -0.003, 0.0002), Vec3(0.005, -0.003, 0.0002));
  go(Vec3(0.005, -0.003, 0.0002), Vec3(0.005, 0.004, 0.0002));
  EXPECT_TRUE(std::any_of(events.begin(), events.end(), [](const TissueEvent& e) { return std::string(e.kind) == "cut"; }));
  TissueSnapshot cut;
  t.snapshot(cut);
  ASSERT_GE(cut.cut_links.size(), 16u);
  EXPECT_EQ(cut.links.size() + cut.cut_links.size(), rest.links.size());
  // No drawn link or triangle joins two particles across a cut link.
  std::set<std::pair<int, int>> gone;
  for (const auto& [i, j] : cut.cut_links) gone.insert({std::min(i, j), std::max(i, j)});
  for (const auto& [i, j] : cut.links) EXPECT_FALSE(gone.count({std::min(i, j), std::max(i, j)}));
  for (const auto& tri : cut.triangles)
    for (int e = 0; e < 3; ++e) {
      const int a = tri[size_t(e)], b = tri[size_t((e + 1) % 3)];
      EXPECT_FALSE(gone.count({std::min(a, b), std::max(a, b)})) << "a drawn triangle bridges the cut";
    }
  EXPECT_LT(cut.triangles.size(), rest.triangles.size());
  // Back to rest for a new run: healed.
  t.reset();
  TissueSnapshot healed;
  t.snapshot(healed);
  EXPECT_TRUE(healed.cut_links.empty());
  EXPECT_EQ(healed.links.size(), rest.links.size());
  EXPECT_EQ(healed.triangles.size(), rest.triangles.size());
}

TEST(ChargedCut, ACuttingMaterialOutOfRangeIsRefusedAtBuildNamingTheKey) {
  PatchDef patch;
  patch.width = patch.height = 0.01, patch.spacing = 0.001;
  for (const char* key : {"cutting_force", "cutting_drag_per_length", "wound_gap"}) {
    ChargedMaterialDef mat;
    double& v = std::string(key) == "cutting_force" ? mat.cutting_force
              : std::string(key) == "wound_gap"     ? mat.wound_gap
                                                    : mat.cutting_drag_per_length;
    for (double bad : {-1.0, std::numeric_limits<double>::quiet_NaN()}) {
      v = bad;
      auto m = build_charged_patch(patch, mat, "t.yaml:3: tissue 'skin'");
      ASSERT_FALSE(m.ok()) << key << " " << bad;
      EXPECT_NE(m.error().message.find(std::string("'") + key + "'"), std::string::npos) << m.error().message;
    }
  }
}

// Item 8: thousands of random blade paths — crossing, re-cutting, cutting pieces off — through
// one patch: no non-finite value, the cut set symmetric and only growing, the force finite.
TEST(ChargedCut, RandomBladePathsNeverBreakIt) {
  Patch p;
  std::mt19937 rng(37);
  std::uniform_real_distribution<double> u(-0.013, 0.013), depth(-0.004, 0.001), dir(-1, 1);
  long cut_before = 0;
  for (int path = 0; path < 2000; ++path) {
    Vec3 a(u(rng), 0.003, u(rng)), b(u(rng), depth(rng), u(rng));
    Vec3 axis(0.4 * dir(rng), -1, 0.4 * dir(rng));
    axis.normalize();
    const int ticks = 5 + int(rng() % 20);
    for (int k = 0; k <= ticks; ++k) {
      ChargedHip h = blade_at(a + (b - a) * (double(k) / ticks), 0.002 + 0.01 * (rng() % 100) / 100.0, axis);
      if (rng() % 500 == 0) h.position.x() = std::numeric_limits<double>::quiet_NaN();
      const Vec3 f = step(p.m, p.s, h, kDt, 0);
      ASSERT_TRUE(f.allFinite()) << "path " << path;
      ASSERT_GE(p.s.cut_link_count, cut_before);
      cut_before = p.s.cut_link_count;
    }
  }
  for (size_t i = 0; i < p.m.size(); ++i) ASSERT_TRUE(p.s.position(i).allFinite());
  cut_set(p.m, p.s);  // asserts symmetry
  EXPECT_GT(p.s.cut_link_count, 50);
}

}  // namespace
