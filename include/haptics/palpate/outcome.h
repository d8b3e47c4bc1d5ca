// palpate/outcome.h — what a CVC run's needle did (vein | posterior_wall | artery | none | outside_model), the
// flashback, and the trainee's metrics (docs/cvc.md, "Outcome and metrics"): a small per-tick state
// machine over the needle's tip and the tissues' puncture events; constant model, stepped state.
#pragma once

#include <palpate/core.h>
#include <palpate/scene_def.h>

#include <cstdint>
#include <vector>

namespace palpate {

// Outcome priority: outside_model > artery > posterior_wall > vein > none.
enum class Outcome : std::uint8_t {
  none,            // no vessel reached
  vein,            // the tip entered the internal jugular vein's lumen (flashback): success
  posterior_wall,  // through the vein's back wall
  artery,          // the carotid's wall punctured (the tip in its lumen)
  outside_model,   // the needle entered the body where no skin is modelled (beyond the skin
                   //   patch's edge): nothing it met after can be scored
};
// "none", "vein", "posterior_wall", "artery", "outside_model": the names summary.json uses.
const char* outcome_name(Outcome outcome) noexcept;

// What simulator studies score trainees by (docs/cvc.md gives the definitions and sources).
struct TrainingMetrics {
  Outcome outcome = Outcome::none;
  int skin_punctures = 0;        // punctures of a skin tissue (skin breaks)
  int passes = 0;                // forward advances under the skin: one per skin puncture, one per
                                 // re-advance > pass_distance after a withdrawal > pass_distance
  int redirections = 0;          // the passes that began under the skin (no new skin puncture)
  bool flashback = false;        // the tip entered a vein's lumen through a punctured wall
  double flashback_time = 0;     // s since the start of the run (when flashback)
  bool arterial_flashback = false;     // the tip entered an artery's lumen through a punctured wall:
                                       //   pulsatile, bright red blood (a complication)
  double arterial_flashback_time = 0;  // s since the start of the run (when arterial_flashback)
  double first_skin_puncture = -1;  // s since the start of the run; < 0 = none
  double time_to_flashback = -1; // s from the first skin puncture (the run's start if none); < 0 = none
  double deepest_depth = 0;      // m, deepest tip below the skin's rest surface (0 if never below)
  double peak_force = 0;         // N, largest force sent to the device
};

// A tissue's part in the outcome, and its rest surface as the classification sees it.
struct OutcomeTissue {
  enum class Role : std::uint8_t { other, skin, vein, artery } role = Role::other;
  enum class Shape : std::uint8_t {
    none,      // no geometry known (a mesh): depth unknown, the lumen entered at the puncture
    flat,      // a plane through `center` with outward `normal`; the lumen lies behind it
    cylinder,  // a tube: axis through `center` along `axis`, `radius`, ±`half_length` along it
    sphere,    // a ball about `center` of `radius`
  } shape = Shape::none;
  Vec3 center = Vec3::Zero();  // m, flat: a point on the surface; cylinder: on the axis at the
                               // patch's middle; sphere: the centre
  Vec3 normal = Vec3::UnitY(); // unit, flat: outward normal
  Vec3 axis = Vec3::UnitZ();   // unit, cylinder: the tube's axis
  double radius = 0;           // m, cylinder and sphere
  double half_length = 0;      // m, cylinder: half the patch's extent along the axis
  // The patch's edges, for the skin (where the body may be entered): half its width across
  // (flat: along `across`; cylinder: the arc from `normal` about the axis) and half its height
  // (flat: along `along`; cylinder: half_length). 0 = unbounded (a mesh, a sphere).
  double half_width = 0;       // m
  double half_height = 0;      // m
  Vec3 across = Vec3::UnitX(); // unit, the patch's u (patch_frame)
  Vec3 along = Vec3::UnitZ();  // unit, the patch's v
};

// The constant part: built once from the scene.
struct OutcomeModel {
  std::vector<OutcomeTissue> tissues;  // (#tissues), by scene index
  int skin = -1;                       // the tissue depth is measured from (first role skin); -1 none
  double pass_distance = 0.002;        // m, advance / withdrawal along the needle that makes a pass
};

// The tissues' roles and rest surfaces from the scene (patches; a mesh's shape is none). Tissues
// without a role skin: none is the skin (no depth, no skin punctures).
OutcomeModel build_outcome_model(const SceneDef& scene);

// A generated patch's frame exactly as the charged-particle model builds it (u ⟂ n from UnitX, or
// UnitZ when |n.x| ≥ 0.9; v = n × u): a cylinder's axis runs along v. Tested against ChargedModel.
void patch_frame(const Vec3& normal, Vec3& u, Vec3& v) noexcept;

// Depth (m) of `p` below tissue t's rest surface: > 0 behind a flat surface, inside a tube or ball;
// 0 for shape none.
double depth_below(const OutcomeTissue& t, const Vec3& p) noexcept;

// Whether `p` lies within tissue t's patch edges (across and along its rest surface, at any depth);
// true for a tissue whose edges are not known (half_width or half_height 0).
bool within_edges(const OutcomeTissue& t, const Vec3& p) noexcept;

// Everything that changes; plain data, copied freely. Tissues past the 64th are not tracked.
struct OutcomeState {
  TrainingMetrics metrics;
  std::uint64_t vein_open = 0;    // bit i: vein i punctured from outside (its lumen may be entered)
  std::uint64_t in_lumen = 0;     // bit i: the tip has been in vein i's lumen (shape none: opened)
  std::uint64_t artery_open = 0;  // bit i: artery i punctured from outside (its lumen may be entered)
  bool posterior = false, artery = false;
  bool under_skin = false;        // a skin puncture, and the tip not back out above the skin since
  bool advancing = true;          // pass state: advancing (else withdrawn > pass_distance)
  double travel = 0;              // m, the tip's advance along the needle, summed over ticks
  double extreme = 0;             // m, travel's max while advancing, min while withdrawn
  Vec3 last_tip = Vec3::Zero();
  bool started = false;
  bool redirected = false;        // this tick began a new pass (a redirection): for the caller's event
  bool outside = false;           // the tip went under the skin's rest surface beyond its edges
                                  //   without a skin puncture: the outcome is outside_model
  bool left_model = false;        // this tick it did so (first time): for the caller's event
  double outside_depth = 0;       // m, then: the tip's depth below the skin's rest surface
  // The flashback, once (for the caller's event).
  int flashback_tissue = -1;
  double flashback_depth = 0;     // m, below the vein wall's rest surface
  double flashback_force = 0;     // N, force sent that tick
  // The arterial flashback, once: this tick (for the caller's event), where and with what force.
  bool arterial_now = false;
  int arterial_tissue = -1;
  double arterial_depth = 0;      // m, below the artery wall's rest surface
  double arterial_force = 0;      // N, force sent that tick
};

// A tissue's event at `time` with the tip where the tissues saw it. Call for each event of a tick
// before that tick's outcome_tick. "puncture" events count; other kinds are ignored.
void outcome_event(const OutcomeModel& model, OutcomeState& state, const char* kind, int tissue,
                   double time, const Vec3& tip, const Vec3& axis) noexcept;

// One tick: the tip (m), the needle's unit axis (handle → tip), the magnitude of the force sent (N).
// Returns true on the tick of the flashback (state.flashback_* say where). Allocation-free.
bool outcome_tick(const OutcomeModel& model, OutcomeState& state, double time, const Vec3& tip,
                  const Vec3& axis, double force) noexcept;

}  // namespace palpate
