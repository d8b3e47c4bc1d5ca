// loop.cpp — HapticLoop: the fixed-period haptic thread (read device → step tissues → render →
// watchdog → safety → write device → record), its headless form and its live statistics.
#include <palpate/haptics.h>
#include <palpate/tissue.h>

#include "haptics/contact.h"
#include "haptics/histogram.h"
#include "haptics/multirate.h"
#include "haptics/pacing.h"
#include "haptics/recorder.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <thread>

#include <pthread.h>
#include <sched.h>

namespace palpate {

namespace {

// Row layout of run.csv; tissue figures follow the fixed columns (and the proxy's, if any).
enum Col : size_t {
  kT, kToolX, kToolY, kToolZ, kForceX, kForceY, kForceZ, kForceN, kTick,
  kQw, kQx, kQy, kQz, kButtons, kEvents, kFixedColumns
};
// The columns kept (in the recorder's temporary file) for series(): t .. force_N, then tool_qw .. tool_qz, then each extra
// tool's pose and force (create()).

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
  void publish(const ToolSample& v) noexcept {
    const std::uint64_t s = seq_.load(std::memory_order_relaxed);
    seq_.store(s + 1, std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_release);
    const double d[kN] = {v.time, double(v.tick), v.position.x(), v.position.y(), v.position.z(),
                          v.orientation.w(), v.orientation.x(), v.orientation.y(), v.orientation.z(),
                          v.axis.x(), v.axis.y(), v.axis.z(), v.force.x(), v.force.y(), v.force.z()};
    for (size_t i = 0; i < kN; ++i) v_[i].store(d[i], std::memory_order_relaxed);
    seq_.store(s + 2, std::memory_order_release);
  }
  ToolSample read() const noexcept {
    double d[kN];
    std::uint64_t s1 = 0;
    for (;;) {
      s1 = seq_.load(std::memory_order_acquire);
      if (s1 & 1u) continue;
      for (size_t i = 0; i < kN; ++i) d[i] = v_[i].load(std::memory_order_relaxed);
      std::atomic_thread_fence(std::memory_order_acquire);
      if (seq_.load(std::memory_order_relaxed) == s1) break;
    }
    ToolSample out;
    if (s1 == 0) return out;  // nothing published yet
    out.valid = true;
    out.time = d[0], out.tick = std::uint64_t(d[1]);
    out.position = Vec3(d[2], d[3], d[4]);
    out.orientation = Quat(d[5], d[6], d[7], d[8]);
    out.axis = Vec3(d[9], d[10], d[11]);
    out.force = Vec3(d[12], d[13], d[14]);
    return out;
  }

 private:
  static constexpr size_t kN = 15;
  std::atomic<std::uint64_t> seq_{0};
  std::atomic<double> v_[kN] = {};
};

TimingFigures figures_of(const LatencyHistogram& h) {
  return {h.percentile(0.5), h.percentile(0.99), h.max()};
}

}  // namespace

struct HapticLoop::Impl {
  // An extra tool (LoopTool): its device's state, its own safety filter and live figures.
  struct ToolSlot {
    LoopTool def;
    ForceSafety safety;
    DeviceState state;
    Vec3 last_good_position = Vec3::Zero();
    Quat last_good_orientation = Quat::Identity();
    TickFault read_fault = TickFault::none;
    size_t col = 0;  // its first CSV column
    RelaxedDouble max_force, fx, fy, fz;
    RelaxedCount non_finite, step_failed, clamped, rate_limited, overrun, stalled, device_failed;
    SampleExchange sample;
    ToolSlot(const LoopTool& t, double ramp) : def(t), safety(t.device->limits(), ramp) {}
  };
  static constexpr size_t kToolColumns = 12;  // x y z qw qx qy qz force_x force_y force_z force_N events

  struct Slot {
    Tissue* tissue = nullptr;
    std::unique_ptr<PhysicsWorker> worker;  // null: stepped on the haptic thread
    size_t figure_offset = 0, figure_count = 0;
  };

  Device& device;
  LoopSettings s;
  std::vector<Slot> slots;
  ForceSafety safety;
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

  // Haptic-thread state.
  ToolState tool;
  DeviceState state;
  OutcomeState outcome;
  Vec3 scene_axis = Vec3(0, -1, 0);      // unit, the needle's direction at identity (device frame)
  Vec3 last_good_position = Vec3::Zero();
  Quat last_good_orientation = Quat::Identity();
  std::uint64_t k = 0;                   // ticks done
  bool headless_now = false;

