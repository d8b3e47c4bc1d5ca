// cut.cpp — cutting the charged-particle layer (stages.h): the links a blade's swept edge crosses,
// the wound's edges parting, and the share of the layer left under a tool over an open wound.
// Method and limits: docs/models/cutting.md.
#include "tissue/charged/stages.h"

#include "core/blade_sweep.h"

namespace palpate::charged {

namespace {

// The height of p over the rest surface (m); false when p is not near the patch (mesh patches).
bool rest_height(const ChargedModel& m, const Vec3& p, double reach, double& height) noexcept {
  if (m.layout != ChargedLayout::mesh) {
    height = lattice_height(m, p);
    return true;
  }
  Vec3 n;
  return rest_surface(m, p, reach, height, n);
}

// Particle i's wound entry, added (offset zero, not easing) when it has none: appended to the
// table and hashed into its index (open addressing, at most half full). Null when the table is full.
ChargedWound* wound_entry(ChargedState& s, int i) noexcept {
  const size_t mask = s.wound_index.size() - 1;
  size_t k = (static_cast<std::uint32_t>(i) * 2654435761u) & mask;
  for (;; k = (k + 1) & mask) {
    const std::int32_t w = s.wound_index[k];
    if (w < 0) break;
    if (s.wound[static_cast<size_t>(w)].particle == i) return &s.wound[static_cast<size_t>(w)];
  }
  if (s.wound_count == s.wound.size()) {
    ++s.wound_full;
    return nullptr;
  }
  s.wound_index[k] = static_cast<std::int32_t>(s.wound_count);
  ChargedWound& wd = s.wound[s.wound_count++];
  wd = ChargedWound{};
  wd.particle = i;
  wd.since = s.time;
  s.flags[static_cast<size_t>(i)] |= kWound;
  return &wd;
}

// Send particle i's rest offset toward `to` (m) from wherever it is now: the easing restarts from
// its current value, so the particle's target never jumps.
void retarget(const ChargedModel& m, ChargedState& s, int i, const Vec3& to) noexcept {
  const auto k = static_cast<size_t>(i);
  ChargedWound* entry = wound_entry(s, i);
  if (!entry) return;
  ChargedWound& wd = *entry;
  Vec3 now, old_to;
  wound_offset(m, s, wd, now, old_to);
  for (int c = 0; c < 3; ++c) wd.from[c] = static_cast<float>(now[c]), wd.to[c] = static_cast<float>(to[c]);
  wd.since = s.time;
  // Active, so relaxation carries it along its moving rest position.
  if (!(s.flags[k] & kActive)) {
    s.flags[k] |= kActive;
    s.active[s.active_count++] = i;
  }
}

Vec3 final_offset(const ChargedState& s, int i) noexcept {
  const ChargedWound* wd = charged_wound_of(s, i);
  return wd ? Vec3(wd->to[0], wd->to[1], wd->to[2]) : Vec3::Zero();
}

void mark(ChargedState& s, int i, size_t& count) noexcept {
  auto& f = s.flags[static_cast<size_t>(i)];
  if (f & kWoundEdge) return;
  f |= kWoundEdge;
  s.cut_scratch[count++] = i;
}

}  // namespace

int cut_links(const ChargedModel& m, ChargedState& s, const Vec3& heel0, const Vec3& tip0, const Vec3& heel1,
              const Vec3& tip1) noexcept {
  const BladeSweep sweep{heel0, tip0, heel1, tip1};
  const double travel = std::max((tip1 - tip0).norm(), (heel1 - heel0).norm());
  const double edge = std::max((tip0 - heel0).norm(), (tip1 - heel1).norm());
  if (!(std::isfinite(travel) && std::isfinite(edge)) || !(edge > 0)) return 0;
  // Where the sweep can meet a link: a link's crossing point X lies within `travel` of a point of
  // one of the two edges (each sweep triangle is within the edges' displacement of an edge), and
  // within a link's length of the rest surface, whose height is 1-Lipschitz. So sample the edges,
  // keep the samples within travel + link + sample step of the surface, and search the ball
  // around them grown by as much. (A link is at most max_separation long at rest.)
  const double link = m.max_separation;
  constexpr int kSamples = 16;
  const double step = edge / (kSamples - 1);
  const double band = travel + link + step;
  Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
  bool any = false;
  for (const auto& [a, b] : {std::pair{heel0, tip0}, std::pair{heel1, tip1}})
    for (int k = 0; k < kSamples; ++k) {
      const Vec3 p = a + (b - a) * (double(k) / (kSamples - 1));
      double height = 0;
      if (!rest_height(m, p, band + m.spacing, height) || !(std::abs(height) <= band)) continue;
      lo = lo.cwiseMin(p), hi = hi.cwiseMax(p), any = true;
    }
  if (!any) return 0;  // the edge passes nowhere near the rest surface
  lo -= Vec3::Constant(band), hi += Vec3::Constant(band);
  Vec3 slo, shi;
  sweep_bounds(sweep, 0.0, slo, shi);
  const Vec3 centre = 0.5 * (lo + hi);
  const double radius = 0.5 * (hi - lo).norm();

  int cut = 0;
  size_t marked = 0;
  std::array<int, 6> nb{};
  for_each_candidate(m, centre, radius, [&](int i) {
    const auto ki = static_cast<size_t>(i);
    const Vec3 oi = m.origin(ki);
    m.neighbour_slots(i, nb);
    for (int a = 0; a < 6; ++a) {
      const int j = nb[static_cast<size_t>(a)];
      if (j < 0 || ((s.cut[ki] >> a) & 1u)) continue;
      const Vec3 oj = m.origin(static_cast<size_t>(j));
      // Cheap cull on the boxes, then Möller–Trumbore, always from the lower index (so a link's
      // answer does not depend on which end found it).
      if ((oi.cwiseMax(oj).array() < slo.array()).any() || (oi.cwiseMin(oj).array() > shi.array()).any()) continue;
      const Vec3& p = i < j ? oi : oj;
      const Vec3& q = i < j ? oj : oi;
      // Which of the sweep's two triangles it crosses: the cut's face there, whose normal says
      // which way each end parts.
      Vec3 face = Vec3::Zero();
      if (segment_crosses_triangle(p, q, sweep.a0, sweep.b0, sweep.b1))
        face = (sweep.b0 - sweep.a0).cross(sweep.b1 - sweep.a0);
      else if (segment_crosses_triangle(p, q, sweep.a0, sweep.b1, sweep.a1))
        face = (sweep.b1 - sweep.a0).cross(sweep.a1 - sweep.a0);
      else
        continue;
      const int back = charged_slot_of(m, j, i);
      s.cut[ki] |= static_cast<std::uint8_t>(1u << a);
      if (back >= 0) s.cut[static_cast<size_t>(j)] |= static_cast<std::uint8_t>(1u << back);
      ++s.cut_link_count;
      ++cut;
      // Each end parts away from the cut's face, in its own tangent plane (the face's normal
      // toward its side; along the link where the face is degenerate).
      for (const auto& [e, f] : {std::pair{i, j}, std::pair{j, i}}) {
        const Vec3 oe = m.origin(static_cast<size_t>(e)), ne = m.particle_normal(static_cast<size_t>(e)).normalized();
        const Vec3 link_dir = oe - m.origin(static_cast<size_t>(f));
        Vec3 d = face.squaredNorm() > 0 ? Vec3(face * (face.dot(link_dir) >= 0 ? 1.0 : -1.0)) : link_dir;
        d -= d.dot(ne) * ne;
        if (!(d.squaredNorm() > 0)) continue;
        d.normalize();
        ChargedWound* wd = wound_entry(s, e);
        if (!wd) continue;  // the table is full: cut, but this end does not part
        for (int c = 0; c < 3; ++c) wd->away[c] += static_cast<float>(d[c]);
        mark(s, e, marked);
      }
    }
  });
  if (cut == 0) return 0;

  // Each edge particle's offset: half the gap, along the sum of its cuts' directions (so a particle
  // cut on opposite sides — a sliver between two cuts — stays: the sum cancels), no more than half
  // max_displacement, which repulsion and the separation rule keep it within.
  const double half = std::min(0.5 * m.material.wound_gap, 0.5 * m.material.max_displacement);
  const size_t first = marked;
  for (size_t a = 0; a < first; ++a) {
    const int i = s.cut_scratch[a];
    const ChargedWound* wd = charged_wound_of(s, i);
    const Vec3 away(wd->away[0], wd->away[1], wd->away[2]);
    retarget(m, s, i, away * (half / std::max(1.0, away.norm())));
  }
  // Where an edge particle is still tied (past a cut's end, along its edge), both ends' rest
  // positions must keep the separation rule, or relaxation and the rule would pull against each
  // other: shrink the offsets on such links until they do (each round by 0.7; 12 rounds leave 1 %).
  const double limit = 0.95 * m.max_separation;
  for (int round = 0; round < 12; ++round) {
    bool changed = false;
    for (size_t a = 0; a < marked; ++a) {
      const int i = s.cut_scratch[a];
      const auto ki = static_cast<size_t>(i);
      if (!(s.flags[ki] & kWound)) continue;
      m.neighbour_slots(i, nb);
      for (int k = 0; k < 6; ++k) {
        const int j = nb[static_cast<size_t>(k)];
        if (j < 0 || ((s.cut[ki] >> k) & 1u)) continue;
        const Vec3 wi = final_offset(s, i), wj = final_offset(s, j);
        const Vec3 d = (m.origin(ki) + wi) - (m.origin(static_cast<size_t>(j)) + wj);
        if (!(d.norm() > limit)) continue;
        retarget(m, s, i, wi * 0.7);
        if (s.flags[static_cast<size_t>(j)] & kWound) {
          retarget(m, s, j, wj * 0.7);
          mark(s, j, marked);
        }
        changed = true;
      }
    }
    if (!changed) break;
  }
  for (size_t a = 0; a < marked; ++a)
    s.flags[static_cast<size_t>(s.cut_scratch[a])] &= static_cast<std::uint8_t>(~kWoundEdge);
  return cut;
}

double layer_presence(const ChargedModel& m, const ChargedState& s, const Vec3& foot, const Vec3& n) noexcept {
  const double ell = kPresenceKernel * m.spacing, inv2 = 1 / (ell * ell);
  const double reach = ell + m.material.max_displacement + 0.5 * m.material.wound_gap;
  double rest = 0, now = 0;
  auto weight = [&](const Vec3& d) {
    const double along = d.dot(n);
    if (!(std::abs(along) < reach)) return 0.0;  // the far side of a thin or closed surface
    const double r2 = (d - along * n).squaredNorm() * inv2;
    return r2 < 1 ? (1 - r2) * (1 - r2) : 0.0;
  };
  for_each_candidate(m, foot, reach, [&](int i) {
    const auto k = static_cast<size_t>(i);
    rest += weight(m.origin(k) - foot);
    now += weight(s.position(k) - foot);
  });
  if (!(rest > 0)) return 1.0;
  return std::clamp(now / (kPresenceFull * rest), 0.0, 1.0);
}

}  // namespace palpate::charged
