// stages.h — the charged-particle step's stages and the queries they share (internal): the HIP's
// tracks (stage 1), relaxation (2), repulsion (3), the layers above pressing (3b), propagation (4),
// the rest surface under the HIP, the event queue, and cutting (cut.cpp: the links a blade's sweep
// crosses, the wound's opening, the layer's presence over a wound). step.cpp runs them in order and
// computes the force; docs/models/charged-particles.md and cutting.md have the equations and reasoning.
#pragma once

#include <palpate/charged.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <span>

// Hidden: used inside the library only, so called directly rather than through the PLT.
namespace palpate {
namespace charged __attribute__((visibility("hidden"))) {

inline constexpr std::uint8_t kActive = 1, kQueued = 2, kReversed = 4;
inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kOnset = 0.1;            // e / D: the contact law's linear term starts over e
inline constexpr double kSeparationSlack = 1e-5; // relative: float rounding allowed on max_separation
inline constexpr double kPinnedFraction = 1 - 1e-4;  // |p - o| ≥ this · D counts as at maximum displacement

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

void push_event(ChargedState& s, const TissueEvent& e) noexcept;

void set_position(ChargedState& s, int i, const Vec3& p) noexcept;

// A particle left its origin (or moved again): remember it in the active set and queue it for
// the separation rule. Both arrays have capacity n and each particle is in each at most once.
void touch(ChargedState& s, int i, size_t& q_tail) noexcept;

// The rest surface under the HIP: signed distance of h above it (m, along the outward normal) and
// that normal. Generated patches use their exact shape; a mesh patch a smooth kernel-weighted mean
// of the tangent planes at the particles' origins near h (C¹ in h; below).
// False when h is not over the patch (beyond a lattice's edges, or no mesh particle within ρ).
bool rest_surface(const ChargedModel& m, const Vec3& h, double rho, double& dist, Vec3& normal) noexcept;

// The signed height of p over a generated patch's rest surface (plane, cylinder, sphere), without
// the patch's bounds: rest_surface's distance, at a few flops.
double lattice_height(const ChargedModel& m, const Vec3& p) noexcept;

// Where the shaft's line through the tip `h` (pointing along unit `axis`) last crossed a generated
// patch's rest surface coming in from `side` (+1 outer, −1 inner): `point` on the surface and the
// surface's `normal` there toward that side. Searched back along the line in steps of
// `step_length` (at most 8) and bisected. False for a mesh patch, a tip not under the surface, or a
// line that does not come out within 8 steps (then the nearest surface point serves).
bool entry_point(const ChargedModel& m, const Vec3& h, const Vec3& axis, double side, double step_length,
                 Vec3& point, Vec3& normal) noexcept;

// Stage 1 — HIP update: which holes the tool passes through now; exits, and holes that close.
// A tool enters a hole's track when its tip is within R of the track's line and no farther than
// R above the rest surface there (where contact would begin: re-entering an open hole along its
// track meets no resistance), and stays in it until its tip is out — R above the surface (the
// hole's tangent plane; or, withdrawn behind the hole along the shaft `axis`, R clear of the rest
// surface: `over` and `rest_height` are rest_surface's for the tip, unsided): a layer lets
// go of the shaft only when the shaft is out of it, however far a hand drifts it sideways or
// redirects it (the track's centring force pushes back: step.cpp). Leaving outward is clear of
// any contact, so the force resumes from zero. Every way in is also a way to stay: a tool never
// flickers in and out of a track.
// Returns whether the tool is in any track; `near`: whether its tip is by a hole it is in (there the
// patch neither pushes nor is pushed: the tool passes through).
bool update_tracks(const ChargedModel& m, ChargedState& s, const Vec3& tip, const Vec3& axis, bool over,
                   double rest_height, double R, int tissue, bool& near) noexcept;

// Stage 3 — repulsion: a particle inside the HIP's sphere of influence is pushed inward along its
// own surface normal out to the sphere's surface (where the repulsion vanishes), but never beyond
// max_displacement from its origin. Pushing along the normal (not radially, and always inward:
// the tool comes from the outer side) keeps particles from sliding around or over the HIP, so a
// tool cannot slip through or under the patch without puncturing it.
// `side`: +1 for a tool on the outer side, −1 for one inside a two-sided layer (a vessel's lumen):
// particles are then pushed outward.
void repulsion(const ChargedModel& m, ChargedState& s, const Vec3& h, double R, double side,
               size_t& q_tail) noexcept;

// Stage 3b — the layers above press on this one (scene order lists layers from the outside in):
// an active particle of a layer above that lies below this layer's rest surface pushes down, along
// their normals, the particles of this layer within ρ of it sideways that are above it, to its
// level (past this layer's max_displacement if need be: it is carried along). So a layer pushed
// down pushes the one below instead of passing through it; the separation rule then spreads the
// push. Holes (reversed particles) are not pushed.
// Generated lattices only (their sideways search costs a few sites per particle).
void press_from_above(const ChargedModel& m, ChargedState& s, std::span<const ChargedLayer> above,
                      size_t& q_tail) noexcept;

// Stage 4 — propagation (ChainMail, Gibson 1997): a moved particle drags each neighbour that now
// violates max_separation just far enough to satisfy it, keeping the neighbour within its own
// max_displacement; the neighbour is queued in turn. Only disturbed particles are visited.
// `D`: the farthest a particle may be dragged from its origin (max_displacement, more for a layer
// carried along by the layers above it).
void propagation(const ChargedModel& m, ChargedState& s, size_t q_head, size_t q_tail, double D) noexcept;

// Stage 2 — relaxation: every displaced particle returns toward its origin,
// p ← o + (p − o)·exp(−λ·dt), the exact solution of dp/dt = −λ (p − o) over the tick. The same
// factor for all keeps every neighbour pair within max_separation (a convex combination).
void relaxation(const ChargedModel& m, ChargedState& s, double dt) noexcept;

// Cutting (cut.cpp; docs/models/cutting.md) ---------------------------------------------------------

inline constexpr std::uint8_t kWound = 8;       // flags bit 3: on a wound's edge (in state.wound)
inline constexpr std::uint8_t kWoundEdge = 16;  // flags bit 4: scratch mark while a cut is applied
inline constexpr double kBladeMaxSpeed = 1.0;    // m/s: an edge moving faster in a tick jumped (a teleport)
inline constexpr double kPresenceKernel = 1.5;   // spacings: the presence kernel's radius
inline constexpr double kPresenceFull = 0.9;     // share of the rest density that counts as whole tissue
inline constexpr double kDragOnset = 0.01;       // s: the cutting drag builds no faster than this time constant

// A wound edge's rest offset now (m) and the offset it eases to.
inline void wound_offset(const ChargedModel& m, const ChargedState& s, const ChargedWound& w, Vec3& now,
                         Vec3& to) noexcept {
  const double f = std::exp(-m.material.elasticity * std::max(0.0, s.time - w.since));
  to = Vec3(w.to[0], w.to[1], w.to[2]);
  now = to + (Vec3(w.from[0], w.from[1], w.from[2]) - to) * f;
}

// The share of the layer under a tool whose foot on the rest surface is `foot` (normal `n`), in
// [0, 1]: the particles' current density around the foot, sideways, over their rest density there,
// each a sum of the C¹ kernel (1 − r²/ℓ²)², ℓ = kPresenceKernel spacings; full from kPresenceFull of
// it. 1 on whole tissue; falls smoothly to 0 over an open wound, whose edges moved away. So a tool
// drawn across a wound feels it give and the edges come back, without a step (docs/models/cutting.md).
double layer_presence(const ChargedModel& m, const ChargedState& s, const Vec3& foot, const Vec3& n) noexcept;

// Cut every link whose rest segment (origins) crosses the edge's sweep from (heel0, tip0) to
// (heel1, tip1); the edges of the links cut start to part (wound offsets). Returns how many links
// were cut. Allocation-free: scratch is the state's cut_scratch.
int cut_links(const ChargedModel& m, ChargedState& s, const Vec3& heel0, const Vec3& tip0, const Vec3& heel1,
              const Vec3& tip1) noexcept;

}  // namespace charged
}  // namespace palpate