  // Shared with readers (live statistics); written only by the haptic thread.
  LatencyHistogram period_h, step_h;
  RelaxedCount ticks, misses, resyncs, non_finite, step_failed, clamped, rate_limited, overrun,
      stalled, device_failed;
  RelaxedDouble max_force, fx, fy, fz, px, py, pz;
  RelaxedCount m_outcome, m_skin_punctures, m_passes, m_redirections, m_flashback;
  RelaxedDouble m_flashback_time, m_first_skin, m_time_to_flashback, m_deepest;
  std::atomic<bool> running{false}, stop_requested{false}, priority{false};
  std::thread thread;
  std::vector<std::unique_ptr<ToolSlot>> tools;  // extra tools, in create()'s order
  SampleExchange needle_sample;                  // tool 0's newest tick
  size_t kept_series = 0;                        // columns the recorder keeps in memory
  std::vector<std::string> series_columns;       // their names, in series() order

  Impl(Device& d, const LoopSettings& settings)
      : device(d), s(settings), safety(d.limits(), settings.ramp_in) {}

  // Extra tools, step 1: read each device. A failed read or a non-finite or degenerate pose holds
  // the last good pose, and that tool's force goes to zero this tick (its own fault only).
  void read_tools(double t) noexcept {
    for (auto& tp : tools) {
      ToolSlot& x = *tp;
      const bool ok = x.def.device->read(t, x.state);
      const double qn = x.state.orientation.norm();
      if (!ok || !x.state.position.allFinite() || !std::isfinite(qn) || !(qn > 1e-6)) {
        x.read_fault = TickFault::device_failed;
        x.state.position = x.last_good_position;
        x.state.orientation = x.last_good_orientation;
        x.state.velocity.setZero();
      } else {
        if (qn != 1.0) x.state.orientation.coeffs() /= qn;
        x.read_fault = TickFault::none;
        x.last_good_position = x.state.position;
        x.last_good_orientation = x.state.orientation;
      }
    }
  }

  // Extra tools, steps 3–6: each tool's force law, its own safety filter, its device, its columns.
  // `fault`: the needle's tick fault; an overrun (the tick as a whole ran late) zeroes every tool,
  // a needle-only fault (a failed step, a stalled physics thread, the needle's device) does not.
  void send_tools(double t, double dt, TickFault fault) noexcept {
    for (auto& tp : tools) {
      ToolSlot& x = *tp;
      TickFault f = x.read_fault;
      if (f == TickFault::none && fault == TickFault::overrun) f = TickFault::overrun;
      const Vec3 request = f == TickFault::none ? x.def.model->force(x.state.position, x.state.orientation, t)
                                                : Vec3(Vec3::Zero());
      const Vec3 sent = x.safety.filter(request, dt, f);
      x.def.device->write(sent, Vec3::Zero());
      double* r = row.data() + x.col;
      r[0] = x.state.position.x(), r[1] = x.state.position.y(), r[2] = x.state.position.z();
      r[3] = x.state.orientation.w(), r[4] = x.state.orientation.x();
      r[5] = x.state.orientation.y(), r[6] = x.state.orientation.z();
      r[7] = sent.x(), r[8] = sent.y(), r[9] = sent.z();
      const double fn = sent.norm();
      r[10] = fn;
      r[11] = double(x.safety.last_events());
      if (fn > x.max_force.get()) x.max_force.set(fn);
      x.fx.set(sent.x()), x.fy.set(sent.y()), x.fz.set(sent.z());
      const SafetyCounters& c = x.safety.counters();
      x.non_finite.set(c.non_finite), x.step_failed.set(c.step_failed), x.clamped.set(c.clamped);
      x.rate_limited.set(c.rate_limited), x.overrun.set(c.overrun), x.stalled.set(c.stalled);
      x.device_failed.set(c.device_failed);
      ToolSample smp;
      smp.time = t, smp.tick = k + 1;
      smp.position = x.state.position, smp.orientation = x.state.orientation, smp.force = sent;
      x.sample.publish(smp);
    }
  }

  // Zero force to every extra tool (the loop's last word to each device).
  void zero_tools() noexcept {
    for (auto& tp : tools) tp->def.device->write(Vec3::Zero(), Vec3::Zero());
  }

