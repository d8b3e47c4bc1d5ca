// blade.h — a blade against a mass-spring organ (internal; used by the scene tissue, tissue.cpp):
// which springs its edge cuts each tick, and the force the hand feels while it cuts
// (docs/models/cutting.md, "Mass-spring organs").
#pragma once

#include <palpate/spring.h>

#include "core/blade_sweep.h"

#include <array>
#include <cstdint>
#include <vector>

namespace palpate::spring {

struct BladeSettings {
  double cutting_force = 1.0;       // N, contact force at which the blade starts to part the organ
  double drag_per_length = 170.0;   // N/m of edge inside the organ while cutting
  double max_jump = 0.005;          // m per tick: a blade that moved farther teleported (a glitch): no cut
  double force_rate = 100.0;        // N/s, the fastest the felt force changes while cutting (below the
                                    // safety filter's 200 N/s, so the filter never has to act)
  double hold_time = 0.02;          // s after the last cut over which the felt force stays rate-limited
  double withdrawn = 0.0005;        // m the tip must come back out of the organ's surface to stop cutting
  double drag_speed = 0.005;        // m/s below which the drag fades linearly to zero (no chatter at rest)
  double relax_time = 0.05;         // s over which the dimple pressed before the tissue parted springs back
  double cut_speed = 0.005;         // m/s below which the parting resistance fades linearly to zero
};

class BladeCut {
 public:
  BladeCut(const SpringModel& model, SpringCutter& cutter, const BladeSettings& settings);
  // Before the step: while cutting (the contact force of the last step reached cutting_force, and
  // from then until the tip is drawn back out of the organ's surface), remove the springs the edge's sweep since the last tick crosses,
  // and, while pressed past cutting_force, those within reach of its tip (it parts what it presses).
  // Returns how many springs were removed. noexcept, no allocation.
  int cut(const SpringState& state, const ToolState& tool, double dt) noexcept;
  // After the step: the force to render from the organ's contact force on the blade. While cutting
  // and moving: the contact across the motion, and along it −(cutting_force + drag_per_length · edge in
  // the organ) (each fading to zero below cut_speed, drag_speed; only the drag when drawn back out);
  // held still, the contact at most cutting_force. Every change while cutting rate-limited to force_rate.
  Vec3 felt(const Vec3& contact, const ToolState& tool, double dt) noexcept;
  void reset() noexcept;

  bool cutting() const noexcept { return cutting_; }
  std::uint64_t jumps() const noexcept { return jumps_; }      // sweeps refused as teleports
  std::uint64_t springs_cut() const noexcept { return cut_; }
  // m of edge in the organ: the tip's depth below the organ's own surface over it, along its normal,
  // over the cosine of the edge's angle to that normal (at most the edge's length).
  double depth() const noexcept { return depth_; }

 private:
  bool surface_normal_near(const Vec3& p, const Vec3& lo, const Vec3& hi) noexcept;
  bool surface_over(const Vec3& p, const Vec3& lo, const Vec3& hi, Vec3& point) const noexcept;
  const SpringModel& model_;
  SpringCutter& cutter_;
  BladeSettings settings_;
  double reach_ = 0;                   // m beyond the tip's sphere that a pressing tip parts
  bool have_prev_ = false;
  Vec3 prev_tip_ = Vec3::Zero(), prev_axis_ = Vec3::Zero();
  Vec3 surface_point_ = Vec3::Zero();   // the organ's own surface over the tip (local_surface)
  Vec3 surface_normal_ = Vec3::UnitY();  // and its outward normal there
  double dimple_ = 0;                  // m, what of the tip's depth is the dimple (relaxing)
  bool cutting_ = false;
  double since_cut_ = 1e9;             // s since the last removal
  double since_cutting_ = 1e9;         // s since the blade last cut (cutting_ true)
  double last_contact_ = 0;            // N, |contact force| of the last step
  Vec3 out_ = Vec3::Zero();            // N, the last felt force
  double depth_ = 0;
  std::uint64_t jumps_ = 0, cut_ = 0;
  std::vector<std::array<int, 3>> outer_;  // the organ's surface triangles before any cut
  std::vector<int> outer_start_, outer_of_;  // CSR: each vertex's triangles of outer_
  std::vector<int> candidates_;        // (springs) scratch
  std::vector<std::uint8_t> seen_;     // (springs) scratch
};

}  // namespace palpate::spring
