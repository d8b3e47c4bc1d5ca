// safety.cpp — ForceSafety: finite, clamped, ramped and rate-limited forces for a device.
#include <palpate/safety.h>

#include <algorithm>
#include <cmath>
#include <cstring>

namespace palpate {

void safety_event_names(std::uint32_t mask, char* out, size_t size) noexcept {
  static constexpr const char* kNames[] = {"non_finite", "step_failed", "clamped",       "rate_limited",
                                           "overrun",    "stalled",     "device_failed", "blade_teleport"};
  if (size == 0) return;
  out[0] = '\0';
  size_t used = 0;
  for (size_t i = 0; i < std::size(kNames); ++i) {
    if (!(mask & (1u << i))) continue;
    const size_t n = std::strlen(kNames[i]);
    if (used + n + 2 > size) break;
    if (used) out[used++] = '|';
    std::memcpy(out + used, kNames[i], n);
    used += n;
    out[used] = '\0';
  }
}

ForceSafety::ForceSafety(const DeviceLimits& limits, double ramp_time)
    : limits_(limits), ramp_time_(std::max(0.0, ramp_time)) {}

void ForceSafety::reset() noexcept {
  since_start_ = 0;
  last_.setZero();
  events_ = 0;
}

Vec3 ForceSafety::filter(const Vec3& requested, double dt, bool step_ok) noexcept {
  return filter(requested, dt, step_ok ? TickFault::none : TickFault::step_failed);
}

Vec3 ForceSafety::filter(const Vec3& requested, double dt, TickFault fault) noexcept {
  Vec3 f = requested;
  events_ = 0;
  if (fault != TickFault::none) {
    switch (fault) {
      case TickFault::overrun: ++counters_.overrun, events_ |= kEventOverrun; break;
      case TickFault::stalled: ++counters_.stalled, events_ |= kEventStalled; break;
      case TickFault::device_failed: ++counters_.device_failed, events_ |= kEventDeviceFailed; break;
      default: ++counters_.step_failed, events_ |= kEventStepFailed; break;
    }
    f.setZero();
    since_start_ = 0;
  } else if (!f.allFinite()) {
    ++counters_.non_finite;
    events_ |= kEventNonFinite;
    f.setZero();
    since_start_ = 0;
  }
  // Clamp the magnitude, keep the direction.
  const double max_force = std::max(0.0, limits_.max_force);
  const double norm = f.norm();
  if (norm > max_force) {
    ++counters_.clamped;
    events_ |= kEventClamped;
    f *= max_force / norm;
  }
  // Ramp in after start or after a fault.
  if (ramp_time_ > 0 && since_start_ < ramp_time_) f *= since_start_ / ramp_time_;
  since_start_ += dt;
  // Rate limit: the change from the last sent force is at most max_force_rate · dt.
  const double max_step = std::max(0.0, limits_.max_force_rate) * dt;
  const Vec3 change = f - last_;
  const double change_norm = change.norm();
  if (change_norm > max_step) {
    ++counters_.rate_limited;
    events_ |= kEventRateLimited;
    f = last_ + change * (max_step / change_norm);
  }
  // Final guard: whatever happened above, what leaves is finite and within the maximum.
  if (!f.allFinite()) f.setZero();
  const double out_norm = f.norm();
  if (out_norm > max_force) f *= max_force / out_norm;
  last_ = f;
  return f;
}

Vec3 ForceSafety::ramp_down(double dt) noexcept {
  const double max_step = std::max(0.0, limits_.max_force_rate) * dt;
  const double n = last_.norm();
  if (!std::isfinite(n) || n <= max_step)
    last_.setZero();
  else
    last_ *= (n - max_step) / n;
  return last_;
}

}  // namespace palpate
