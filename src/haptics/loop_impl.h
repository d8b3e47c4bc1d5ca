// loop_impl.h — HapticLoop's insides, shared by loop.cpp (building, threads, statistics) and
// tick.cpp (the tick's named stages): the tools in one array, the tissues' slots, the live figures
// other threads read, and the stage clock.
#pragma once

#include <palpate/haptics.h>
#include <palpate/tissue.h>

#include "haptics/contact.h"
#include "haptics/histogram.h"
#include "haptics/multirate.h"
#include "haptics/recorder.h"

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace palpate {

// The row's fixed columns (run.csv): create() names them, the tick's record stage writes them;
// tissue figures follow (and the proxy's, if any), then each extra tool's kToolColumns.
enum LoopColumn : size_t {
  kT, kToolX, kToolY, kToolZ, kForceX, kForceY, kForceZ, kForceN, kTick, kQw, kQx, kQy, kQz, kButtons, kEvents,
  kPassivityEnergy, kPassivityDamping, kFixedColumns
};

// A double shared between threads, written by one.
struct RelaxedDouble {
  std::atomic<double> v{0};
  void set(double x) noexcept { v.store(x, std::memory_order_relaxed); }
  double get() const noexcept { return v.load(std::memory_order_relaxed); }
};
struct RelaxedCount {
  std::atomic<std::uint64_t> v{0};
  void set(std::uint64_t x) noexcept { v.store(x, std::memory_order_relaxed); }
  void inc() noexcept { set(get() + 1); }
  std::uint64_t get() const noexcept { return v.load(std::memory_order_relaxed); }
};

// A tool's newest tick for readers on other threads: a sequence lock over relaxed atomics (the
// writer never waits; a reader retries the rare read that overlapped a write). Any number of readers.
class SampleExchange {
 public:
  void publish(const ToolSample& v) noexcept;
  ToolSample read() const noexcept;

 private:
  static constexpr size_t kN = 16;
  std::atomic<std::uint64_t> seq_{0};
  std::atomic<double> v_[kN] = {};
};

// The stage clock: the CPU's time-stamp counter where it is invariant (x86-64: ~10 ns a read here,
// against clock_gettime's ~25 ns), calibrated once per process against CLOCK_MONOTONIC; elsewhere
// CLOCK_MONOTONIC itself. Eight reads a tick time the seven stages.
struct StageClock {
  static std::uint64_t now() noexcept;
  static double seconds_per_count() noexcept;  // calibrated on first call (1 ms), then constant
};

// Durations per stage, written by the haptic thread, read live by any other.
struct StageTimes {
  std::array<CountHistogram, kTickStageCount> h;  // in StageClock counts
};

struct HapticLoop::Impl {
  // A tool in the hand: its device's state, its own safety filter and live figures. Tool 0 is the
  // scene's tool, its force the tissues' (through the coupling); tools 1.. have a force law of their own.
  struct ToolSlot {
    LoopTool def;
    ForceSafety safety;
    PassivityController passivity;
    DeviceState state;
    Vec3 last_good_position = Vec3::Zero();
    Quat last_good_orientation = Quat::Identity();
    TickFault read_fault = TickFault::none;
    Vec3 request = Vec3::Zero();  // N, this tick's force before the safety filter
    Vec3 sent = Vec3::Zero();     // N, after it: what the device got
    size_t col = 0;               // its first CSV column (tools 1..)
    RelaxedDouble max_force, fx, fy, fz, px, py, pz;
    RelaxedCount non_finite, step_failed, clamped, rate_limited, overrun, stalled, device_failed;
    RelaxedCount blade_teleport;
    RelaxedCount pc_active, pc_capped;
    RelaxedDouble pc_dissipated, pc_min_energy, pc_max_damping, pc_energy;
    std::uint64_t blade_teleports = 0;  // the loop's own count (the filter's are in `safety`)
    std::uint32_t loop_events = 0;      // SafetyEvent bits the loop set this tick (kEventBladeTeleport)
    bool grasp = false;                 // a tissue tool's grasp (button 1) as last read well
    SampleExchange sample;
    ToolSlot(const LoopTool& t, double ramp)
        : def(t), safety(t.device->limits(), ramp), passivity(t.device->limits(), t.passivity) {}
    void publish_counters() noexcept;
    SafetyCounters counters() const noexcept;
    PassivityCounters passivity_counters() const noexcept;
  };
  // x y z qw qx qy qz force_x force_y force_z force_N events passivity_energy passivity_damping
  static constexpr size_t kToolColumns = 14;
  static constexpr size_t kToolEvents = 11;  // its `events` column, after the kept series

  struct Slot {
    Tissue* tissue = nullptr;
    std::unique_ptr<PhysicsWorker> worker;  // null: stepped on the haptic thread
    size_t figure_offset = 0, figure_count = 0;
  };

  // What one tick carries from stage to stage.
  struct TickState {
    double t = 0;                    // s, this tick's time
    std::int64_t deadline_ns = 0;    // when its work must be done (realtime), 0 headless
    TickFault fault = TickFault::none;  // tool 0's: a failed read, step or stalled physics, an overrun
    Vec3 f_inline = Vec3::Zero();    // N, the tissues stepped on this thread
    Vec3 f_tissue = Vec3::Zero();    // N, with those rendered from a multi-rate model
    Mat3 j_rendered = Mat3::Zero();  // N/m, the rendered contacts' stiffness
    Vec3 f_second = Vec3::Zero();    // N, the tissues' force on the tool acting on them beside tool 0
    double force_norm = 0;           // N, |force sent to tool 0|
  };

  LoopSettings s;
  std::vector<std::unique_ptr<ToolSlot>> tools;  // tool 0, then the extra tools in create()'s order
  std::vector<Slot> slots;
  CouplingModel coupling;
  ProxyState proxy;
  ContactEstimator proxy_estimator{1e7};  // N/m bound: the tissue's own stiffness, not the device's
  std::vector<std::string> columns;
  size_t proxy_col = 0;
  std::vector<double> row;               // one tick's record (sized once)
  std::vector<TissueEvent> event_buf;
  std::unique_ptr<Recorder> recorder;
  std::vector<std::vector<double>> series;  // series(), read from the recorder's file on first use
  bool series_loaded = false;
  std::vector<Event> events;
  size_t kept_series = 0;                   // columns the recorder keeps
  std::vector<std::string> series_columns;  // their names, in series() order

  // Haptic-thread state.
  ToolState tool;
  ToolState seen;  // the tool as the tissues meet it: mapped to rest by the tools that deform them
  OutcomeState outcome;
  Vec3 scene_axis = Vec3(0, -1, 0);  // unit, the needle's direction at identity (device frame)
  // A blade tool (settings.tool.kind "blade"): where its edge's ends were last tick, to tell a hand's
  // stroke from a teleport (LoopSettings::blade_max_speed).
  bool blade_tool = false;
  bool blade_prev_valid = false;
  std::int64_t blade_prev_ns = 0;  // realtime: when the last tick's blade was read (0: headless)
  Vec3 blade_prev_tip = Vec3::Zero(), blade_prev_heel = Vec3::Zero();
  std::uint64_t k = 0;               // ticks done
  bool headless_now = false;

  // Shared with readers (live statistics); written only by the haptic thread.
  LatencyHistogram period_h, step_h;
  StageTimes stages;
  RelaxedCount ticks, misses, resyncs;
  RelaxedCount m_outcome, m_skin_punctures, m_passes, m_redirections, m_flashback, m_arterial;
  RelaxedDouble m_flashback_time, m_first_skin, m_time_to_flashback, m_deepest, m_arterial_time;
  std::atomic<bool> running{false}, stop_requested{false}, priority{false};
  std::thread thread;

  explicit Impl(const LoopSettings& settings) : s(settings) {}
  ToolSlot& needle() noexcept { return *tools.front(); }
  const ToolSlot& needle() const noexcept { return *tools.front(); }

  // The tick (tick.cpp): the stages in order, each timed into `stages`. Returns the tick's whole
  // duration in StageClock counts (0 when settings.time_stages is off).
  std::uint64_t tick(std::int64_t deadline_ns) noexcept;
  void read_devices(TickState& ts) noexcept;
  void gate_blade(const TickState& ts) noexcept;
  void step_tissues(TickState& ts) noexcept;
  void render_forces(TickState& ts) noexcept;
  void watchdog(TickState& ts) noexcept;
  void safety_and_write(TickState& ts) noexcept;
  void record(TickState& ts) noexcept;
  void live_figures(TickState& ts) noexcept;

  void zero_tools() noexcept;
  void publish_metrics() noexcept;
  void thread_main() noexcept;
};

}  // namespace palpate
