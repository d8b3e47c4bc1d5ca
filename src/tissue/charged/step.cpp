// step.cpp — the charged-particle step: its stages in order (stages.cpp: HIP update, relaxation,
// repulsion, propagation by the separation rule), then the force (contact law on the indentation,
// puncture, snap, track centring and shaft friction) and a blade's cut and drag (cut.cpp).
// Equations and reasoning: docs/models/charged-particles.md.
#include <palpate/charged.h>

#include "tissue/charged/stages.h"

#include <algorithm>
#include <cmath>

namespace palpate {

using namespace charged;

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

double charged_coulomb_force(double kqq, double r, double R) noexcept {
  if (!(r < R) || !(R > 0)) return 0.0;
  const double rc = std::max(r, 0.1 * R);
  return kqq * (1 / (rc * rc) - 1 / (R * R));
}

Vec3 step(const ChargedModel& m, ChargedState& s, const ChargedHip& hip, double dt, int tissue,
          std::span<const ChargedLayer> above) noexcept {
  s.stats.contacts = s.stats.pinned = 0;
  s.stats.propagation_visits = s.stats.propagation_moves = s.stats.candidates = 0;
  s.stats.indentation = s.stats.shaft_in_layer = 0;
  s.stats.edge_in_layer = 0, s.stats.presence = 1, s.stats.links_cut = 0, s.stats.cutting = false;
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

  // Where the tool is against the rest surface (the tracks' exits need it too).
  const double reach = R + D + 3 * m.spacing;
  double dist = 0;
  Vec3 normal = Vec3::Zero();
  const bool over = rest_surface(m, h, reach, dist, normal);
  // 1. HIP update.
  bool near_hole = false;
  const bool in_track = update_tracks(m, s, h, axis, over, dist, R, tissue, near_hole);
  // 2. Relaxation: first, so that what pushes this tick (the tool, the layers above) has the last
  // word — contact particles end the tick on the tool's sphere, pressed ones under the layer above.
  relaxation(m, s, dt);
  // From which side the tool meets the surface: a two-sided layer (a vessel wall) is met from
  // inside too, its side fixed while the contact lasts.
  if (over && mat.two_sided && !s.engaged) s.side = dist >= 0 ? 1 : -1;
  if (!mat.two_sided) s.side = 1;
  dist *= s.side, normal *= s.side;
  // force_model coulomb: the seed's force, from the particles where the tool finds them this tick
  // — relaxed, not yet repelled (so it is stiffer the longer the tick, and grows with the
  // particles' density: docs/models/charged-particles.md).
  const double pinned_at = kPinnedFraction * D;
  Vec3 coulomb_force = Vec3::Zero();
  if (m.coulomb && !near_hole)
    for_each_candidate(m, h, R + D, [&](int i) {
      const auto k = static_cast<size_t>(i);
      if (s.flags[k] & kReversed) return;
      const Vec3 d = s.position(k) - h;
      const double r = d.norm();
      if (r > 0 && r < R) coulomb_force -= charged_coulomb_force(m.coulomb_kqq, r, R) * (d / r);
    });
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
  double contact_force = 0;  // N, |the contact force| this tick (the track's forces apart)
  // A layer under one the tool is still pressing (not through) is pressed by that layer, not cut by
  // the needle: it cannot be punctured before the layer above it is.
  bool covered = false;
  for (const ChargedLayer& layer : above) covered = covered || (layer.state && layer.state->engaged);
  // A puncture: the particles in the sphere of influence reverse their charge and a hole opens
  // where the shaft came through the rest surface (on a vessel tented deep before it gave, the
  // nearest surface point may be on its flank instead). The give below carries this tick's force
  // from here on — only if the hand already felt the contact on the last tick: a tool that jumped
  // into the layer gets no pop.
  // Figures: particles in the sphere of influence, and those held at maximum displacement.
  auto count_contacts = [&] {
    for_each_candidate(m, h, R + D, [&](int i) {
      const auto k = static_cast<size_t>(i);
      if (s.flags[k] & kReversed) return;
      if (!((s.position(k) - h).squaredNorm() < R * R)) return;
      ++s.stats.contacts;
      if ((s.position(k) - m.origin(k)).norm() >= pinned_at) ++s.stats.pinned;
    });
  };
  auto open_hole = [&] {
    ChargedHole& hole = s.holes[static_cast<size_t>(s.next_hole)];
    s.next_hole = (s.next_hole + 1) % kChargedMaxHoles;
    hole.center = h, hole.axis = axis, hole.in_track = true, hole.open = true;
    hole.surface = h - dist * normal, hole.normal = over ? normal : Vec3(-axis), hole.side = s.side, hole.bristle = 0;
    entry_point(m, h, axis, s.side, std::max(D, R), hole.surface, hole.normal);
    s.give = s.contact_peak > 0 ? force : Vec3::Zero();
    s.give_age = 0;
    s.engaged = false;
    force.setZero();
    for_each_candidate(m, h, R + D, [&](int i) {
      if ((s.position(static_cast<size_t>(i)) - h).norm() < R) s.flags[static_cast<size_t>(i)] |= kReversed;
    });
    s.contact_peak = std::max(s.contact_peak, s.give.norm());
    push_event(s, TissueEvent{s.time, "puncture", tissue, -dist, s.contact_peak});
  };
  if (near_hole) {
    s.engaged = false;
  } else if (m.coulomb) {
    // The seed's contact force (force_model coulomb): the Coulomb sum over the particles in the
    // sphere of influence where this tick found them (before the repulsion moved them), and the
    // seed's puncture: a needle with a particle held at max_displacement and the sum past the
    // puncture force.
    count_contacts();
    force = coulomb_force;
    contact_force = force.norm();
    contact = contact_force > 0;
    s.engaged = contact;
    if (over) s.stats.indentation = std::max(0.0, R - dist);
    if (hip.sharp && contact && s.stats.pinned > 0 && contact_force >= mat.puncture_force && !covered) open_hole();
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
        // Over a cut, only the share of the layer still under the tool pushes back (the wound's
        // gap: none; its edges: the rise back to whole tissue), and a needle in the gap punctures
        // nothing (docs/models/cutting.md). An uncut patch skips this (bit-identical to before).
        double presence = 1;
        if (s.cut_link_count > 0) presence = s.stats.presence = layer_presence(m, s, h - dist * normal, normal);
        const bool puncture = hip.sharp && delta >= D && !covered && presence >= 0.5;
        // A covered layer at max_displacement under a needle carries its puncture force, no more:
        // it tears as soon as the layer above lets the needle through.
        const double held = hip.sharp && (puncture || covered) ? std::min(delta, D) : delta;
        force = charged_contact_force(mat, held) * normal;
        if (presence != 1) force *= presence;
        contact_force = force.norm();
        if (puncture) open_hole();
      }
    }
    count_contacts();
  }
  // A blade: it cuts what its edge swept through since the last tick while pressed past
  // cutting_force, and drags while it cuts (docs/models/cutting.md).
  if (hip.blade) {
    const double L = hip.edge_length;
    const bool edge_ok = std::isfinite(L) && L > 0;
    const Vec3 heel = h - axis * (edge_ok ? L : 0.0);
    const Vec3 moved = h - s.blade_tip;
    const double travel = std::max(moved.norm(), (heel - s.blade_heel).norm());
    const bool jumped = s.blade_valid && !(travel <= kBladeMaxSpeed * dt);
    if (jumped) ++s.stats.blade_jumps;
    // Once it has parted the layer, a blade drawn along its incision goes on cutting what its edge
    // meets while its tip stays under the rest surface: the wound no longer holds it at
    // cutting_force (it has parted), and a scalpel drawn on makes one incision, not a row of nicks.
    const bool drawn_on = s.cut_stroke && over && dist < 0;
    const bool cutting = edge_ok && s.blade_valid && !jumped && dt > 0 && !near_hole &&
                         ((contact && contact_force >= mat.cutting_force) || drawn_on);
    s.stats.cutting = cutting;
    if (cutting) {
      const int n = cut_links(m, s, s.blade_heel, s.blade_tip, heel, h);
      s.stats.links_cut = n;
      if (n > 0 && !s.cut_stroke) push_event(s, TissueEvent{s.time, "cut", tissue, -dist, contact_force});
      if (n > 0) s.cut_stroke = true;
    } else {
      s.cut_stroke = false;
    }
    // The drag: cutting_drag_per_length × the edge's length inside the layer (depth in
    // [0, thickness] below the rest surface), against the edge's motion along the surface, through
    // a Dahl bristle (like the shaft's friction) that builds over friction_presliding of travel and
    // no faster than kDragOnset, and lets go over puncture_time once the blade stops cutting.
    if (over && edge_ok) {
      const double d_tip = -dist, d_heel = -dist + L * axis.dot(normal);
      const double lo = std::min(d_tip, d_heel), hi = std::max(d_tip, d_heel);
      const double overlap = std::max(0.0, std::min(hi, mat.thickness) - std::max(lo, 0.0));
      s.stats.edge_in_layer = hi > lo ? overlap / (hi - lo) * L : (lo >= 0 && lo <= mat.thickness ? L : 0.0);
    }
    const double z0 = mat.friction_presliding;
    Vec3 along = Vec3::Zero();
    if (s.blade_valid && !jumped) along = moved - moved.dot(normal) * normal;
    const double x = along.norm();
    const double onset = 1 - std::exp(-dt / kDragOnset);
    if (cutting) {
      if (x > 0) s.cut_bristle += (z0 / x * along - s.cut_bristle) * std::min(1 - std::exp(-x / z0), onset);
    } else {
      const double tau = mat.puncture_time > 0 ? mat.puncture_time : kDragOnset;
      s.cut_bristle *= std::exp(-dt / tau);
    }
    force -= mat.cutting_drag_per_length * s.stats.edge_in_layer / z0 * s.cut_bristle;
    s.blade_heel = heel, s.blade_tip = h, s.blade_valid = edge_ok;
  } else {
    s.blade_valid = false;
    s.cut_bristle = Vec3::Zero();
  }
  if (in_track) {
    const double v_axial = hip.velocity.dot(axis);
    const double T = mat.thickness, z0 = mat.friction_presliding;
    // Dahl's bristle over this tick's axial travel x = v·dt, solved exactly for constant v:
    // dz/dx = 1 − sgn(v)·z/z0, so z → z0·sgn(v) + (z − z0·sgn(v))·e^(−|x|/z0). A function of the
    // travel, not the tick; a reversal moves the friction smoothly through zero over ~z0.
    for (ChargedHole& hole : s.holes) {
      if (!hole.in_track) continue;
      // The length of shaft inside the layer: the part of the segment tail → tip whose depth below
      // the rest surface lies in [0, thickness].
      const double d_tip = (hole.surface - h).dot(hole.normal), d_tail = (hole.surface - tail).dot(hole.normal);
      const double lo = std::min(d_tip, d_tail), hi = std::max(d_tip, d_tail);
      const double overlap = std::max(0.0, std::min(hi, T) - std::max(lo, 0.0));
      const double length = hi > lo ? overlap / (hi - lo) * (h - tail).norm() : 0.0;
      s.stats.shaft_in_layer += length;
      // Centring: where the shaft's line passes the hole's centre, its offset e from the track's
      // line is pulled back with F_p·tanh(e/R) — growing with e and saturating at F_p, however far
      // the shaft is drifted or redirected: the layer holds it while it is inside. The layer grips
      // over its first min(thickness, R) of shaft, so the pull fades to zero as the tip comes out
      // (a redirected needle withdrawn is let go smoothly, no catch at the surface). A line, not the
      // segment: on a straight withdrawal e stays as it was, and the pull only falls.
      const double grip = std::min(T, R);
      const double held = grip > 0 ? std::min(1.0, length / grip) : 1.0;
      Vec3 off = h - hole.center;
      off -= off.dot(axis) * axis;                 // the line's point nearest the centre, from it
      off -= off.dot(hole.axis) * hole.axis;       // across the track
      const double off_norm = off.norm();
      if (off_norm > 0 && held > 0) force -= held * charged_track_force(mat, off_norm, R) * (off / off_norm);
      // Friction on that length (Okamura et al. 2004): the kinetic friction per unit length times
      // the Dahl bristle's share of it.
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