  void publish_counters() noexcept {
    const SafetyCounters& c = safety.counters();
    non_finite.set(c.non_finite), step_failed.set(c.step_failed), clamped.set(c.clamped);
    rate_limited.set(c.rate_limited), overrun.set(c.overrun), stalled.set(c.stalled);
    device_failed.set(c.device_failed);
  }

  void publish_metrics() noexcept {
    const TrainingMetrics& m = outcome.metrics;
    m_outcome.set(std::uint64_t(m.outcome)), m_skin_punctures.set(std::uint64_t(m.skin_punctures));
    m_passes.set(std::uint64_t(m.passes)), m_redirections.set(std::uint64_t(m.redirections));
    m_flashback.set(m.flashback ? 1 : 0), m_flashback_time.set(m.flashback_time);
    m_first_skin.set(m.first_skin_puncture), m_time_to_flashback.set(m.time_to_flashback);
    m_deepest.set(m.deepest_depth);
  }

  // One tick. `deadline_ns`: when this tick's work must be done (realtime), 0 headless.
  void tick(std::int64_t deadline_ns) noexcept {
    const double dt = s.dt;
    const double t = double(k + 1) * dt;
    TickFault fault = TickFault::none;

    // 1. Device. A failed read, a non-finite pose or a degenerate orientation (no rotation can be
    // read from it) holds the last good pose: the needle neither jumps back to the scene's axis
    // inside the tissue nor turns on garbage.
    const bool read_ok = device.read(t, state);
    const double qn = state.orientation.norm();
    if (!read_ok || !state.position.allFinite() || !state.velocity.allFinite() || !std::isfinite(qn) ||
        !(qn > 1e-6)) {
      fault = TickFault::device_failed;
      state.position = last_good_position;
      state.velocity.setZero();
      state.orientation = last_good_orientation;
    } else {
      if (qn != 1.0) state.orientation.coeffs() /= qn;
      last_good_position = state.position;
      last_good_orientation = state.orientation;
    }
    read_tools(t);
    const bool virtual_coupling = s.coupling == Coupling::virtual_;
    tool.time = t;
    tool.tip = virtual_coupling ? proxy.position : state.position;
    tool.velocity = virtual_coupling ? proxy.velocity : state.velocity;
    // The needle points along the device's orientation applied to its device-frame axis, for the
    // HIP and the proxy alike. With no rotation it is the scene's axis exactly (no round-off), so
    // a device without orientation gives the same ticks as a fixed axis, bit for bit.
    tool.axis = needle_axis(scene_axis, state.orientation);
    tool.grasp = (state.buttons & 1u) != 0;

    // 2. Tissues: inline ones step now; multi-rate ones render their linearised contact.
    const std::int64_t now = deadline_ns ? monotonic_ns() : 0;
    Vec3 f_inline = Vec3::Zero(), f_rendered = Vec3::Zero();
    Mat3 j_rendered = Mat3::Zero();
    for (Slot& sl : slots) {
      std::span<double> figs(row.data() + sl.figure_offset, sl.figure_count);
      if (sl.worker) {
        Vec3 f;
        const TickFault tf =
            sl.worker->render(tool, now, headless_now ? 0.0 : s.watchdog.stall_timeout, f, figs);
        if (tf != TickFault::none && fault == TickFault::none) fault = tf;
        f_rendered += f;
        j_rendered += sl.worker->jacobian();
      } else {
        f_inline += sl.tissue->step(tool, dt);
        // A step that reset its tissue returns an ordinary zero: count it and restart the ramp.
        if (sl.tissue->last_step_failed() && fault == TickFault::none) fault = TickFault::step_failed;
        sl.tissue->figures(figs);
      }
    }
    const Vec3 f_tissue = f_inline + f_rendered;

    // 3. Rendering: the HIP's force, or the proxy's coupling force.
    Vec3 request = f_tissue;
    if (virtual_coupling) {
      if (f_tissue.allFinite()) {
        proxy_estimator.update(tool.tip, f_inline);
        request = step_proxy(coupling, proxy, state.position, state.velocity, f_tissue,
                             proxy_estimator.jacobian() + j_rendered, dt);
      }
      if (!f_tissue.allFinite() || !proxy.position.allFinite() || fault != TickFault::none) {
        proxy.position = state.position;  // start again at the device, at rest
        proxy.velocity.setZero();
        proxy_estimator.reset();
      }
    }

    // 4. Watchdog: work past its deadline by more than the margin sends zero.
    if (deadline_ns && fault == TickFault::none &&
        double(monotonic_ns() - deadline_ns) * 1e-9 > s.watchdog.overrun_margin)
      fault = TickFault::overrun;

    // 5. Safety, then the device.
    const Vec3 sent = safety.filter(request, dt, fault);
    device.write(sent, Vec3::Zero());
    send_tools(t, dt, fault);

    // 6. Record.
    double* r = row.data();
    r[kT] = t;
    r[kToolX] = state.position.x(), r[kToolY] = state.position.y(), r[kToolZ] = state.position.z();
    r[kForceX] = sent.x(), r[kForceY] = sent.y(), r[kForceZ] = sent.z();
    const double fn = sent.norm();
    r[kForceN] = fn;
    r[kTick] = double(k);
    r[kQw] = state.orientation.w(), r[kQx] = state.orientation.x();
    r[kQy] = state.orientation.y(), r[kQz] = state.orientation.z();
    r[kButtons] = double(state.buttons);
    r[kEvents] = double(safety.last_events());
    if (proxy_col) {
      r[proxy_col] = proxy.position.x(), r[proxy_col + 1] = proxy.position.y();
      r[proxy_col + 2] = proxy.position.z();
    }
    if (recorder) {
      if (headless_now)
        recorder->push_wait(row);
      else
        recorder->push(row);
    }
    for (size_t i = 0; i < slots.size(); ++i) {
      size_t n = 0;
      while ((n = slots[i].worker ? slots[i].worker->drain_events(event_buf)
                                  : slots[i].tissue->drain_events(event_buf)) > 0)
        for (size_t e = 0; e < n; ++e) {
          const TissueEvent& ev = event_buf[e];
          outcome_event(s.outcome, outcome, ev.kind, int(i), ev.time, tool.tip, tool.axis);
          if (recorder) (void)recorder->push_event({ev.time, ev.kind, int(i), ev.depth, ev.force});
        }
    }
    // The outcome after this tick's events: where the tip is now (as the tissues saw it).
    if (outcome_tick(s.outcome, outcome, t, tool.tip, tool.axis, fn) && recorder)
      (void)recorder->push_event({t, "flashback", outcome.flashback_tissue, outcome.flashback_depth,
                                  outcome.flashback_force});

    // 7. Live figures.
    ++k;
    ticks.set(k);
    if (fn > max_force.get()) max_force.set(fn);
    fx.set(sent.x()), fy.set(sent.y()), fz.set(sent.z());
    px.set(state.position.x()), py.set(state.position.y()), pz.set(state.position.z());
    publish_counters();
    publish_metrics();
    ToolSample smp;
    smp.time = t, smp.tick = k;
    smp.position = tool.tip, smp.orientation = state.orientation, smp.axis = tool.axis, smp.force = sent;
    needle_sample.publish(smp);
  }

