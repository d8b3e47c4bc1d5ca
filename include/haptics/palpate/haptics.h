// palpate/haptics.h — the haptic loop a simulator embeds: a thread at a fixed 1 ms period that
// reads the device, steps the tissues (some at their own rate), renders and filters the force,
// writes it, and records every tick; with live timing and safety statistics.
#pragma once

#include <palpate/contact.h>
#include <palpate/core.h>
#include <palpate/device.h>
#include <palpate/outcome.h>
#include <palpate/safety.h>
#include <palpate/scene_def.h>
#include <palpate/tissue.h>

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <span>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace palpate {

class Tissue;

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

// The physics period a scene gives a tissue (s): 1 / material.physics_rate for a mass-spring organ
// that sets one, else 0 (every tick on the haptic thread).
double scene_physics_dt(const TissueDef& tissue) noexcept;

// The tick's stages, in order (docs/architecture.md): each is timed every tick into LoopStats::stages.
enum class TickStage : std::uint8_t {
  read_devices,      // every tool's device: pose, velocity, buttons (a bad read holds the last good pose)
  step_tissues,      // inline tissues step; multi-rate ones render their local contact model
  render_forces,     // tool 0's force from the tissues (or the proxy's coupling); the others' own laws
  watchdog,          // a tick past its deadline sends zero
  safety_and_write,  // each tool's safety filter, then its device
  record,            // the row to the recorder, the tissues' events, the outcome
  live_figures,      // counters, forces and tool samples for other threads
};
inline constexpr size_t kTickStageCount = 7;
const char* tick_stage_name(TickStage stage) noexcept;

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
  PassivitySettings passivity;        // tool 0's passivity observer and controller (on by default)
  ToolDef tool;                       // tool.axis: the needle's (or blade's) direction at identity
                                      // orientation; each tick the tissues see orientation * tool.axis
  double blade_max_speed = 3.0;       // m/s, the fastest a blade's tip may move and still cut: a tick
                                      // that moves it farther (a glitch, a teleport) presses without
                                      // cutting and is counted (SafetyCounters::blade_teleport)
  std::filesystem::path csv;          // record every tick here (via <csv>.part); "" = no recording
  OutcomeModel outcome;               // roles and rest surfaces the run's outcome and metrics are
                                      // tracked over each tick (build_outcome_model); empty = none
  size_t recorder_capacity = 8192;    // rows in the recorder's ring
  bool try_realtime_priority = true;  // ask for SCHED_FIFO (needs privileges; fine without)
  bool time_stages = true;            // time each stage of every tick (LoopStats::stages; ~80 ns a
                                      // tick, docs/BENCHMARKS.md); false only to measure that cost
};

// Median / p99 / max of a duration, in seconds.
struct TimingFigures {
  double median = 0, p99 = 0, max = 0;
};

// A tool beside the needle (the ultrasound probe in the other hand): its own device, its own force
// law and its own safety filter (ForceSafety with the device's limits: finite, clamped to its
// max_force, rate-limited to its max_force_rate, ramped in, zero on a failed read or an overrun),
// read, evaluated and written on the same tick as the needle; zero force at stop. Not owned.
struct LoopTool {
  std::string name = "probe";       // prefix of its CSV columns (probe_x, ..., probe_force_N)
  Device* device = nullptr;         // its limits() bound its safety filter
  ToolForceModel* model = nullptr;  // force(position, orientation, t) on the haptic thread
  double ramp_in = 0.1;             // s, its forces ramp in from zero at start and after a fault
  // A tool that acts on the tissues as tool 0 does (a grasper in the other hand; `model` unused):
  // its shape (kind sphere: radius), posed into every tissue before its step (Tissue::set_second_tool,
  // device button 1 its grasp), its force the tissues' (Tissue::second_tool_force). At most one, and
  // only with every tissue stepped on the haptic thread.
  std::optional<ToolDef> tissue_tool;
  // Its passivity observer and controller (PassivityController; its damping capped by its device's
  // limits().damping), on by default.
  PassivitySettings passivity;
};

// One tool's newest tick, readable from any thread, never torn (a sequence lock the haptic thread
// never waits on). Tool 0 is the needle: `position` its tip as the tissues saw it, `axis` its
// direction; tools 1.. are the extra tools in create()'s order, `axis` unused.
struct ToolSample {
  bool valid = false;                    // false until the first tick
  double time = 0;                       // s, the tick's time
  std::uint64_t tick = 0;                // ticks done when it was taken (1 = the first)
  Vec3 position = Vec3::Zero();          // m
  Quat orientation = Quat::Identity();   // unit, the device's
  Vec3 axis = Vec3(0, -1, 0);            // unit, the needle's direction (tool 0)
  Vec3 force = Vec3::Zero();             // N, the force sent to its device
  std::uint32_t buttons = 0;             // its device's buttons (bit 0: a grasper's jaws closed)
};

