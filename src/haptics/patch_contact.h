// patch_contact.h — the haptic thread's contact solve against a compliant surface patch
// (ContactPatch, issue 24): the tool's sphere pressed into the patch's triangles with a penalty,
// the patch's points moving under the contact load through its compliance W, every tick.
#pragma once

#include <palpate/haptics.h>

#include <array>

namespace palpate {

// Scratch of one solve (the points' positions under load, their loads' directions): sized by the
// patch's capacity, kept by the caller, so the solve never allocates.
struct PatchScratch {
  std::array<Vec3, ContactPatch::kMaxPoints> free{};      // the free positions at this tick
  std::array<Vec3, ContactPatch::kMaxPoints> position{};
  std::array<Vec3, ContactPatch::kMaxPoints> g{};
  std::array<int, ContactPatch::kMaxPoints> loaded{};  // the points with g ≠ 0, loaded_count of them
};

struct PatchContact {
  Vec3 force = Vec3::Zero();  // N, on the tool
  double depth = 0;           // m, Φ at the solution
  double stiffness = 0;       // N/m, dF/dΦ at the solution: k / (1 + k w), 0 out of contact; the
                              // contact's Jacobian on the tool is −stiffness · d dᵀ, d the force's
                              // direction (for the virtual coupling's implicit proxy step)
  int iterations = 0;
  bool valid = false;         // false: the tool is outside the patch's reach (or inside the organ
                              // deeper than its radius); the caller renders something else
};

// The penalty contact of the sphere (centre, radius) with the patch (docs/haptics.md, Multi-rate):
// the same law as the mass-spring model's surface contact (docs/models/mass-spring.md, "Contact")
// — each triangle t whose closest point p_t at the loaded positions y lies within the radius on
// its outer side is pressed with weight φ_t = r − |c − p_t| along n_t = (c − p_t)/|c − p_t|, depth
// Φ = max φ_t, direction sums g_i = Σ_t ω_t w_t,i n_t with |Σ ω_t n_t| = 1, force F = k Φ along
// Σ ω_t n_t — with the points under the load −F g: y = x_free − W g F. Solved by Newton on F with
// the geometry re-evaluated each iteration: with w = gᵀ W g (m/N, the compliance along g),
//   F⁺ = max(0, k (Φ(y) + w F) / (1 + k w)),   y ← x_free − W g F⁺,
// (half steps from the third iteration on, so a contact set that changes with the load does not
// make it cycle) until F changes by less than 1e-9·(1 + F) N or `max_iterations`. k = min(patch.stiffness,
// max_stiffness): the rendered stiffness dF/dc = k / (1 + k w) never exceeds the device's.
// noexcept, no allocation: O(iterations · (triangles + points · loaded points)).
// `elapsed` (s, ≥ 0): the time since the step that published the patch; the free positions are
// taken as x_free + elapsed · v_free (the organ goes on moving between its steps as it moved at the
// step: holding them for the whole period renders a sawtooth at the physics rate, the force rising
// with the tool against a frozen surface and falling back at each new step).
PatchContact solve_patch(const ContactPatch& patch, const Vec3& centre, double radius, double max_stiffness,
                         PatchScratch& scratch, double elapsed = 0, int max_iterations = 24) noexcept;

}  // namespace palpate
