// palpate/safety.h — the force safety filter every force passes before it reaches a device, and
// the watchdog's faults that make it send zero.
#pragma once

#include <palpate/core.h>
#include <palpate/device.h>

#include <cstdint>

namespace palpate {

// Why a tick's force may not be trusted; any fault but `none` sends zero force (ramped down).
enum class TickFault : std::uint8_t {
  none = 0,
  step_failed,    // a step reported failure
  overrun,        // the tick's work ran past its deadline by more than the watchdog's margin
  stalled,        // a physics thread has published nothing for longer than the stall timeout
  device_failed,  // the device's read failed or gave a non-finite pose
};

// One bit per thing the filter did this tick (the `events` column of run.csv names them).
enum SafetyEvent : std::uint32_t {
  kEventNonFinite = 1u << 0,
  kEventStepFailed = 1u << 1,
  kEventClamped = 1u << 2,
  kEventRateLimited = 1u << 3,
  kEventOverrun = 1u << 4,
  kEventStalled = 1u << 5,
  kEventDeviceFailed = 1u << 6,
  kEventBladeTeleport = 1u << 7,  // the blade's tip jumped too far this tick: it pressed, it did not cut
};
// "clamped|rate_limited" for a mask, "" for none; `out` holds at least 96 characters.
void safety_event_names(std::uint32_t mask, char* out, size_t size) noexcept;

// Counts of what the filter had to do; each is an event the run summary reports.
struct SafetyCounters {
  std::uint64_t non_finite = 0;     // ticks whose input force had a NaN or infinity
  std::uint64_t step_failed = 0;    // ticks where the step reported failure (zero force sent)
  std::uint64_t clamped = 0;        // ticks where |F| exceeded the device's maximum
  std::uint64_t rate_limited = 0;   // ticks where the change of force exceeded the rate limit
  std::uint64_t overrun = 0;        // ticks zeroed by the watchdog: work past deadline + margin
  std::uint64_t stalled = 0;        // ticks zeroed by the watchdog: a physics thread stalled
  std::uint64_t device_failed = 0;  // ticks zeroed because the device read failed or was NaN
  // Ticks a blade's tip moved farther than LoopSettings::blade_max_speed · dt: the tissues met it as
  // a blunt tool that tick (ToolState::blade false), so a glitch of the device never slices the
  // tissue. Its force is not zeroed (it still presses), so zeroed() leaves it out.
  std::uint64_t blade_teleport = 0;

  // Ticks the filter sent zero for (each restarts the ramp-in); clamping and rate limits excluded.
  std::uint64_t zeroed() const noexcept { return non_finite + step_failed + overrun + stalled + device_failed; }
};

// When the watchdog steps in (realtime runs; a headless run has no wall-clock deadline).
struct WatchdogSettings {
  double overrun_margin = 0.0005;  // s past a tick's deadline (start + dt) before force goes to zero
  double stall_timeout = 0.05;     // s without a new physics step before force goes to zero (or ten of its periods, when longer)
};

// Makes any requested force safe to send (DESIGN.md §3 "Safety"):
//   1. a non-finite force, or a fault, gives zero force (and the ramp restarts);
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
  // The same with the watchdog's reason when the tick is not to be trusted.
  Vec3 filter(const Vec3& requested, double dt, TickFault fault) noexcept;
  // One step of the ramp to zero at stop: the last force shrunk by at most max_force_rate · dt
  // (zero once within that). Counts nothing; the caller sends it once per tick until it is zero.
  Vec3 ramp_down(double dt) noexcept;
  const SafetyCounters& counters() const { return counters_; }
  const Vec3& last() const { return last_; }
  // SafetyEvent bits of the last filter() call.
  std::uint32_t last_events() const { return events_; }
  void reset() noexcept;

 private:
  DeviceLimits limits_;
  double ramp_time_;
  double since_start_ = 0;  // s since start or since the last fault
  Vec3 last_ = Vec3::Zero();
  SafetyCounters counters_;
  std::uint32_t events_ = 0;
};

}  // namespace palpate