// An extra tool's figures (LoopStats::tools).
struct LoopToolStats {
  std::string name;
  double max_force = 0;               // N, largest force sent to its device
  double max_force_limit = 0;         // N, its device's limit
  SafetyCounters safety;              // its own filter's counters
  PassivityCounters passivity;        // its own passivity controller's
  bool passivity_enabled = true;      // whether that controller adds damping (LoopTool::passivity)
  Vec3 last_force = Vec3::Zero();     // N
};

// A tissue stepped on its own thread (LoopTissue::physics_dt > 0; docs/haptics.md, "Multi-rate"):
// whether its physics kept its rate, and how the haptic thread rendered it.
struct LoopPhysicsStats {
  int tissue = -1;                    // index in the loop's tissues
  double period = 0;                  // s, the physics period asked for
  std::uint64_t steps = 0;            // physics steps taken
  TimingFigures step;                 // s, one physics step's work (the step and what it publishes)
  std::uint64_t late = 0;             // steps that ended after the next one was due (threaded only)
  std::uint64_t patch_ticks = 0;      // haptic ticks rendered from the compliant contact patch
  std::uint64_t patch_fallbacks = 0;  // ticks a published patch did not cover the tool (linearised instead)
};

// The loop's statistics, readable live from any thread (for a viewer) and at the end.
struct LoopStats {
  std::uint64_t ticks = 0;
  TimingFigures period;               // s, wake-up to wake-up (realtime only)
  TimingFigures step;                 // s, one tick's work: read, step, render, filter, write
  std::array<TimingFigures, kTickStageCount> stages{};  // s, each stage's share of it (TickStage order)
  std::uint64_t deadline_misses = 0;  // realtime ticks whose work ended after the next deadline
  std::uint64_t resyncs = 0;          // times the loop fell > 10 ticks behind and reset its clock
  SafetyCounters safety;
  PassivityCounters passivity;        // tool 0's passivity controller: what it did so far
  double passivity_energy = 0;        // J, tool 0's observed energy E now
  std::uint64_t recorder_dropped = 0; // rows the recorder's ring had no room for (should be 0)
  double max_force = 0;               // N, largest force sent
  TrainingMetrics metrics;            // the run's outcome and the trainee's metrics so far
  Vec3 last_force = Vec3::Zero();     // N, the last force sent
  Vec3 last_position = Vec3::Zero();  // m, the device's last position
  bool realtime_priority = false;     // whether SCHED_FIFO was granted
  bool running = false;
  std::vector<LoopToolStats> tools;   // the extra tools (create()'s order)
  std::vector<LoopPhysicsStats> physics;  // the tissues on their own thread, in tissue order
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
  // `tools`: extra tools beside the needle, each with its own device and safety (LoopTool).
  static Result<std::unique_ptr<HapticLoop>> create(Device& device, std::vector<LoopTissue> tissues,
                                                    const LoopSettings& settings,
                                                    std::vector<LoopTool> tools = {});
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
  // Tool i's newest tick (0 = the needle, 1.. the extra tools), from any thread; lock- and wait-free.
  ToolSample tool_sample(size_t i) const noexcept;
  size_t tool_count() const noexcept;  // 1 + the extra tools

  // Finish the recording (rename <csv>.part to <csv>); after stop(). The kept series are
  // t, tool_x, tool_y, tool_z, force_x, force_y, force_z, force_N, tool_qw, tool_qx, tool_qy,
  // tool_qz (the device's orientation, unit), one vector each; then per extra tool (named N)
  // N_x, N_y, N_z, N_qw, N_qx, N_qy, N_qz, N_force_x, N_force_y, N_force_z, N_force_N.
  Status finish_recording();
  // The kept series whole, in memory (read back from the recorder's temporary file on first call:
  // 96 bytes a tick for the needle's twelve; a long run's are large: for_each_series_row streams).
  const std::vector<std::vector<double>>& series() const;
  // The same row by row (after finish_recording()), a block at a time from the file, holding none
  // of the run in memory: `row` has one tick's values in series() order. An error when the file
  // could not be written (disk full) or read, or nothing was recorded.
  Status for_each_series_row(const std::function<void(std::span<const double> row)>& fn) const;
  std::uint64_t series_rows() const;
  // Tissue events drained during the run, in order (after finish_recording()); the loop adds a
  // "flashback" event (tissue: the vein) on the tick the tip first enters a vein's lumen.
  struct Event {
    double time = 0;
    std::string kind;
    int tissue = -1;
    double depth = 0, force = 0;
  };
  const std::vector<Event>& events() const;
  // Column names of the CSV (the figures of each tissue are prefixed with its name; each extra
  // tool's pose, force and safety events follow them, prefixed with the tool's name).
  const std::vector<std::string>& columns() const;
  // Names of the kept series' columns, in series() order (empty without a recording).
  const std::vector<std::string>& series_columns() const;

  struct Impl;

 private:
  explicit HapticLoop(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace palpate
