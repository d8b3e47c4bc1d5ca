// step.cpp — the charged-particle step kernel pipeline: HIP update, repulsion, propagation
// (separation rule), relaxation (elasticity), force (contact law on the indentation, puncture,
// snap, track centring and shaft friction).
// Equations and reasoning: docs/models/charged-particles.md.
#include <palpate/charged.h>

#include <algorithm>
#include <cmath>

namespace palpate {

namespace {

constexpr std::uint8_t kActive = 1, kQueued = 2, kReversed = 4;
constexpr double kPi = 3.14159265358979323846;
constexpr double kOnset = 0.1;            // e / D: the contact law's linear term starts over e
constexpr double kSeparationSlack = 1e-5; // relative: float rounding allowed on max_separation
constexpr double kPinnedFraction = 1 - 1e-4;  // |p - o| ≥ this · D counts as at maximum displacement

// Calls f(i) for every particle whose origin may lie within `rho` of h (a superset; callers test
// exact distances). Generated lattices invert their (u, v) map, a mesh patch walks its cell grid;
// either way the cost follows the ball's size, never the patch's.
// `lateral`: ignore how far h lies off the surface and visit every site within rho of h's
// projection onto it (lattices only; a mesh patch treats it as an ordinary query).
template <class F>
void for_each_candidate(const ChargedModel& m, const Vec3& h, double rho, F&& f, bool lateral = false) noexcept {
  if (m.layout == ChargedLayout::mesh) {
    std::array<std::int64_t, 3> lo{}, hi{};
    for (int k = 0; k < 3; ++k) {
      const auto kk = static_cast<size_t>(k);
      const double a = std::floor((h[k] - rho - m.grid_min[k]) / m.cell_size);
      const double b = std::floor((h[k] + rho - m.grid_min[k]) / m.cell_size);
      if (b < 0 || a > static_cast<double>(m.grid_dims[kk] - 1)) return;
      lo[kk] = std::max<std::int64_t>(0, static_cast<std::int64_t>(a));
      hi[kk] = std::min<std::int64_t>(m.grid_dims[kk] - 1, static_cast<std::int64_t>(b));
    }
    for (std::int64_t iz = lo[2]; iz <= hi[2]; ++iz)
      for (std::int64_t iy = lo[1]; iy <= hi[1]; ++iy) {
        const std::int64_t row = (iz * m.grid_dims[1] + iy) * m.grid_dims[0];
        const std::int64_t k0 = row + lo[0], k1 = row + hi[0];
        auto it = std::lower_bound(m.cell_key.begin(), m.cell_key.end(), k0);
        for (; it != m.cell_key.end() && *it <= k1; ++it) {
          const size_t cell = static_cast<size_t>(it - m.cell_key.begin());
          for (std::int32_t i = m.cell_start[cell]; i < m.cell_start[cell + 1]; ++i) f(static_cast<int>(i));
        }
      }
    return;
  }
  // Lattice: the HIP's (u, v) and a window of half-widths (du, dv) that holds every origin within
  // rho (chord ≤ arc on bent patches; bounds derived in docs/models/charged-particles.md).
  double u = 0, v = 0, du = rho, dv = rho;
  bool full_u = false, full_v = false;
  const double a = m.radius;
  const Vec3 axis_point = m.center - a * m.normal;
  if (m.layout == ChargedLayout::flat) {
    const Vec3 d = h - m.center;
    const double w = lateral ? 0.0 : d.dot(m.normal);
    if (std::abs(w) >= rho) return;
    u = d.dot(m.tangent_u), v = d.dot(m.tangent_v);
    du = dv = std::sqrt(rho * rho - w * w);
  } else if (m.layout == ChargedLayout::cylinder) {
    const Vec3 w = h - axis_point;
    const double x = w.dot(m.tangent_u), z = w.dot(m.normal), rh = lateral ? a : std::hypot(x, z);
    if (std::abs(rh - a) >= rho) return;
    v = w.dot(m.tangent_v);
    const double arg = rh > 0 ? rho / (2 * std::sqrt(rh * a)) : 2.0;
    if (arg >= 1) full_u = true;
    else u = a * std::atan2(x, z), du = a * 2 * std::asin(arg);
  } else {  // sphere
    const Vec3 w = lateral ? Vec3(a * (h - axis_point).normalized()) : Vec3(h - axis_point);
    const double rh = w.norm();
    if (std::abs(rh - a) >= rho) return;
    const double arg = rh > 0 ? rho / (2 * std::sqrt(rh * a)) : 2.0;
    if (arg >= 1) {
      full_u = full_v = true;
    } else {
      const double gamma = 2 * std::asin(arg);  // largest angle between directions
      const double theta = std::asin(std::clamp(w.dot(m.tangent_v) / rh, -1.0, 1.0));
      v = a * theta, dv = a * gamma;
      if (std::abs(theta) + gamma >= kPi / 2) full_u = true;
      else u = a * std::atan2(w.dot(m.tangent_u), w.dot(m.normal)),
           du = a * std::asin(std::min(1.0, std::sin(gamma) / std::cos(theta)));
    }
  }
  int r0 = 0, r1 = m.rows - 1;
  if (!full_v) {
    r0 = std::max(0, static_cast<int>(std::floor((v - dv + m.v_mid) / m.row_pitch)));
    r1 = std::min(m.rows - 1, static_cast<int>(std::ceil((v + dv + m.v_mid) / m.row_pitch)));
  }
  // Up to two u ranges: a bent patch's window may wrap across ±π·radius.
  double ranges[2][2] = {{u - du, u + du}, {0, -1}};
  int nranges = 1;
  if (!full_u && m.layout != ChargedLayout::flat) {
    const double half = kPi * a;
    if (u + du > half) ranges[1][0] = u - du - 2 * half, ranges[1][1] = u + du - 2 * half, nranges = 2;
    else if (u - du < -half) ranges[1][0] = u - du + 2 * half, ranges[1][1] = u + du + 2 * half, nranges = 2;
  }
  for (int r = r0; r <= r1; ++r) {
    const double shift = 0.5 * (r & 1);
    int last = -1;  // the two ranges never overlap, but stay safe against double visits
    for (int k = 0; k < nranges; ++k) {
      int c0 = 0, c1 = m.cols - 1;
      if (!full_u) {
        c0 = std::max(0, static_cast<int>(std::floor((ranges[k][0] + m.u_mid) / m.spacing - shift)));
        c1 = std::min(m.cols - 1, static_cast<int>(std::ceil((ranges[k][1] + m.u_mid) / m.spacing - shift)));
      }
      c0 = std::max(c0, last + 1);
      for (int c = c0; c <= c1; ++c) f(r * m.cols + c);
      last = std::max(last, c1);
      if (full_u) break;
    }
  }
}

void push_event(ChargedState& s, const TissueEvent& e) noexcept {
  if (s.event_count == s.events.size()) {  // full: drop the oldest
    s.event_head = (s.event_head + 1) % s.events.size();
    --s.event_count;
    ++s.events_dropped;
  }
  s.events[(s.event_head + s.event_count) % s.events.size()] = e;
  ++s.event_count;
}

// Distance from point c to the segment [a, b], and the segment's point nearest to c.
double segment_distance(const Vec3& a, const Vec3& b, const Vec3& c, Vec3& nearest) noexcept {
  const Vec3 ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0 ? std::clamp((c - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  nearest = a + t * ab;
  return (c - nearest).norm();
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

// Stage 1 — HIP update: which holes the tool passes through now; exits, and holes that close.
// A tool enters a hole's track when its tip is within R of the track's line and no farther than
// R above the rest surface there (where contact would begin: re-entering an open hole along its
// track meets no resistance), and stays in it while its tip is within R + D of the line or its
// shaft passes within R + D of the hole's centre, and the tip is less than R above the surface
// (leaving sideways tears out; leaving outward is clear of any contact, so the force resumes from
// zero). Every way in is also a way to stay: a tool never flickers in and out of a track.
// Returns whether the tool is in any track; `near`: whether its tip is by a hole it is in (there the
// patch neither pushes nor is pushed: the tool passes through).
bool update_tracks(const ChargedModel& m, ChargedState& s, const Vec3& tip, const Vec3& tail, double R,
                   int tissue, bool& near) noexcept {
  const double D = m.material.max_displacement;
  bool any = false;
  near = false;
  for (ChargedHole& hole : s.holes) {
    if (!hole.open) continue;
    const double height = (tip - hole.surface).dot(hole.normal);
    Vec3 e = tip - hole.center;
    e -= e.dot(hole.axis) * hole.axis;  // the tip's offset from the track's line
    const double offset = e.norm();
    bool now = false;
    if (height < R) {
      // Stays while the tip is near the line or the shaft still passes the hole (a tilt about it).
      Vec3 q;
      now = hole.in_track ? offset < R + D || segment_distance(tail, tip, hole.center, q) < R + D
                          : offset < R;
    }
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
    // R over it) and by the hole (sideways within R + D): there the patch must not be met anew.
    // A tip on the track far beyond the band (across a vessel's lumen) meets the layer again.
    near = near || (hole.in_track && height > -(D + 2 * R) && offset < R + D);
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
    const int count = m.neighbours_of(i, nb);
    for (int a = 0; a < count; ++a) {
      const int j = nb[static_cast<size_t>(a)];
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
}

}  // namespace

double charged_contact_force(const ChargedMaterialDef& mat, double delta) noexcept {
  if (!(delta > 0)) return 0.0;
  const double D = mat.max_displacement, Fp = mat.puncture_force, beta = mat.linear_share;
  const double e = kOnset * D;
  const double a1 = beta * Fp / (D - 0.5 * e), a2 = (1 - beta) * Fp / (D * D);
  const double psi = delta < e ? delta * delta / (2 * e) : delta - 0.5 * e;
  return a1 * psi + a2 * delta * delta;
}

double charged_snap_force(const ChargedMaterialDef& mat, double age) noexcept {
  const double tau = mat.puncture_time;
  if (!(tau > 0) || !(age > tau) || !(age < 2 * tau)) return 0.0;
  const double x = age / tau - 1, b = x * (1 - x);
  return mat.snap_share * mat.puncture_force * 16 * b * b;
}

double charged_track_force(const ChargedMaterialDef& mat, double offset, double R) noexcept {
  if (!(R > 0)) return 0.0;
  return mat.puncture_force * std::tanh(offset / R);
}

Vec3 step(const ChargedModel& m, ChargedState& s, const ChargedHip& hip, double dt, int tissue,
          std::span<const ChargedLayer> above) noexcept {
  s.stats.contacts = s.stats.pinned = 0;
  s.stats.propagation_visits = s.stats.propagation_moves = s.stats.candidates = 0;
  s.stats.indentation = s.stats.shaft_in_layer = 0;
  const ChargedMaterialDef& mat = m.material;
  const double D = mat.max_displacement;
  if (!hip.position.allFinite() || !hip.axis.allFinite() || !hip.velocity.allFinite() ||
      !std::isfinite(hip.shaft_length) || !std::isfinite(hip.radius) || !std::isfinite(dt) || dt < 0) {
    reset(m, s);
    ++s.stats.numeric_resets;
    push_event(s, TissueEvent{s.time, "reset", tissue, 0.0, 0.0});
    return Vec3::Zero();
  }
  s.time += dt;
  const double R = std::max(0.0, hip.radius) + mat.particle_radius;  // the sphere of influence
  const Vec3 h = hip.position;
  const Vec3 axis = hip.axis.norm() > 1e-12 ? Vec3(hip.axis.normalized()) : Vec3(0, -1, 0);
  const Vec3 tail = h - axis * std::max(0.0, hip.shaft_length);

  // 1. HIP update.
  bool near_hole = false;
  const bool in_track = update_tracks(m, s, h, tail, R, tissue, near_hole);
  // 2. Relaxation: first, so that what pushes this tick (the tool, the layers above) has the last
  // word — contact particles end the tick on the tool's sphere, pressed ones under the layer above.
  relaxation(m, s, dt);
  // Where the tool is against the rest surface, and from which side: a two-sided layer (a vessel
  // wall) is met from inside too, its side fixed while the contact lasts.
  const double reach = R + D + 3 * m.spacing;
  double dist = 0;
  Vec3 normal = Vec3::Zero();
  const bool over = rest_surface(m, h, reach, dist, normal);
  if (over && mat.two_sided && !s.engaged) s.side = dist >= 0 ? 1 : -1;
  if (!mat.two_sided) s.side = 1;
  dist *= s.side, normal *= s.side;
  // 3. Repulsion (a tool inside a hole's track passes through: the patch does not push it).
  size_t q_tail = 0;
  if (!near_hole) repulsion(m, s, h, R, s.side, q_tail);
  // 3b. The layers above press on this one.
  const size_t before_press = q_tail;
  press_from_above(m, s, above, q_tail);
  const bool pressed = q_tail > before_press;
  // 4. Propagation; then twice more the press and the separation rule (it may have pulled a pressed
  // particle back toward a neighbour held at its max_displacement).
  // A layer under others may be carried as far as they reach: its neighbours follow it there.
  double carried = D;
  for (const ChargedLayer& layer : above)
    if (layer.model) carried = std::max(carried, D + layer.model->material.max_displacement);
  propagation(m, s, 0, q_tail, carried);
  for (int round = 0; round < 2 && pressed; ++round) {
    q_tail = 0;
    press_from_above(m, s, above, q_tail);
    propagation(m, s, 0, q_tail, carried);
  }
  double max_d2 = 0;
  for (size_t a = 0; a < s.active_count; ++a) {
    const auto k = static_cast<size_t>(s.active[a]);
    max_d2 = std::max(max_d2, (s.position(k) - m.origin(k)).squaredNorm());
  }
  s.stats.max_displacement = std::sqrt(max_d2);

  // 5. Force on the HIP.
  Vec3 force = Vec3::Zero();
  bool contact = false;
  double contact_force = 0;  // N, |the contact law's force| this tick (the track's forces apart)
  if (near_hole) {
    s.engaged = false;
  } else {
    // Contact: the law Φ of the indentation δ = R − (height of h above the rest surface), along
    // the surface's normal on the tool's side. δ measures the tool against the surface the
    // particles sample, so it is the same at any spacing, and a function of the tool's position
    // alone (any dt).
    if (!over) {
      s.engaged = false;
    } else {
      const double delta = R - dist;
      // Contact is engaged from the outside: first touch at an indentation up to D, then held
      // down to D + 2R. A tool that appears deeper (started under the layer, or jumped) is under
      // it, not pressing it, until it comes back out.
      s.engaged = delta > 0 && (s.engaged ? delta <= D + 2 * R : delta <= D);
      if (s.engaged) {
        contact = true;
        s.stats.indentation = delta;
        // Puncture: a needle whose indentation reaches max_displacement (Φ(D) = puncture_force);
        // the force of this tick is the law's value there, not past it (a tool that jumped deep).
        // A layer under one the tool is still pressing (not through) is pressed by that layer, not
        // cut by the needle: it cannot be punctured before the layer above it is.
        bool covered = false;
        for (const ChargedLayer& layer : above) covered = covered || (layer.state && layer.state->engaged);
        const bool puncture = hip.sharp && delta >= D && !covered;
        // A covered layer at max_displacement under a needle carries its puncture force, no more:
        // it tears as soon as the layer above lets the needle through.
        const double held = hip.sharp && (puncture || covered) ? std::min(delta, D) : delta;
        force = charged_contact_force(mat, held) * normal;
        contact_force = force.norm();
        if (puncture) {
          ChargedHole& hole = s.holes[static_cast<size_t>(s.next_hole)];
          s.next_hole = (s.next_hole + 1) % kChargedMaxHoles;
          hole.center = h, hole.axis = axis, hole.in_track = true, hole.open = true;
          hole.surface = h - dist * normal, hole.normal = normal, hole.bristle = 0;
          // The give below carries this tick's force from here on — only if the hand already felt
          // the contact on the last tick: a tool that jumped into the layer gets no pop.
          s.give = s.contact_peak > 0 ? force : Vec3::Zero();
          s.give_age = 0;
          s.engaged = false;
          force.setZero();
          for_each_candidate(m, h, R + D, [&](int i) {
            if ((s.position(static_cast<size_t>(i)) - h).norm() < R) s.flags[static_cast<size_t>(i)] |= kReversed;
          });
          s.contact_peak = std::max(s.contact_peak, s.give.norm());
          push_event(s, TissueEvent{s.time, "puncture", tissue, -dist, s.contact_peak});
        }
      }
    }
    // Figures: particles in the sphere of influence, and those at maximum displacement.
    const double pinned_at = kPinnedFraction * D;
    for_each_candidate(m, h, R + D, [&](int i) {
      const auto k = static_cast<size_t>(i);
      if (s.flags[k] & kReversed) return;
      if (!((s.position(k) - h).squaredNorm() < R * R)) return;
      ++s.stats.contacts;
      if ((s.position(k) - m.origin(k)).norm() >= pinned_at) ++s.stats.pinned;
    });
  }
  if (in_track) {
    const double v_axial = hip.velocity.dot(axis);
    const double T = mat.thickness, z0 = mat.friction_presliding;
    // Dahl's bristle over this tick's axial travel x = v·dt, solved exactly for constant v:
    // dz/dx = 1 − sgn(v)·z/z0, so z → z0·sgn(v) + (z − z0·sgn(v))·e^(−|x|/z0). A function of the
    // travel, not the tick; a reversal moves the friction smoothly through zero over ~z0.
    for (ChargedHole& hole : s.holes) {
      if (!hole.in_track) continue;
      // Centring: the shaft point nearest the hole's centre is pulled back toward the track's line.
      Vec3 q;
      segment_distance(tail, h, hole.center, q);
      Vec3 off = q - hole.center;
      off -= off.dot(hole.axis) * hole.axis;
      const double off_norm = off.norm();
      if (off_norm > 0) force -= charged_track_force(mat, off_norm, R) * (off / off_norm);
      // Friction on the length of shaft inside the layer (Okamura et al. 2004): the part of the
      // segment tail → tip whose depth below the rest surface lies in [0, thickness], times the
      // kinetic friction per unit length and the Dahl bristle's share of it.
      const double d_tip = (hole.surface - h).dot(hole.normal), d_tail = (hole.surface - tail).dot(hole.normal);
      const double lo = std::min(d_tip, d_tail), hi = std::max(d_tip, d_tail);
      const double overlap = std::max(0.0, std::min(hi, T) - std::max(lo, 0.0));
      const double length = hi > lo ? overlap / (hi - lo) * (h - tail).norm() : 0.0;
      s.stats.shaft_in_layer += length;
      const double x = v_axial * dt, target = x > 0 ? z0 : (x < 0 ? -z0 : hole.bristle);
      hole.bristle = target + (hole.bristle - target) * std::exp(-std::abs(x) / z0);
      force -= mat.friction_per_length * length * (hole.bristle / z0) * axis;
    }
  }
  // The pop: the force at the last puncture falls to zero over puncture_time (smoothstep, C¹) as
  // the torn layer lets go — no faster than a device can render it — then the hole's reversed
  // charges pull the tool on into the tissue over the next puncture_time: the seed's snap.
  const double tau = mat.puncture_time;
  if (tau > 0 && s.give_age < 2 * tau) {
    const double x = s.give_age / tau;
    if (x < 1) force += s.give * (1 - x * x * (3 - 2 * x));
    if (mat.puncture_force > 0) force += charged_snap_force(mat, s.give_age) * (s.give.norm() / mat.puncture_force) * axis;
    s.give_age += dt;
  }
  if (!force.allFinite()) {
    reset(m, s);
    ++s.stats.numeric_resets;
    push_event(s, TissueEvent{s.time, "reset", tissue, 0.0, 0.0});
    return Vec3::Zero();
  }
  s.contact_peak = contact ? std::max(s.contact_peak, contact_force) : 0.0;
  s.force = force;
  return force;
}

size_t drain_events(ChargedState& s, std::span<TissueEvent> out) noexcept {
  const size_t n = std::min(out.size(), s.event_count);
  for (size_t k = 0; k < n; ++k) out[k] = s.events[(s.event_head + k) % s.events.size()];
  s.event_head = (s.event_head + n) % s.events.size();
  s.event_count -= n;
  return n;
}

}  // namespace palpate
