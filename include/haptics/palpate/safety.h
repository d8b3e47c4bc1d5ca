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

// Time-domain passivity (Hannaford & Ryu 2002, "Time-domain passivity control of haptic
// interfaces", IEEE Trans. Robotics and Automation 18(1)): on every device's force path, before the
// safety filter. The observer integrates the energy flowing from the hand into the simulation, the
// work the hand did against the force the device held over each tick (zero-order hold: the force
// sent at tick k−1 acts until tick k while the device moves from x_{k−1} to x_k),
//   E_k = E_{k−1} − f_{k−1} · (x_k − x_{k−1}),
// exact for a held force (Hannaford & Ryu's Δt·Σ f·v samples the velocity once a tick, and misses
// the work a stiff contact does inside it). A passive tissue keeps E >= 0. When this tick's force
// would make E < 0 by the next tick (its work predicted as −f_k · v_k · Δt: the simulation giving the
// hand energy it never put in — a stiff wall sampled too slowly, a delay, a coupling too stiff), the
// controller adds the damping that absorbs the deficit,
//   α = −E_pred / (Δt · max(|v|², v_floor²)),   f ← f − α v,
// capped at `max_damping_fraction` of the device's own damping limit (DeviceLimits::damping), and
// slewed: α moves towards that by at most its cap per `damping_rise` (3 ms), so switching it on or
// off never steps the force (a deficit left meanwhile is paid back by the ticks after).
// Forgetting: energy a tissue stored (a pressed spring) may come back to the hand, so it is never
// forgotten while the tool is loaded; once the force sent has stayed below `free_force` for a whole
// `window` nothing is stored between tool and tissue any more, and the credit left is energy the
// tissue dissipated: it is forgotten (E ← min(E, 0)), so an old credit never hides a later active
// contact. A deficit is never forgotten. docs/haptics.md, "Passivity".
struct PassivitySettings {
  bool enabled = true;                // false: the observer still runs (E in run.csv), no damping added
  double window = 0.03;               // s, the tool free of force this long forgets its credit
  double velocity_floor = 0.01;       // m/s, |v|² is floored at its square (1e-4 m²/s²)
  double max_damping_fraction = 0.9;  // α <= this × DeviceLimits::damping
  double free_force = 1e-3;           // N, a force below this stores nothing in the contact
  double damping_rise = 0.003;        // s, α changes by at most its cap over this (0: at once)
};

// The settings a scene's device section gives (its passivity* keys).
PassivitySettings passivity_settings(const DeviceDef& def) noexcept;

// What the controller did over a run (summary.json, with the safety counters).
struct PassivityCounters {
  std::uint64_t active_ticks = 0;  // ticks it added damping
  std::uint64_t capped_ticks = 0;  // of those, ticks α hit its cap (the deficit was not all absorbed)
  double dissipated = 0;           // J, energy its damping absorbed (Σ α |v|² Δt)
  double min_energy = 0;           // J, the lowest E observed after control
  double max_damping = 0;          // N·s/m, the largest α
};

// One device's passivity observer and controller. noexcept, no allocation: the haptic thread's.
class PassivityController {
 public:
  PassivityController(const DeviceLimits& limits, const PassivitySettings& settings);
  // One tick: first observe the work done since the last tick (the force last sent, held while
  // the device moved to `position`), then return the requested force with the damping that keeps
  // the predicted E >= 0 (the request itself when none is needed, when disabled, or when an input
  // is not finite: the safety filter deals with those). Then call sent() with what was sent.
  Vec3 control(const Vec3& requested, const Vec3& position, const Vec3& velocity, double dt) noexcept;
  // The force that left the safety filter this tick (held until the next control()).
  void sent(const Vec3& force, double dt) noexcept;
  double energy() const noexcept { return energy_; }   // J, E observed at this tick
  double damping() const noexcept { return alpha_; }   // N·s/m, α this tick (0 = none)
  const PassivityCounters& counters() const noexcept { return counters_; }
  const PassivitySettings& settings() const noexcept { return settings_; }
  double max_damping() const noexcept { return max_alpha_; }
  void reset() noexcept;

 private:
  PassivitySettings settings_;
  double max_alpha_ = 0;        // N·s/m
  double energy_ = 0;           // J
  double alpha_ = 0;            // N·s/m
  double free_for_ = 0;         // s the force sent has stayed below free_force
  bool have_position_ = false;  // a position to measure the next tick's motion from
  Vec3 position_ = Vec3::Zero();   // m, the device at the last tick
  Vec3 held_ = Vec3::Zero();       // N, the force sent at the last tick (held since)
  PassivityCounters counters_;
};

}  // namespace palpate
