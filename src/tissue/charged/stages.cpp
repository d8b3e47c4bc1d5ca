// stages.cpp — the charged-particle step's stages (stages.h): the HIP's tracks, relaxation,
// repulsion, the layers above pressing, propagation (the separation rule), and the queries they
// share. Equations and reasoning: docs/models/charged-particles.md.
#include "tissue/charged/stages.h"

namespace palpate::charged {

void push_event(ChargedState& s, const TissueEvent& e) noexcept {
  if (s.event_count == s.events.size()) {  // full: drop the oldest
    s.event_head = (s.event_head + 1) % s.events.size();
    --s.event_count;
    ++s.events_dropped;
  }
  s.events[(s.event_head + s.event_count) % s.events.size()] = e;
  ++s.event_count;
}

void set_position(ChargedState& s, int i, const Vec3& p) noexcept {
  const auto k = static_cast<size_t>(i);
  s.x[k] = static_cast<float>(p.x()), s.y[k] = static_cast<float>(p.y()), s.z[k] = static_cast<float>(p.z());
}

// A particle left its origin (or moved again): remember it in the active set and queue it for
// the separation rule. Both arrays have capacity n and each particle is in each at most once.
void touch(ChargedState& s, int i, size_t& q_tail) noexcept {
  auto& f = s.flags[static_cast<size_t>(i)];
  if (!(f & kActive)) {
    f |= kActive;
    s.active[s.active_count++] = i;
  }
  if (!(f & kQueued)) {
    f |= kQueued;
    s.queue[q_tail % s.queue.size()] = i;
    ++q_tail;
  }
}

// The rest surface under the HIP: signed distance of h above it (m, along the outward normal) and
// that normal. Generated patches use their exact shape; a mesh patch a smooth kernel-weighted mean
// of the tangent planes at the particles' origins near h (C¹ in h; below).
// False when h is not over the patch (beyond a lattice's edges, or no mesh particle within ρ).
bool rest_surface(const ChargedModel& m, const Vec3& h, double rho, double& dist, Vec3& normal) noexcept {
  switch (m.layout) {
    case ChargedLayout::flat: {
      const Vec3 d = h - m.center;
      dist = d.dot(m.normal), normal = m.normal;
      return std::abs(d.dot(m.tangent_u)) <= m.u_mid && std::abs(d.dot(m.tangent_v)) <= m.v_mid;
    }
    case ChargedLayout::cylinder: {
      const Vec3 w = h - (m.center - m.radius * m.normal);
      const double x = w.dot(m.tangent_u), z = w.dot(m.normal), rh = std::hypot(x, z);
      if (!(rh > 0)) return false;
      dist = rh - m.radius, normal = (x * m.tangent_u + z * m.normal) / rh;
      return std::abs(w.dot(m.tangent_v)) <= m.v_mid && std::abs(m.radius * std::atan2(x, z)) <= m.u_mid;
    }
    case ChargedLayout::sphere: {
      const Vec3 w = h - (m.center - m.radius * m.normal);
      const double rh = w.norm();
      if (!(rh > 0)) return false;
      dist = rh - m.radius, normal = w / rh;
      const double lat = std::asin(std::clamp(w.dot(m.tangent_v) / rh, -1.0, 1.0));
      const double lon = std::atan2(w.dot(m.tangent_u), w.dot(m.normal));
      return std::abs(m.radius * lat) <= m.v_mid && std::abs(m.radius * lon) <= m.u_mid;
    }
    case ChargedLayout::mesh:
      break;
  }
  // Mesh: the particles' tangent planes, weighted by how close h's foot point is to each particle
  // sideways (ℓ, support 1.5 spacings: at least one particle under any point of the surface, and a
  // curvature error of only κ·ℓ²/2) and by their distance (support rho, which keeps the far side
  // of a thin or closed surface out). Both weights (1 − x²)², so the estimate is C¹ in h.
  // The curvature's second-order term is removed too: on a surface bending away by κℓ²/2 over a
  // sideways offset ℓ, the particle's normal is tilted by κℓ from h's, so adding half the offset's
  // component along the mean normal, (ℓ⃗·n̄)/2, cancels it (exact to second order on a sphere).
  double wsum = 0, dsum = 0;
  Vec3 nsum = Vec3::Zero(), lsum = Vec3::Zero();
  const double rho2 = rho * rho, lat2 = (1.5 * m.spacing) * (1.5 * m.spacing);
  for_each_candidate(m, h, rho, [&](int i) {
    const auto k = static_cast<size_t>(i);
    const Vec3 d = h - m.origin(k);
    const double r2 = d.squaredNorm();
    if (r2 >= rho2) return;
    const Vec3 n = m.particle_normal(k).normalized();
    const double height = d.dot(n), l2 = (d - height * n).squaredNorm();
    if (l2 >= lat2) return;
    const double a = 1 - r2 / rho2, b = 1 - l2 / lat2, w = a * a * b * b;
    wsum += w, dsum += w * height, nsum += w * n, lsum += w * (d - height * n);
  });
  if (!(wsum > 0) || !(nsum.norm() > 0)) return false;
  normal = nsum.normalized();
  dist = (dsum + 0.5 * lsum.dot(normal)) / wsum;
  return true;
}

// The signed height of p over a generated patch's rest surface (plane, cylinder, sphere), without
// the patch's bounds: rest_surface's distance, at a few flops.
double lattice_height(const ChargedModel& m, const Vec3& p) noexcept {
  if (m.layout == ChargedLayout::flat) return (p - m.center).dot(m.normal);
  const Vec3 w = p - (m.center - m.radius * m.normal);
  if (m.layout == ChargedLayout::sphere) return w.norm() - m.radius;
  const double x = w.dot(m.tangent_u), z = w.dot(m.normal);
  return std::sqrt(x * x + z * z) - m.radius;
}

bool entry_point(const ChargedModel& m, const Vec3& h, const Vec3& axis, double side, double step_length,
                 Vec3& point, Vec3& normal) noexcept {
  if (m.layout == ChargedLayout::mesh || !(step_length > 0)) return false;
  auto g = [&](double t) { return side * lattice_height(m, h - t * axis); };
  if (!(g(0) < 0)) return false;
  double lo = 0, hi = step_length;
  int steps = 0;
  while (g(hi) < 0) {
    if (++steps == 8) return false;  // the shaft runs along the surface: no crossing near
    lo = hi, hi += step_length;
  }
  for (int k = 0; k < 48 && hi - lo > 1e-12; ++k) {
    const double mid = 0.5 * (lo + hi);
    (g(mid) < 0 ? lo : hi) = mid;
  }
  point = h - hi * axis;
  double d = 0;
  if (!rest_surface(m, point, step_length, d, normal)) return false;
  normal *= side;
  return true;
}

// Stage 1 — HIP update (stages.h).
bool update_tracks(const ChargedModel& m, ChargedState& s, const Vec3& tip, const Vec3& axis, bool over,
                   double rest_height, double R, int tissue, bool& near) noexcept {
  const double D = m.material.max_displacement;
  bool any = false;
  near = false;
  for (ChargedHole& hole : s.holes) {
    if (!hole.open) continue;
    const double height = (tip - hole.surface).dot(hole.normal);
    Vec3 e = tip - hole.center;
    e -= e.dot(hole.axis) * hole.axis;  // the tip's offset from the track's line
    const double offset = e.norm();
    // Out: R above the hole's tangent plane, or withdrawn behind the hole along the shaft and R
    // clear of the layer's rest surface on the side the tool came from (where the plane misleads:
    // a vessel punctured on its flank, where the plane's normal points sideways).
    const bool behind = (tip - hole.surface).dot(axis) < 0;
    const bool clear = !over || rest_height * hole.side >= R;
    const bool now = height < R && !(behind && clear) && (hole.in_track || offset < R);
    if (hole.in_track && !now) {
      push_event(s, TissueEvent{s.time, "exit", tissue, 0.0, 0.0});
      if (m.material.hole_closes) {  // the particles' charges return to normal: the hole heals
        const double reach = 2 * (R + D);
        for_each_candidate(m, hole.center, reach, [&](int i) {
          if ((m.origin(static_cast<size_t>(i)) - hole.center).norm() < reach)
            s.flags[static_cast<size_t>(i)] &= static_cast<std::uint8_t>(~kReversed);
        });
        hole.open = false;
      }
    }
    hole.in_track = now && hole.open;
    any = any || hole.in_track;
    // Near: the tip is in the band where this hole's surface would be met (from D + 2R under it to
    // R over it) while the shaft is in the hole: there the patch must not be met anew (a tip drifted
    // sideways just under the skin is in the skin, not pressing it from below). A tip on the track
    // far beyond the band (across a vessel's lumen) meets the layer again.
    near = near || (hole.in_track && height > -(D + 2 * R));
  }
  return any;
}

// Stage 3 — repulsion: a particle inside the HIP's sphere of influence is pushed inward along its
// own surface normal out to the sphere's surface (where the repulsion vanishes), but never beyond
// max_displacement from its origin. Pushing along the normal (not radially, and always inward:
// the tool comes from the outer side) keeps particles from sliding around or over the HIP, so a
// tool cannot slip through or under the patch without puncturing it.
// `side`: +1 for a tool on the outer side, −1 for one inside a two-sided layer (a vessel's lumen):
// particles are then pushed outward.
void repulsion(const ChargedModel& m, ChargedState& s, const Vec3& h, double R, double side,
               size_t& q_tail) noexcept {
  const double D = m.material.max_displacement;
  for_each_candidate(m, h, R + D, [&](int i) {
    const auto k = static_cast<size_t>(i);
    ++s.stats.candidates;
    if (s.flags[k] & kReversed) return;
    const Vec3 p = s.position(k);
    const Vec3 d = p - h;
    const double r2 = d.squaredNorm();
    if (r2 >= R * R) return;
    // |d - t n|² = R²  →  t = d·n + √((d·n)² − |d|² + R²) > 0, the exit on the inner side.
    const Vec3 n = side * m.particle_normal(k).normalized();
    const double dn = d.dot(n), t = dn + std::sqrt(dn * dn - r2 + R * R);
    const Vec3 o = m.origin(k);
    Vec3 target = p - t * n;
    const Vec3 e = target - o;
    const double el = e.norm();
    if (el > D) target = o + e * (D / el);
    if (target != p) {
      set_position(s, i, target);
      touch(s, i, q_tail);
    }
  });
}

// Stage 3b — the layers above press on this one (scene order lists layers from the outside in):
// an active particle of a layer above that lies below this layer's rest surface pushes down, along
// their normals, the particles of this layer within ρ of it sideways that are above it, to its
// level (past this layer's max_displacement if need be: it is carried along). So a layer pushed
// down pushes the one below instead of passing through it; the separation rule then spreads the
// push. Holes (reversed particles) are not pushed.
// Generated lattices only (their sideways search costs a few sites per particle).
void press_from_above(const ChargedModel& m, ChargedState& s, std::span<const ChargedLayer> above,
                      size_t& q_tail) noexcept {
  if (m.layout == ChargedLayout::mesh) return;
  for (const ChargedLayer& layer : above) {
    if (!layer.model || !layer.state) continue;
    const ChargedState& up = *layer.state;
    const double rho = 0.6 * std::max(layer.model->spacing, m.spacing);
    for (size_t a = 0; a < up.active_count; ++a) {
      const Vec3 p = up.position(static_cast<size_t>(up.active[a]));
      // Particles only ever move inward, so one above the rest surface is above them all: most
      // are, and this cheap height (no atan2, no patch bounds) turns them away first.
      // (Beyond the patch's edges the sideways search below finds no site.)
      if (lattice_height(m, p) >= 0) continue;
      for_each_candidate(m, p, rho, [&](int j) {
        const auto k = static_cast<size_t>(j);
        if (s.flags[k] & kReversed) return;
        const Vec3 nj = m.particle_normal(k).normalized();
        const Vec3 e = p - s.position(k);
        const double height = e.dot(nj);
        if (height >= 0 || (e - height * nj).squaredNorm() >= rho * rho) return;
        // Not clamped to this layer's max_displacement: a layer pressed by the one above is carried
        // along by it (it cannot be cut before the one above is, so it does not stop it either).
        set_position(s, j, s.position(k) + height * nj);
        touch(s, j, q_tail);
      }, true);
    }
  }
}

// Stage 4 — propagation (ChainMail, Gibson 1997): a moved particle drags each neighbour that now
// violates max_separation just far enough to satisfy it, keeping the neighbour within its own
// max_displacement; the neighbour is queued in turn. Only disturbed particles are visited.
// `D`: the farthest a particle may be dragged from its origin (max_displacement, more for a layer
// carried along by the layers above it).
void propagation(const ChargedModel& m, ChargedState& s, size_t q_head, size_t q_tail, double D) noexcept {
  const double S = m.max_separation;
  const double S_check2 = S * S * (1 + kSeparationSlack) * (1 + kSeparationSlack);
  const size_t bound = 16 * m.size() + 1024;  // safety bound; never reached by a consistent patch
  size_t pops = 0;
  std::array<int, 6> nb{};
  while (q_head != q_tail) {
    const int i = s.queue[q_head % s.queue.size()];
    ++q_head;
    s.flags[static_cast<size_t>(i)] &= static_cast<std::uint8_t>(~kQueued);
    if (++pops > bound) {  // drop the rest of the queue, count it, keep the step bounded
      while (q_head != q_tail) {
        s.flags[static_cast<size_t>(s.queue[q_head % s.queue.size()])] &= static_cast<std::uint8_t>(~kQueued);
        ++q_head;
      }
      ++s.stats.propagation_overflows;
      break;
    }
    const Vec3 pi = s.position(static_cast<size_t>(i));
    // A cut link ties nothing: the slots' order is neighbours_of's, so an uncut patch is visited
    // exactly as before cutting existed.
    m.neighbour_slots(i, nb);
    const unsigned cut = s.cut[static_cast<size_t>(i)];
    for (int a = 0; a < 6; ++a) {
      const int j = nb[static_cast<size_t>(a)];
      if (j < 0 || ((cut >> a) & 1u)) continue;
      const auto kj = static_cast<size_t>(j);
      ++s.stats.propagation_visits;
      const Vec3 pj = s.position(kj);
      const Vec3 d = pj - pi;
      const double L2 = d.squaredNorm();
      if (L2 <= S_check2) continue;
      const Vec3 oj = m.origin(kj);
      Vec3 target = pi + d * (S / std::sqrt(L2));
      const Vec3 e = target - oj;
      const double el = e.norm();
      if (el > D) target = oj + e * (D / el);
      if ((target - pi).squaredNorm() > S_check2) {
        // Both balls (|p - p_i| ≤ S, |p - o_j| ≤ D) meet on the segment o_j → p_i, because
        // |p_i - o_j| ≤ D + rest spacing < D + S: take that point.
        const Vec3 g = pi - oj;
        const double gl = g.norm();
        target = oj + g * std::max(0.0, 1 - S / gl);
      }
      set_position(s, j, target);
      ++s.stats.propagation_moves;
      touch(s, j, q_tail);
    }
  }
}

// Stage 2 — relaxation: every displaced particle returns toward its origin,
// p ← o + (p − o)·exp(−λ·dt), the exact solution of dp/dt = −λ (p − o) over the tick. The same
// factor for all keeps every neighbour pair within max_separation (a convex combination).
void relaxation(const ChargedModel& m, ChargedState& s, double dt) noexcept {
  const double alpha = std::exp(-m.material.elasticity * dt);
  const double settle2 = (1e-4 * m.spacing) * (1e-4 * m.spacing);
  for (size_t a = 0; a < s.active_count;) {
    const int i = s.active[a];
    const auto k = static_cast<size_t>(i);
    if (s.flags[k] & kWound) {  // a wound's edge: below
      ++a;
      continue;
    }
    const Vec3 o = m.origin(k);
    const Vec3 before = s.position(k);
    const Vec3 d = (before - o) * alpha;
    if (alpha != 1.0) set_position(s, i, o + d);
    // Home when within 1e-4 spacing, or when float resolution stops the approach (no progress).
    if (d.squaredNorm() <= settle2 || (alpha != 1.0 && s.position(k) == before)) {
      set_position(s, i, o);  // leave the active set: swap-remove (deterministic)
      s.flags[k] &= static_cast<std::uint8_t>(~kActive);
      s.active[a] = s.active[--s.active_count];
      continue;
    }
    ++a;
  }
  // A wound's edge returns to its origin moved by its easing offset (docs/models/cutting.md); it
  // stays in the active set (it is away from its origin for good).
  for (size_t w = 0; w < s.wound_count; ++w) {
    const int i = s.wound[w].particle;
    Vec3 now, to;
    wound_offset(m, s, s.wound[w], now, to);
    const Vec3 o = m.origin(static_cast<size_t>(i)) + now;
    if (alpha != 1.0) set_position(s, i, o + (s.position(static_cast<size_t>(i)) - o) * alpha);
  }
}

}  // namespace palpate::charged
