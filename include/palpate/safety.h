// palpate/safety.h — the force safety filter every force passes before it reaches a device.
#pragma once

#include <palpate/core.h>
#include <palpate/device.h>

#include <cstdint>

namespace palpate {

// Counts of what the filter had to do; each is an event the run summary reports.
struct SafetyCounters {
  std::uint64_t non_finite = 0;    // ticks whose input force had a NaN or infinity
  std::uint64_t step_failed = 0;   // ticks where the step reported failure (zero force sent)
  std::uint64_t clamped = 0;       // ticks where |F| exceeded the device's maximum
  std::uint64_t rate_limited = 0;  // ticks where the change of force exceeded the rate limit
};

// Makes any requested force safe to send (DESIGN.md §3 "Safety"):
//   1. a non-finite force, or a failed step, gives zero force (and the ramp restarts);
//   2. the magnitude is clamped to the device's maximum, keeping the direction;
//   3. forces ramp in linearly from zero over `ramp_time` after start or a fault;
//   4. the change per tick is limited to max_force_rate · dt (so no kick, even to zero).
// noexcept, no allocation: called on the haptic thread every tick.
class ForceSafety {
 public:
  ForceSafety(const DeviceLimits& limits, double ramp_time);
  // `requested`: the model's force on the tool (N); `dt`: the tick (s); `step_ok`: whether the
  // step that produced it finished in time and without numerical trouble.
  Vec3 filter(const Vec3& requested, double dt, bool step_ok) noexcept;
  const SafetyCounters& counters() const { return counters_; }
  const Vec3& last() const { return last_; }
  void reset() noexcept;

 private:
  DeviceLimits limits_;
  double ramp_time_;
  double since_start_ = 0;  // s since start or since the last fault
  Vec3 last_ = Vec3::Zero();
  SafetyCounters counters_;
};

}  // namespace palpate