  void thread_main() noexcept {
    if (s.try_realtime_priority) priority.store(try_realtime_priority(80));
    const auto period = static_cast<std::int64_t>(std::llround(s.dt * 1e9));
    const auto spin = static_cast<std::int64_t>(s.spin * 1e9);
    std::int64_t next = monotonic_ns() + period;
    std::int64_t prev_wake = 0;
    while (!stop_requested.load(std::memory_order_acquire) && (s.max_ticks == 0 || k < s.max_ticks)) {
      sleep_until_ns(next, spin);
      const std::int64_t wake = monotonic_ns();
      if (prev_wake) period_h.add(double(wake - prev_wake) * 1e-9);
      prev_wake = wake;
      tick(next + period);
      const std::int64_t end = monotonic_ns();
      step_h.add(double(end - wake) * 1e-9);
      if (end > next + period) misses.inc();
      next += period;
      if (end > next + 10 * period) {  // far behind (the process was stopped): start afresh
        next = end + period;
        resyncs.inc();
      }
    }
    // The last word is zero, reached within the rate limit one tick at a time (at most 1 s of
    // ticks; a device that allows no faster change gets the zero then).
    // Every tool (the probe too) ramps down through its own filter.
    const auto any_force = [&] {
      if (!safety.last().isZero()) return true;
      for (auto& tp : tools)
        if (!tp->safety.last().isZero()) return true;
      return false;
    };
    for (std::int64_t i = 0; i * period < 1'000'000'000 && any_force(); ++i) {
      sleep_until_ns(next, spin);
      device.write(safety.ramp_down(s.dt), Vec3::Zero());
      for (auto& tp : tools) tp->def.device->write(tp->safety.ramp_down(s.dt), Vec3::Zero());
      next += period;
    }
    device.write(Vec3::Zero(), Vec3::Zero());
    fx.set(0), fy.set(0), fz.set(0);
    zero_tools();
    running.store(false, std::memory_order_release);
  }
};

