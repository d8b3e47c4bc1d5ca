// multirate.cpp — the physics worker's thread, its step and the haptic side's linearised render.
#include "haptics/multirate.h"

#include "haptics/pacing.h"

#include <palpate/haptics.h>

#include <algorithm>
#include <cmath>

#include <pthread.h>
#include <sched.h>

namespace palpate {

double scene_physics_dt(const TissueDef& t) noexcept {
  return t.model == "mass_spring" && t.spring.physics_rate > 0 ? 1.0 / t.spring.physics_rate : 0.0;
}

PhysicsWorker::PhysicsWorker(Tissue& tissue, int index, double physics_dt, double haptic_dt,
                             double max_stiffness, bool threaded, MultiRateContact method)
    : tissue_(tissue),
      index_(index),
      physics_dt_(physics_dt),
      haptic_dt_(haptic_dt),
      threaded_(threaded),
      estimator_(max_stiffness),
      max_stiffness_(max_stiffness),
      method_(method),
      event_scratch_(64) {
  if (method_ == MultiRateContact::compliance) compliance_ = tissue_.contact_compliance();
  every_ = std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::llround(physics_dt / haptic_dt)));
  PhysicsSnapshot init;
  init.figures.assign(tissue.figure_names().size(), 0.0);
  out_.fill(init);
}

PhysicsWorker::~PhysicsWorker() { stop(); }

void PhysicsWorker::start() {
  started_ns_ = monotonic_ns();
  if (!threaded_ || thread_.joinable()) return;
  stop_.store(false);
  thread_ = std::thread([this] { physics_main(); });
  if (cpu_ >= 0 && cpu_ < CPU_SETSIZE) {  // best effort: a machine with one CPU, or a cgroup without it, refuses
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(cpu_, &set);
    (void)pthread_setaffinity_np(thread_.native_handle(), sizeof(set), &set);
  }
}

void PhysicsWorker::stop() {
  stop_.store(true, std::memory_order_release);
  if (thread_.joinable()) thread_.join();
}

