// multirate.h — PhysicsWorker: a tissue too large for a 1 ms step, stepped on its own thread at
// its own rate; the haptic thread renders its force at 1 kHz from the contact model linearised at
// its last step, exchanged through lock-free triple buffers (neither side ever blocks).
#pragma once

#include <palpate/core.h>
#include <palpate/safety.h>
#include <palpate/tissue.h>

#include "haptics/contact.h"
#include "haptics/histogram.h"
#include "haptics/patch_contact.h"
#include "haptics/spsc_ring.h"
#include "haptics/triple_buffer.h"

#include <atomic>
#include <cstdint>
#include <span>
#include <thread>
#include <vector>

namespace palpate {

// What a physics step publishes: the linearised contact and the tissue's figures at that step.
struct PhysicsSnapshot {
  ContactLinearisation contact;
  std::uint64_t seq = 0;          // 0 = nothing published yet
  std::int64_t published_ns = 0;  // CLOCK_MONOTONIC when published
  bool ok = true;                 // false when the step's force was not finite
  std::vector<double> figures;    // the tissue's figures (sized once, filled in place)
  bool has_patch = false;         // the model's compliant contact patch (ContactComplianceSource)
  ContactPatch patch;
};

// How the haptic thread renders a multi-rate tissue's contact between its steps.
enum class MultiRateContact {
  compliance,  // solve the contact against the model's compliant patch every tick when it offers
               // one (ContactComplianceSource), else as `linearised`
  linearised,  // F0 + J·(x − x0), J from ContactJacobianSource or the secant (Broyden) estimate
};

class PhysicsWorker {
 public:
  // `max_stiffness` (N/m): the rendered stiffness's bound (the device's). `threaded`: false steps
  // inline from render() every physics_dt/dt ticks (headless, deterministic).
  PhysicsWorker(Tissue& tissue, int index, double physics_dt, double haptic_dt, double max_stiffness,
                bool threaded, MultiRateContact method = MultiRateContact::compliance);
  ~PhysicsWorker();
  PhysicsWorker(const PhysicsWorker&) = delete;
  PhysicsWorker& operator=(const PhysicsWorker&) = delete;

  void start();
  void stop();

  // Haptic thread, every tick: hand over the tool, render F0 + J·(x − x0) at the tool's tip into
  // `force`, copy the last figures into `figures`. Returns `stalled` when threaded and nothing was
  // published for max(`stall_timeout`, 10 physics periods) s (counted from start), `step_failed`
  // for a non-finite step.
  TickFault render(const ToolState& tool, std::int64_t now_ns, double stall_timeout, Vec3& force,
                   std::span<double> figures) noexcept;
  // Haptic thread, after render(): the Jacobian ∂F/∂x of the contact that tick rendered (for the
  // virtual coupling's implicit proxy step): from the compliant patch's solve, −k_eff d dᵀ along the
  // force (k_eff = k / (1 + k w) ≤ the device's stiffness), else the linearisation's J.
  const Mat3& jacobian() const noexcept { return rendered_jacobian_; }
  // Haptic thread: move tissue events the physics side queued into `out`.
  size_t drain_events(std::span<TissueEvent> out) noexcept;
  std::uint64_t physics_steps() const noexcept { return steps_.load(std::memory_order_relaxed); }
  // Haptic ticks rendered from the compliant patch, and those that fell back to the linearised
  // contact although a patch was published (the tool outside its reach). Haptic-thread counters.
  // Single writer (the haptic thread), readable live from any thread.
  std::uint64_t patch_ticks() const noexcept { return patch_ticks_.load(std::memory_order_relaxed); }
  std::uint64_t patch_fallbacks() const noexcept { return patch_fallbacks_.load(std::memory_order_relaxed); }
  // Each physics step's work (s: the tissue's step, its contact patch, publishing), and the steps
  // that ended after the next was due (threaded: the physics did not keep its rate). Readable live.
  const LatencyHistogram& step_times() const noexcept { return step_h_; }
  std::uint64_t late_steps() const noexcept { return late_.load(std::memory_order_relaxed); }
  double physics_dt() const noexcept { return physics_dt_; }
  // Pin the physics thread to this CPU (best effort, before start(); -1: leave it to the OS).
  void set_cpu(int cpu) noexcept { cpu_ = cpu; }

 private:
  void physics_main() noexcept;
  void physics_step(const ToolState& tool) noexcept;

  Tissue& tissue_;
  int index_;
  double physics_dt_, haptic_dt_;
  bool threaded_;
  std::uint64_t every_ = 1;   // inline: step every this many ticks
  std::uint64_t tick_ = 0;    // inline: haptic ticks seen
  ContactEstimator estimator_;
  double max_stiffness_;
  MultiRateContact method_;
  ContactComplianceSource* compliance_ = nullptr;
  PatchScratch patch_scratch_;            // haptic thread
  Mat3 rendered_jacobian_ = Mat3::Zero();  // haptic thread: the last tick's ∂F/∂x
  bool hold_blade_ = false;               // haptic thread: hand the tool over with blade = false
  bool hold_restart_ = false;             //   (render(): a no-cut tick not yet seen by a step)
  std::uint64_t hold_until_seq_ = 0;      //   threaded: until the snapshot sequence reaches this
  std::uint64_t rendered_seq_ = 0;        // haptic thread: the snapshot last rendered, and how many
  std::uint64_t ticks_on_snapshot_ = 0;   // ticks it has been rendered for
  std::atomic<std::uint64_t> patch_ticks_{0}, patch_fallbacks_{0};  // haptic thread writes
  LatencyHistogram step_h_;               // physics step's work (the thread that steps writes)
  std::atomic<std::uint64_t> late_{0};
  int cpu_ = -1;
  TripleBuffer<ToolState> tool_in_;
  TripleBuffer<PhysicsSnapshot> out_;
  SpscRing<TissueEvent> events_{256, 1};
  std::vector<TissueEvent> event_scratch_;
  std::uint64_t seq_ = 0;            // physics-side
  std::int64_t last_published_ns_ = 0;  // physics-side: the last publish, and the time since the
  double last_interval_ = 0;            // one before it (threaded only; s)
  std::int64_t started_ns_ = 0;
  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> steps_{0};
  std::thread thread_;
};

}  // namespace palpate
