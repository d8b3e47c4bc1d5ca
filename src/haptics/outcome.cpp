// outcome.cpp — the CVC run's outcome, flashback and trainee metrics: the scene's roles and rest
// surfaces (build_outcome_model) and the allocation-free per-tick state machine over them.
#include <palpate/outcome.h>

#include <algorithm>
#include <cmath>
#include <cstring>

namespace palpate {

namespace {

using Role = OutcomeTissue::Role;
using Shape = OutcomeTissue::Shape;

constexpr int kTracked = 64;  // tissues with a bit in OutcomeState's masks

bool tracked(const OutcomeModel& m, int i) noexcept {
  return i >= 0 && i < kTracked && size_t(i) < m.tissues.size();
}

// The lumen: behind a flat wall, inside a tube (within its extent) or a ball; shape none: anywhere
// (the puncture is all that is known).
bool in_lumen(const OutcomeTissue& t, const Vec3& p) noexcept {
  if (t.shape == Shape::none) return true;
  if (depth_below(t, p) <= 0) return false;
  if (t.shape == Shape::cylinder) return std::abs((p - t.center).dot(t.axis)) <= t.half_length;
  return true;
}

// The rest surface's outward direction at (or nearest to) p; zero when unknown.
Vec3 outward(const OutcomeTissue& t, const Vec3& p) noexcept {
  switch (t.shape) {
    case Shape::flat: return t.normal;
    case Shape::cylinder: {
      const Vec3 d = p - t.center;
      const Vec3 radial = d - d.dot(t.axis) * t.axis;
      const double r = radial.norm();
      return r > 0 ? Vec3(radial / r) : Vec3::Zero();
    }
    case Shape::sphere: {
      const Vec3 d = p - t.center;
      const double r = d.norm();
      return r > 0 ? Vec3(d / r) : Vec3::Zero();
    }
    case Shape::none: break;
  }
  return Vec3::Zero();
}

Outcome classify(const OutcomeState& s) noexcept {
  if (s.outside) return Outcome::outside_model;
  if (s.artery) return Outcome::artery;
  if (s.posterior) return Outcome::posterior_wall;
  if (s.metrics.flashback) return Outcome::vein;
  return Outcome::none;
}

}  // namespace

const char* outcome_name(Outcome outcome) noexcept {
  switch (outcome) {
    case Outcome::vein: return "vein";
    case Outcome::posterior_wall: return "posterior_wall";
    case Outcome::artery: return "artery";
    case Outcome::outside_model: return "outside_model";
    case Outcome::none: break;
  }
  return "none";
}

void patch_frame(const Vec3& n, Vec3& u, Vec3& v) noexcept {
  // The same arithmetic as src/tissue/charged/model.cpp's frame(); OutcomeModel.PatchFrame* tests
  // hold the two together.
  const Vec3 e = std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitZ();
  u = (e - e.dot(n) * n).normalized();
  v = n.cross(u);
}

double depth_below(const OutcomeTissue& t, const Vec3& p) noexcept {
  switch (t.shape) {
    case Shape::flat: return (t.center - p).dot(t.normal);
    case Shape::cylinder: {
      const Vec3 d = p - t.center;
      return t.radius - (d - d.dot(t.axis) * t.axis).norm();
    }
    case Shape::sphere: return t.radius - (p - t.center).norm();
    case Shape::none: break;
  }
  return 0;
}

bool within_edges(const OutcomeTissue& t, const Vec3& p) noexcept {
  if (!(t.half_width > 0) || !(t.half_height > 0)) return true;
  switch (t.shape) {
    case Shape::flat: {
      const Vec3 d = p - t.center;
      return std::abs(d.dot(t.across)) <= t.half_width && std::abs(d.dot(t.along)) <= t.half_height;
    }
    case Shape::cylinder: {
      // The arc from the patch's middle (along `normal`) to p's direction about the axis.
      const Vec3 d = p - t.center;
      const double arc = t.radius * std::atan2(d.dot(t.across), d.dot(t.normal));
      return std::abs(arc) <= t.half_width && std::abs(d.dot(t.axis)) <= t.half_height;
    }
    case Shape::sphere:
    case Shape::none: break;
  }
  return true;
}

OutcomeModel build_outcome_model(const SceneDef& scene) {
  OutcomeModel m;
  m.tissues.resize(scene.tissues.size());
  for (size_t i = 0; i < scene.tissues.size(); ++i) {
    const TissueDef& def = scene.tissues[i];
    OutcomeTissue& t = m.tissues[i];
    if (def.role == "skin") t.role = Role::skin;
    else if (def.role == "vein") t.role = Role::vein;
    else if (def.role == "artery") t.role = Role::artery;
    if (def.role == "skin" && m.skin < 0) m.skin = int(i);
    if (!def.patch || !def.patch->normal.allFinite() || !(def.patch->normal.norm() > 0)) continue;
    const PatchDef& p = *def.patch;
    const Vec3 n = p.normal.normalized();
    Vec3 u, v;
    patch_frame(n, u, v);
    t.across = u;
    t.along = v;
    // The outermost particles lie half the width (a quarter spacing more on alternate rows) and
    // half the height from the middle: the edges where modelled skin ends.
    if (p.shape == "flat" || p.shape == "cylinder") {
      t.half_width = 0.5 * p.width + 0.25 * p.spacing;
      t.half_height = 0.5 * p.height;
    }
    if (p.shape == "flat") {
      t.shape = Shape::flat;
      t.center = p.center;
      t.normal = n;
    } else if (p.shape == "cylinder" || p.shape == "sphere") {
      // The patch's centre lies on the surface; the axis (or the ball's centre) radius behind it.
      t.shape = p.shape == "cylinder" ? Shape::cylinder : Shape::sphere;
      t.center = p.center - p.radius * n;
      t.radius = p.radius;
      t.normal = n;
      t.axis = v;
      t.half_length = 0.5 * p.height;
    }
  }
  return m;
}

void outcome_event(const OutcomeModel& model, OutcomeState& s, const char* kind, int tissue,
                   double time, const Vec3& tip, const Vec3& axis) noexcept {
  if (!kind || std::strcmp(kind, "puncture") != 0 || !tracked(model, tissue)) return;
  const OutcomeTissue& t = model.tissues[size_t(tissue)];
  const std::uint64_t bit = std::uint64_t(1) << tissue;
  switch (t.role) {
    case Role::skin:
      if (tissue != model.skin) break;  // the outermost skin layer counts skin breaks
      ++s.metrics.skin_punctures;
      if (s.metrics.first_skin_puncture < 0) s.metrics.first_skin_puncture = time;
      // Each skin break starts a pass.
      s.under_skin = true;
      ++s.metrics.passes;
      s.advancing = true;
      s.extreme = s.travel;
      break;
    case Role::vein: {
      // From inside the lumen the needle heads out through the wall: the posterior wall. Without
      // geometry, a vein already entered and punctured again is taken as through its back wall.
      bool posterior = false;
      if (t.shape == Shape::none)
        posterior = (s.in_lumen & bit) != 0;
      else
        posterior = outward(t, tip).dot(axis) > 0;
      if (posterior)
        s.posterior = true;
      else
        s.vein_open |= bit;
      break;
    }
    case Role::artery:
      s.artery = true;
      // From outside: its lumen is entered next (an arterial flashback); from inside, out again.
      if (t.shape == Shape::none || outward(t, tip).dot(axis) < 0) s.artery_open |= bit;
      break;
    case Role::other: break;
  }
  s.metrics.outcome = classify(s);
}

bool outcome_tick(const OutcomeModel& model, OutcomeState& s, double time, const Vec3& tip,
                  const Vec3& axis, double force) noexcept {
  TrainingMetrics& m = s.metrics;
  s.redirected = false;
  if (!s.started) {
    s.last_tip = tip;
    s.started = true;
  }
  s.travel += (tip - s.last_tip).dot(axis);
  s.last_tip = tip;
  if (force > m.peak_force) m.peak_force = force;

  s.left_model = false;
  if (model.skin >= 0 && size_t(model.skin) < model.tissues.size()) {
    const OutcomeTissue& skin = model.tissues[size_t(model.skin)];
    if (skin.shape != Shape::none) {
      const double depth = depth_below(skin, tip);
      if (depth > m.deepest_depth) m.deepest_depth = depth;
      if (s.under_skin && depth <= 0) s.under_skin = false;  // back out above the skin
      // Under the skin's rest surface with no skin puncture, beyond the patch's edges: the needle
      // went into the body where no skin (nor anything under it) is modelled. Whatever it meets
      // afterwards is not the trainee's doing: the run is outside_model from here on.
      if (!s.outside && !s.under_skin && depth > 0 && !within_edges(skin, tip)) {
        s.outside = true;
        s.left_model = true;
        s.outside_depth = depth;
      }
    }
  }

  // Passes: a withdrawal of more than pass_distance along the needle, then a re-advance of more
  // than pass_distance, all under the skin (hysteresis on the tip's travel along the needle).
  if (s.under_skin) {
    const double d = model.pass_distance;
    if (s.advancing) {
      if (s.travel > s.extreme)
        s.extreme = s.travel;
      else if (s.travel < s.extreme - d)
        s.advancing = false, s.extreme = s.travel;
    } else {
      if (s.travel < s.extreme)
        s.extreme = s.travel;
      else if (s.travel > s.extreme + d) {
        s.advancing = true, s.extreme = s.travel;
        ++m.passes;
        ++m.redirections;
        s.redirected = true;
      }
    }
  }

  // Flashback: the tip inside the lumen of a vein whose wall it has punctured.
  bool flashback_now = false;
  for (std::uint64_t open = s.vein_open; open != 0; open &= open - 1) {
    const int i = __builtin_ctzll(open);
    if (!tracked(model, i)) continue;
    const OutcomeTissue& t = model.tissues[size_t(i)];
    if (!in_lumen(t, tip)) continue;
    s.in_lumen |= std::uint64_t(1) << i;
    if (!m.flashback) {
      m.flashback = true;
      m.flashback_time = time;
      m.time_to_flashback = time - (m.first_skin_puncture >= 0 ? m.first_skin_puncture : 0.0);
      s.flashback_tissue = i;
      s.flashback_depth = depth_below(t, tip);
      s.flashback_force = force;
      flashback_now = true;
    }
  }
  // The arterial flashback: the tip inside the lumen of an artery whose wall it has punctured.
  s.arterial_now = false;
  for (std::uint64_t open = s.artery_open; open != 0 && !m.arterial_flashback; open &= open - 1) {
    const int i = __builtin_ctzll(open);
    if (!tracked(model, i)) continue;
    const OutcomeTissue& t = model.tissues[size_t(i)];
    if (t.shape != Shape::none && !in_lumen(t, tip)) continue;
    m.arterial_flashback = true;
    m.arterial_flashback_time = time;
    s.arterial_now = true;
    s.arterial_tissue = i;
    s.arterial_depth = depth_below(t, tip);
    s.arterial_force = force;
  }
  m.outcome = classify(s);
  return flashback_now;
}

}  // namespace palpate