HapticLoop::HapticLoop(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

HapticLoop::~HapticLoop() {
  stop();
  if (impl_->recorder) (void)impl_->recorder->close();
}

Result<std::unique_ptr<HapticLoop>> HapticLoop::create(Device& device, std::vector<LoopTissue> tissues,
                                                       const LoopSettings& settings,
                                                       std::vector<LoopTool> tools) {
  if (!(settings.dt > 0) || !std::isfinite(settings.dt))
    return Error{"haptic loop: dt must be a positive number of seconds"};
  auto impl = std::make_unique<Impl>(device, settings);
  Impl& m = *impl;
  m.coupling = make_coupling(device.limits(), settings.proxy_mass, settings.coupling_stiffness);
  m.tool.radius = settings.tool.radius;
  m.tool.needle = settings.tool.kind == "needle";
  m.tool.length = m.tool.needle ? settings.tool.length : 0.0;
  if (settings.tool.axis.allFinite() && settings.tool.axis.norm() > 0)
    m.scene_axis = settings.tool.axis.normalized();
  m.tool.axis = m.scene_axis;
  m.columns = {"t", "tool_x", "tool_y", "tool_z", "force_x", "force_y", "force_z", "force_N",
               "tick", "tool_qw", "tool_qx", "tool_qy", "tool_qz", "buttons", "events"};
  if (settings.coupling == Coupling::virtual_) {
    m.proxy_col = m.columns.size();
    for (const char* c : {"proxy_x", "proxy_y", "proxy_z"}) m.columns.push_back(c);
  }
  // The proxy starts where the device is.
  DeviceState first;
  if (device.read(0.0, first) && first.position.allFinite()) {
    m.proxy.position = first.position;
    m.last_good_position = first.position;
    const double qn = first.orientation.norm();
    if (std::isfinite(qn) && qn > 1e-6) m.last_good_orientation = Quat(first.orientation.coeffs() / qn);
  }
  for (size_t i = 0; i < tissues.size(); ++i) {
    const LoopTissue& lt = tissues[i];
    if (!lt.tissue) return Error{"haptic loop: tissue " + std::to_string(i) + " is null"};
    if (lt.physics_dt < 0 || !std::isfinite(lt.physics_dt))
      return Error{"haptic loop: tissue '" + lt.tissue->name() + "': physics_dt must be >= 0 s"};
    Impl::Slot sl;
    sl.tissue = lt.tissue;
    sl.figure_offset = m.columns.size();
    for (const auto& f : lt.tissue->figure_names()) m.columns.push_back(lt.tissue->name() + "." + f);
    sl.figure_count = m.columns.size() - sl.figure_offset;
    if (lt.physics_dt > 0)
      sl.worker = std::make_unique<PhysicsWorker>(*lt.tissue, int(i), lt.physics_dt, settings.dt,
                                                  device.limits().stiffness, settings.realtime);
    m.slots.push_back(std::move(sl));
  }
  for (size_t i = 0; i < tools.size(); ++i) {
    const LoopTool& t = tools[i];
    const std::string which = "haptic loop: tool " + std::to_string(i + 1) + " '" + t.name + "'";
    if (!t.device || !t.model) return Error{which + ": needs a device and a force model"};
    if (t.name.empty()) return Error{"haptic loop: tool " + std::to_string(i + 1) + " needs a name"};
    for (const auto& u : m.tools)
      if (u->def.name == t.name) return Error{which + ": two tools have that name"};
    if (!(t.ramp_in >= 0) || !std::isfinite(t.ramp_in)) return Error{which + ": ramp_in must be >= 0 s"};
    auto slot = std::make_unique<Impl::ToolSlot>(t, t.ramp_in);
    slot->col = m.columns.size();
    for (const char* c : {"_x", "_y", "_z", "_qw", "_qx", "_qy", "_qz", "_force_x", "_force_y",
                          "_force_z", "_force_N", "_events"})
      m.columns.push_back(t.name + c);
    DeviceState at_start;  // the tool holds this pose if its first reads fail
    if (t.device->read(0.0, at_start) && at_start.position.allFinite()) {
      slot->last_good_position = at_start.position;
      const double qn = at_start.orientation.norm();
      if (std::isfinite(qn) && qn > 1e-6) slot->last_good_orientation = Quat(at_start.orientation.coeffs() / qn);
    }
    m.tools.push_back(std::move(slot));
  }
  m.publish_metrics();  // the live figures start as "nothing yet" (no flashback time 0 s)
  m.row.assign(m.columns.size(), 0.0);
  m.event_buf.resize(64);
  if (!settings.csv.empty()) {
    std::vector<ColumnFormat> formats(m.columns.size(), ColumnFormat::number);
    formats[kTick] = formats[kButtons] = ColumnFormat::integer;
    formats[kEvents] = ColumnFormat::safety_events;
    RecorderOptions ro;
    ro.capacity_rows = settings.recorder_capacity;
    ro.keep_columns = {kT, kToolX, kToolY, kToolZ, kForceX, kForceY, kForceZ, kForceN, kQw, kQx, kQy, kQz};
    for (const auto& tp : m.tools) {
      formats[tp->col + Impl::kToolColumns - 1] = ColumnFormat::safety_events;
      for (size_t c = 0; c + 1 < Impl::kToolColumns; ++c) ro.keep_columns.push_back(tp->col + c);
    }
    m.kept_series = ro.keep_columns.size();
    for (size_t c : ro.keep_columns) m.series_columns.push_back(m.columns[c]);
    auto rec = Recorder::open(settings.csv, m.columns, formats, ro);
    if (!rec) return rec.error();
    m.recorder = std::move(*rec);
  }
  return std::unique_ptr<HapticLoop>(new HapticLoop(std::move(impl)));
}

Status HapticLoop::start() {
  Impl& m = *impl_;
  if (!m.s.realtime) return Error{"haptic loop: built for headless runs (settings.realtime = false)"};
  if (m.running.load() || m.thread.joinable()) return Error{"haptic loop: already started"};
  // Both cores (issue 24): with a multi-rate tissue on a machine of two CPUs or more, the haptic
  // thread runs on the first and the physics threads on the others, so a physics step never takes
  // the haptic thread's core. Best effort: a refused affinity (a cgroup without those CPUs) leaves
  // the threads to the scheduler.
  const unsigned ncpu = std::thread::hardware_concurrency();
  bool pinned = false;
  int next_cpu = 1;
  for (auto& sl : m.slots)
    if (sl.worker) {
      if (ncpu >= 2) {
        sl.worker->set_cpu(next_cpu);
        next_cpu = next_cpu + 1 < static_cast<int>(ncpu) ? next_cpu + 1 : 1;
        pinned = true;
      }
      sl.worker->start();
    }
  m.stop_requested.store(false);
  m.running.store(true);
  m.thread = std::thread([&m] { m.thread_main(); });
  if (pinned) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(0, &set);
    (void)pthread_setaffinity_np(m.thread.native_handle(), sizeof(set), &set);
  }
  return {};
}