void PhysicsWorker::physics_step(const ToolState& tool) noexcept {
  const std::int64_t began = monotonic_ns();
  const Vec3 f = tissue_.step(tool, physics_dt_);
  PhysicsSnapshot& s = out_.write_slot();
  s.ok = f.allFinite() && tool.tip.allFinite() && !tissue_.last_step_failed();
  if (s.ok) {
    // The model's own stiffness when it offers one, else the secant estimate across its steps.
    Mat3 j;
    const auto* src = dynamic_cast<const ContactJacobianSource*>(&tissue_);
    if (src && src->contact_jacobian(j))
      estimator_.set_jacobian(j);
    else
      estimator_.update(tool.tip, f);
    s.contact.x0 = tool.tip;
    s.contact.f0 = f;
    s.contact.jacobian = estimator_.jacobian();
    // The patch must cover the tool until the next one: a period, or as long as the last step
    // took when the physics runs late (the 54k organ at 50 Hz on two cores: ~40 ms).
    const double horizon = std::max(physics_dt_, last_interval_);
    s.has_patch = compliance_ && compliance_->contact_patch(tool, physics_dt_, horizon, s.patch);
  } else {
    s.has_patch = false;
    estimator_.reset();
    s.contact = ContactLinearisation{};
  }
  tissue_.figures(s.figures);
  s.seq = ++seq_;
  s.published_ns = monotonic_ns();
  if (threaded_ && last_published_ns_ > 0) last_interval_ = double(s.published_ns - last_published_ns_) * 1e-9;
  last_published_ns_ = s.published_ns;
  out_.publish();
  size_t n = 0;
  while ((n = tissue_.drain_events(event_scratch_)) > 0)
    for (size_t i = 0; i < n; ++i) {
      event_scratch_[i].tissue = index_;
      (void)events_.try_push({&event_scratch_[i], 1});  // full: dropped (256 pending is plenty)
    }
  step_h_.add(double(monotonic_ns() - began) * 1e-9);
  steps_.store(steps_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
}

void PhysicsWorker::physics_main() noexcept {
  const auto period = static_cast<std::int64_t>(physics_dt_ * 1e9);
  std::int64_t next = monotonic_ns();
  while (!stop_.load(std::memory_order_acquire)) {
    tool_in_.update();
    physics_step(tool_in_.read());
    next += period;
    const std::int64_t now = monotonic_ns();
    if (now > next) late_.store(late_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
    if (now > next + 10 * period) next = now;  // fell far behind: don't try to catch up
    sleep_until_ns(next, 0);
  }
}

TickFault PhysicsWorker::render(const ToolState& tool, std::int64_t now_ns, double stall_timeout,
                                Vec3& force, std::span<double> figures) noexcept {
  // A tick on which the loop stopped a blade cutting (ToolState::blade false: it jumped, or its pose
  // was held) must reach the physics step, which sees only one tick in physics_dt/dt: otherwise that
  // step would sweep the edge from its last pose across the jump. So the tool handed over stays
  // blade = false from that tick until a step has surely read it: inline, the next step; threaded,
  // until the snapshot sequence is two past the one seen that tick (the step after next started
  // after that tick's hand-over, which it therefore read or a later no-cut one).
  if (!tool.blade) hold_blade_ = true, hold_restart_ = true;
  if (threaded_) {
    ToolState& w = tool_in_.write_slot();
    w = tool;
    if (hold_blade_) w.blade = false;
    tool_in_.publish();
  } else if (tick_++ % every_ == 0) {
    ToolState t = tool;
    if (hold_blade_) t.blade = false;
    hold_blade_ = false;
    physics_step(t);
  }
  out_.update();
  const PhysicsSnapshot& s = out_.read();
  if (threaded_ && hold_blade_) {
    if (hold_restart_)
      hold_until_seq_ = s.seq + 2, hold_restart_ = false;
    else if (s.seq >= hold_until_seq_)
      hold_blade_ = false;
  }
  const size_t nf = std::min(figures.size(), s.figures.size());
  std::copy_n(s.figures.begin(), nf, figures.begin());
  force.setZero();
  rendered_jacobian_.setZero();
  if (threaded_ && stall_timeout > 0) {
    // Silent for stall_timeout, or for ten of its own periods when that is longer: an organ whose
    // step runs late (the 54k organ steps in 30–100 ms at 50 Hz on a 2-core VM) is slow, not stuck,
    // and the last patch it published is still a passive contact with it; zeroing the force each
    // time a step ran past 50 ms dropped the press 258 times in a minute.
    const double timeout = std::max(stall_timeout, 10 * physics_dt_);
    const std::int64_t since = s.seq ? s.published_ns : started_ns_;
    if (double(now_ns - since) * 1e-9 > timeout) return TickFault::stalled;
  }
  if (s.seq == 0) return TickFault::none;
  if (!s.ok) return TickFault::step_failed;
  // Ticks since this snapshot's step (the first tick that renders it is 0): the patch's points move
  // on with their velocity for at most one physics period (a late step holds them there).
  if (s.seq != rendered_seq_) { rendered_seq_ = s.seq; ticks_on_snapshot_ = 0; }
  const double elapsed = std::min(physics_dt_, static_cast<double>(ticks_on_snapshot_++) * haptic_dt_);
  if (s.has_patch) {
    const PatchContact c = solve_patch(s.patch, tool.tip, tool.radius, max_stiffness_, patch_scratch_, elapsed);
    if (c.valid) {
      force = c.force;
      const double magnitude = c.force.norm();
      if (magnitude > 0) {
        const Vec3 d = c.force / magnitude;
        rendered_jacobian_ = -c.stiffness * d * d.transpose();
      }
      patch_ticks_.store(patch_ticks_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
      return TickFault::none;
    }
    patch_fallbacks_.store(patch_fallbacks_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  }
  force = s.contact.force_at(tool.tip);
  rendered_jacobian_ = s.contact.jacobian;
  return TickFault::none;
}

size_t PhysicsWorker::drain_events(std::span<TissueEvent> out) noexcept {
  size_t n = 0;
  for (std::span<const TissueEvent> e = events_.front(); !e.empty() && n < out.size(); e = events_.front()) {
    out[n++] = e[0];
    events_.pop();
  }
  return n;
}

}  // namespace palpate
