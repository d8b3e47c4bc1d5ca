// blade.h — a blade against a mass-spring organ (internal; used by the scene tissue, tissue.cpp):
// which springs its edge cuts each tick, and the force the hand feels while it cuts
// (docs/models/cutting.md, "Mass-spring organs").
#pragma once

#include <palpate/spring.h>

#include "core/blade_sweep.h"

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
  double withdrawn = 0.0005;        // m the tip must come back out past where it went in to stop cutting
  double drag_speed = 0.005;        // m/s below which the drag fades linearly to zero (no chatter at rest)
};

class BladeCut {
 public:
  BladeCut(const SpringModel& model, SpringCutter& cutter, const BladeSettings& settings);
  // Before the step: while cutting (the contact force of the last step reached cutting_force, and
  // from then until the tip is drawn back out past where it went in), remove the springs the edge's sweep since the last tick crosses,
  // and, while pressed past cutting_force, those within reach of its tip (it parts what it presses).
  // Returns how many springs were removed. noexcept, no allocation.
  int cut(const SpringState& state, const ToolState& tool, double dt) noexcept;
  // After the step: the force to render from the organ's contact force on the blade: while cutting,
  // its size held at most cutting_force and every change rate-limited to force_rate, plus the drag
  // −drag_per_length · (edge in the organ) along the blade's motion.
  Vec3 felt(const Vec3& contact, const ToolState& tool, double dt) noexcept;
  void reset() noexcept;

  bool cutting() const noexcept { return cutting_; }
  std::uint64_t jumps() const noexcept { return jumps_; }      // sweeps refused as teleports
  std::uint64_t springs_cut() const noexcept { return cut_; }
  double depth() const noexcept { return depth_; }             // m of edge in the organ (estimate)

 private:
  const SpringModel& model_;
  SpringCutter& cutter_;
  BladeSettings settings_;
  double reach_ = 0;                   // m beyond the tip's sphere that a pressing tip parts
  bool have_prev_ = false;
  Vec3 prev_tip_ = Vec3::Zero(), prev_axis_ = Vec3::Zero();
  Vec3 entry_ = Vec3::Zero();          // the tip where the cut began
  bool cutting_ = false;
  double since_cut_ = 1e9;             // s since the last removal
  double last_contact_ = 0;            // N, |contact force| of the last step
  Vec3 out_ = Vec3::Zero();            // N, the last felt force
  double depth_ = 0;
  std::uint64_t jumps_ = 0, cut_ = 0;
  std::vector<int> candidates_;        // (springs) scratch
  std::vector<std::uint8_t> seen_;     // (springs) scratch
};

}  // namespace palpate::spring
