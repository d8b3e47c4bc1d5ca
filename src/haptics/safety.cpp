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

PassivitySettings passivity_settings(const DeviceDef& def) noexcept {
  PassivitySettings p;
  p.enabled = def.passivity;
  p.window = def.passivity_window;
  p.velocity_floor = def.passivity_velocity_floor;
  p.max_damping_fraction = def.passivity_max_damping;
  return p;
}

PassivityController::PassivityController(const DeviceLimits& limits, const PassivitySettings& settings)
    : settings_(settings) {
  const double fraction = std::isfinite(settings.max_damping_fraction) ? std::max(0.0, settings.max_damping_fraction) : 0.0;
  const double damping = std::isfinite(limits.damping) ? std::max(0.0, limits.damping) : 0.0;
  max_alpha_ = fraction * damping;
  if (!(settings_.velocity_floor > 0) || !std::isfinite(settings_.velocity_floor)) settings_.velocity_floor = 0.01;
  if (!(settings_.window >= 0) || !std::isfinite(settings_.window)) settings_.window = 0.03;
  if (!(settings_.free_force >= 0) || !std::isfinite(settings_.free_force)) settings_.free_force = 1e-3;
  if (!(settings_.damping_rise >= 0) || !std::isfinite(settings_.damping_rise)) settings_.damping_rise = 0.003;
}

void PassivityController::reset() noexcept {
  energy_ = 0;
  alpha_ = 0;
  free_for_ = 0;
  have_position_ = false;
  position_.setZero();
  held_.setZero();
  counters_ = {};
}

Vec3 PassivityController::control(const Vec3& requested, const Vec3& position, const Vec3& velocity, double dt) noexcept {
  const double before = alpha_;
  alpha_ = 0;
  // The work of the force held since the last tick over the device's motion since then.
  if (position.allFinite()) {
    if (have_position_) energy_ -= held_.dot(position - position_);
    position_ = position;
    have_position_ = true;
    counters_.min_energy = std::min(counters_.min_energy, energy_);
  }
  if (!settings_.enabled || !requested.allFinite() || !velocity.allFinite() || !(dt > 0)) return requested;
  // The energy at the next tick if the request were sent as it is, the device going on at v; the
  // damping that would absorb its deficit (a deficit of round-off, under a picojoule, is none).
  const double predicted = energy_ - requested.dot(velocity) * dt;
  double needed = 0;
  if (predicted < -1e-12) {
    const double floor2 = settings_.velocity_floor * settings_.velocity_floor;
    needed = -predicted / (dt * std::max(velocity.squaredNorm(), floor2));
    if (!(needed <= max_alpha_)) {
      needed = max_alpha_;
      ++counters_.capped_ticks;
    }
  }
  // α moves towards what is needed by at most its cap per `damping_rise` (3 ms): switched on or
  // off in one tick it would step the force by α·v, a catch the hand feels (0.02 N measured on the
  // probe scene); a deficit left meanwhile is paid back by the ticks after.
  const double step = settings_.damping_rise > 0 ? max_alpha_ * dt / settings_.damping_rise : max_alpha_;
  const double alpha = std::clamp(needed, std::max(0.0, before - step), before + step);
  if (!(alpha > 1e-9 * max_alpha_)) return requested;  // (round-off of the slew: none)
  alpha_ = alpha;
  ++counters_.active_ticks;
  counters_.max_damping = std::max(counters_.max_damping, alpha);
  counters_.dissipated += alpha * velocity.squaredNorm() * dt;
  return requested - alpha * velocity;
}

void PassivityController::sent(const Vec3& force, double dt) noexcept {
  held_ = force.allFinite() ? force : Vec3(Vec3::Zero());
  // Free of force for a whole window: nothing is stored between tool and tissue, so the credit
  // left was dissipated; forget it. A deficit stays until the damping has paid it back.
  free_for_ = held_.norm() < settings_.free_force ? free_for_ + dt : 0.0;
  if (free_for_ >= settings_.window && energy_ > 0) energy_ = 0;
}

}  // namespace palpate