void HapticLoop::stop() {
  Impl& m = *impl_;
  m.stop_requested.store(true, std::memory_order_release);
  if (m.thread.joinable()) m.thread.join();
  for (auto& sl : m.slots)
    if (sl.worker) sl.worker->stop();
  m.zero_tools();  // the haptic thread has ended (or never ran): the tools' last word is zero too
  m.running.store(false);
}

void HapticLoop::wait() {
  Impl& m = *impl_;
  if (m.thread.joinable()) m.thread.join();
  stop();
}

void HapticLoop::run_headless(std::uint64_t ticks) {
  Impl& m = *impl_;
  m.headless_now = true;
  for (auto& sl : m.slots)
    if (sl.worker) sl.worker->start();
  for (std::uint64_t i = 0; i < ticks; ++i) {
    const std::int64_t start = monotonic_ns();
    m.tick(0);
    m.step_h.add(double(monotonic_ns() - start) * 1e-9);
  }
  m.headless_now = false;
}

LoopStats HapticLoop::stats() const {
  const Impl& m = *impl_;
  LoopStats st;
  st.ticks = m.ticks.get();
  st.period = figures_of(m.period_h);
  st.step = figures_of(m.step_h);
  st.deadline_misses = m.misses.get();
  st.resyncs = m.resyncs.get();
  st.safety.non_finite = m.non_finite.get();
  st.safety.step_failed = m.step_failed.get();
  st.safety.clamped = m.clamped.get();
  st.safety.rate_limited = m.rate_limited.get();
  st.safety.overrun = m.overrun.get();
  st.safety.stalled = m.stalled.get();
  st.safety.device_failed = m.device_failed.get();
  st.recorder_dropped = m.recorder ? m.recorder->dropped() : 0;
  st.max_force = m.max_force.get();
  TrainingMetrics& tm = st.metrics;
  tm.outcome = static_cast<Outcome>(m.m_outcome.get());
  tm.skin_punctures = int(m.m_skin_punctures.get()), tm.passes = int(m.m_passes.get());
  tm.redirections = int(m.m_redirections.get()), tm.flashback = m.m_flashback.get() != 0;
  tm.flashback_time = m.m_flashback_time.get(), tm.first_skin_puncture = m.m_first_skin.get();
  tm.time_to_flashback = m.m_time_to_flashback.get(), tm.deepest_depth = m.m_deepest.get();
  tm.peak_force = st.max_force;
  st.last_force = Vec3(m.fx.get(), m.fy.get(), m.fz.get());
  st.last_position = Vec3(m.px.get(), m.py.get(), m.pz.get());
  st.realtime_priority = m.priority.load();
  st.running = m.running.load();
  for (const auto& tp : m.tools) {
    const Impl::ToolSlot& x = *tp;
    LoopToolStats ts;
    ts.name = x.def.name;
    ts.max_force = x.max_force.get();
    ts.max_force_limit = x.def.device->limits().max_force;
    ts.safety.non_finite = x.non_finite.get(), ts.safety.step_failed = x.step_failed.get();
    ts.safety.clamped = x.clamped.get(), ts.safety.rate_limited = x.rate_limited.get();
    ts.safety.overrun = x.overrun.get(), ts.safety.stalled = x.stalled.get();
    ts.safety.device_failed = x.device_failed.get();
    ts.last_force = Vec3(x.fx.get(), x.fy.get(), x.fz.get());
    st.tools.push_back(std::move(ts));
  }
  for (size_t i = 0; i < m.slots.size(); ++i) {
    const PhysicsWorker* w = m.slots[i].worker.get();
    if (!w) continue;
    LoopPhysicsStats ps;
    ps.tissue = static_cast<int>(i);
    ps.period = w->physics_dt();
    ps.steps = w->physics_steps();
    ps.step = figures_of(w->step_times());
    ps.late = w->late_steps();
    ps.patch_ticks = w->patch_ticks();
    ps.patch_fallbacks = w->patch_fallbacks();
    st.physics.push_back(ps);
  }
  return st;
}

