// safety.cpp — ForceSafety: finite, clamped, ramped and rate-limited forces for a device.
#include <palpate/safety.h>

#include <algorithm>
#include <cmath>

namespace palpate {

ForceSafety::ForceSafety(const DeviceLimits& limits, double ramp_time)
    : limits_(limits), ramp_time_(std::max(0.0, ramp_time)) {}

void ForceSafety::reset() noexcept {
  since_start_ = 0;
  last_.setZero();
}

Vec3 ForceSafety::filter(const Vec3& requested, double dt, bool step_ok) noexcept {
  Vec3 f = requested;
  if (!step_ok) {
    ++counters_.step_failed;
    f.setZero();
    since_start_ = 0;
  } else if (!f.allFinite()) {
    ++counters_.non_finite;
    f.setZero();
    since_start_ = 0;
  }
  // Clamp the magnitude, keep the direction.
  const double max_force = std::max(0.0, limits_.max_force);
  const double norm = f.norm();
  if (norm > max_force) {
    ++counters_.clamped;
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
    f = last_ + change * (max_step / change_norm);
  }
  // Final guard: whatever happened above, what leaves is finite and within the maximum.
  if (!f.allFinite()) f.setZero();
  const double out_norm = f.norm();
  if (out_norm > max_force) f *= max_force / out_norm;
  last_ = f;
  return f;
}

}  // namespace palpate
