// palpate/haptics.h — the haptic loop a simulator embeds: a thread at a fixed 1 ms period that
// reads the device, steps the tissues (some at their own rate), renders and filters the force,
// writes it, and records every tick; with live timing and safety statistics.
#pragma once

#include <palpate/core.h>
#include <palpate/device.h>
#include <palpate/outcome.h>
#include <palpate/safety.h>
#include <palpate/scene.h>

#include <Eigen/Core>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace palpate {

class Tissue;

// Optional for a Tissue model: the contact stiffness at its last step, ∂F/∂x (N/m), where F is the
// force on the tool and x the tool's position. A multi-rate loop renders F0 + J·(x − x0) between
// the model's steps; a model that does not offer it gets a secant (Broyden) estimate instead.
class ContactJacobianSource {
 public:
  virtual ~ContactJacobianSource() = default;
  // False when the model has no estimate this step (the secant estimate is used then).
  virtual bool contact_jacobian(Eigen::Matrix3d& dforce_dposition) const noexcept = 0;
};

// A tool's force law other than the tissues' contact: evaluated on the haptic thread every tick
// (noexcept, no allocation, no locks), the force on the tool (N) at its pose and the run's time (s).
// The ultrasound probe's is NeckCompression (palpate/ultrasound.h).
class ToolForceModel {
 public:
  virtual ~ToolForceModel() = default;
  virtual Vec3 force(const Vec3& position, const Quat& orientation, double t) noexcept = 0;
};

enum class Coupling : std::uint8_t {
  direct,   // the force on the HIP goes to the device (the seed papers)
  virtual_  // a spring-damper to a tool proxy that the tissue pushes (stiff contact)
};

// A tissue the loop steps, and where: on the haptic thread every tick (physics_dt = 0), or on its
// own thread every physics_dt seconds with the force rendered at 1 kHz from a local linear model.
struct LoopTissue {
  Tissue* tissue = nullptr;  // not owned; must outlive the loop
  double physics_dt = 0;     // s; 0 = every tick on the haptic thread
};

struct LoopSettings {
  double dt = 0.001;                  // s, the haptic tick
  bool realtime = true;               // wall-clock paced on its own thread; false = run_headless()
  double spin = 150e-6;               // s, busy-wait before each deadline (sleep before that)
  std::uint64_t max_ticks = 0;        // stop by itself after this many ticks; 0 = until stop()
  double ramp_in = 0.1;               // s, forces ramp in from zero at start and after a fault
  Coupling coupling = Coupling::direct;
  double proxy_mass = 0.001;          // kg, virtual coupling
  double coupling_stiffness = 0;      // N/m, virtual coupling; 0 = the device's maximum
  WatchdogSettings watchdog;
  ToolDef tool;                       // tool.axis: the needle's direction at identity orientation;
                                      // each tick the tissues see orientation * tool.axis
  std::filesystem::path csv;          // record every tick here (via <csv>.part); "" = no recording
  OutcomeModel outcome;               // roles and rest surfaces the run's outcome and metrics are
                                      // tracked over each tick (build_outcome_model); empty = none
  size_t recorder_capacity = 8192;    // rows in the recorder's ring
  bool try_realtime_priority = true;  // ask for SCHED_FIFO (needs privileges; fine without)
};

// Median / p99 / max of a duration, in seconds.
struct TimingFigures {
  double median = 0, p99 = 0, max = 0;
};

// The loop's statistics, readable live from any thread (for a viewer) and at the end.
struct LoopStats {
  std::uint64_t ticks = 0;
  TimingFigures period;               // s, wake-up to wake-up (realtime only)
  TimingFigures step;                 // s, one tick's work: read, step, render, filter, write
  std::uint64_t deadline_misses = 0;  // realtime ticks whose work ended after the next deadline
  std::uint64_t resyncs = 0;          // times the loop fell > 10 ticks behind and reset its clock
  SafetyCounters safety;
  std::uint64_t recorder_dropped = 0; // rows the recorder's ring had no room for (should be 0)
  double max_force = 0;               // N, largest force sent
  TrainingMetrics metrics;            // the run's outcome and the trainee's metrics so far
  Vec3 last_force = Vec3::Zero();     // N, the last force sent
  Vec3 last_position = Vec3::Zero();  // m, the device's last position
  bool realtime_priority = false;     // whether SCHED_FIFO was granted
  bool running = false;
};

// Process-wide settings for a realtime haptic thread, as realtime Linux applications make them
// (call once at start, before threads and large allocations; the CLI's `run --realtime` and
// `view` do): glibc malloc never hands memory back to the kernel nor serves large blocks with
// mmap, so another thread's free (a renderer's frame buffers) never unmaps pages and interrupts
// the haptic thread's core with a TLB shoot-down; and the process's memory is locked in RAM
// (mlockall) when the memory-lock limit allows it, so the loop never takes a page fault to disk.
struct RealtimeProcess {
  bool malloc_pinned = false;  // mallopt accepted
  bool memory_locked = false;  // mlockall succeeded
};
RealtimeProcess prepare_realtime_process() noexcept;

// The haptic loop. Build it (everything that allocates happens here), then either start() a
// realtime thread or call run_headless() on your own thread. Not copyable; stop() before
// destroying the tissues or device.
class HapticLoop {
 public:
  static Result<std::unique_ptr<HapticLoop>> create(Device& device, std::vector<LoopTissue> tissues,
                                                    const LoopSettings& settings);
  ~HapticLoop();
  HapticLoop(const HapticLoop&) = delete;
  HapticLoop& operator=(const HapticLoop&) = delete;

  // Realtime: start the haptic thread (and the tissues' own physics threads).
  Status start();
  // Ask the threads to end and join them; safe to call twice. Zero force is written last.
  void stop();
  // Wait until max_ticks have run (realtime), then stop().
  void wait();
  // Headless: run `ticks` ticks now on the calling thread with simulated time, as fast as possible;
  // multi-rate tissues step inline every physics_dt so results are deterministic.
  void run_headless(std::uint64_t ticks);

  LoopStats stats() const;
  // Finish the recording (rename <csv>.part to <csv>); after stop(). The kept series are
  // t, tool_x, tool_y, tool_z, force_x, force_y, force_z, force_N, tool_qw, tool_qx, tool_qy,
  // tool_qz (the device's orientation, unit), one vector each.
  Status finish_recording();
  const std::vector<std::vector<double>>& series() const;
  // Tissue events drained during the run, in order (after finish_recording()); the loop adds a
  // "flashback" event (tissue: the vein) on the tick the tip first enters a vein's lumen.
  struct Event {
    double time = 0;
    std::string kind;
    int tissue = -1;
    double depth = 0, force = 0;
  };
  const std::vector<Event>& events() const;
  // Column names of the CSV (the figures of each tissue are prefixed with its name).
  const std::vector<std::string>& columns() const;

  struct Impl;

 private:
  explicit HapticLoop(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace palpate