ToolSample HapticLoop::tool_sample(size_t i) const noexcept {
  const Impl& m = *impl_;
  if (i == 0) return m.needle_sample.read();
  if (i - 1 < m.tools.size()) return m.tools[i - 1]->sample.read();
  return {};
}

size_t HapticLoop::tool_count() const noexcept { return 1 + impl_->tools.size(); }

Status HapticLoop::finish_recording() {
  Impl& m = *impl_;
  if (!m.recorder) return {};
  if (m.running.load()) return Error{"haptic loop: stop() before finish_recording()"};
  Status st = m.recorder->close();
  m.series.clear();
  m.series_loaded = false;
  m.events.clear();
  for (const RecorderEvent& e : m.recorder->events())
    m.events.push_back({e.time, e.kind, e.tissue, e.depth, e.force});
  return st;
}

const std::vector<std::vector<double>>& HapticLoop::series() const {
  Impl& m = *impl_;
  if (!m.series_loaded && m.recorder) {
    m.series_loaded = true;
    for (size_t i = 0; i < m.kept_series; ++i) m.series.push_back(m.recorder->kept(i));
  }
  return m.series;
}

Status HapticLoop::for_each_series_row(const std::function<void(std::span<const double> row)>& fn) const {
  if (!impl_->recorder) return Error{"haptic loop: no recording, so no series"};
  return impl_->recorder->for_each_kept(fn);
}

std::uint64_t HapticLoop::series_rows() const { return impl_->recorder ? impl_->recorder->kept_rows() : 0; }
const std::vector<HapticLoop::Event>& HapticLoop::events() const { return impl_->events; }
const std::vector<std::string>& HapticLoop::columns() const { return impl_->columns; }
const std::vector<std::string>& HapticLoop::series_columns() const { return impl_->series_columns; }

}  // namespace palpate
