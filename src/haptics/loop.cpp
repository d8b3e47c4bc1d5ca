// loop.cpp — HapticLoop: built once (tools, tissues, recorder), the fixed-period haptic thread that
// calls the tick (tick.cpp: its named, timed stages), its headless form and its live statistics.
#include "haptics/loop_impl.h"

#include "haptics/pacing.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <thread>

#include <pthread.h>
#include <sched.h>

namespace palpate {

namespace {


TimingFigures figures_of(const LatencyHistogram& h) {
  return {h.percentile(0.5), h.percentile(0.99), h.max()};
}

}  // namespace

void SampleExchange::publish(const ToolSample& v) noexcept {
  const std::uint64_t s = seq_.load(std::memory_order_relaxed);
  seq_.store(s + 1, std::memory_order_relaxed);
  std::atomic_thread_fence(std::memory_order_release);
  const double d[kN] = {v.time, double(v.tick), v.position.x(), v.position.y(), v.position.z(),
                        v.orientation.w(), v.orientation.x(), v.orientation.y(), v.orientation.z(),
                        v.axis.x(), v.axis.y(), v.axis.z(), v.force.x(), v.force.y(), v.force.z(),
                        double(v.buttons)};
  for (size_t i = 0; i < kN; ++i) v_[i].store(d[i], std::memory_order_relaxed);
  seq_.store(s + 2, std::memory_order_release);
}

ToolSample SampleExchange::read() const noexcept {
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
  out.buttons = std::uint32_t(d[15]);
  return out;
}

void HapticLoop::Impl::ToolSlot::publish_counters() noexcept {
  const SafetyCounters& c = safety.counters();
  non_finite.set(c.non_finite), step_failed.set(c.step_failed), clamped.set(c.clamped);
  rate_limited.set(c.rate_limited), overrun.set(c.overrun), stalled.set(c.stalled);
  device_failed.set(c.device_failed);
  blade_teleport.set(blade_teleports);
  const PassivityCounters& p = passivity.counters();
  pc_active.set(p.active_ticks), pc_capped.set(p.capped_ticks);
  pc_dissipated.set(p.dissipated), pc_min_energy.set(p.min_energy), pc_max_damping.set(p.max_damping);
  pc_energy.set(passivity.energy());
}

PassivityCounters HapticLoop::Impl::ToolSlot::passivity_counters() const noexcept {
  PassivityCounters p;
  p.active_ticks = pc_active.get(), p.capped_ticks = pc_capped.get();
  p.dissipated = pc_dissipated.get(), p.min_energy = pc_min_energy.get(), p.max_damping = pc_max_damping.get();
  return p;
}

SafetyCounters HapticLoop::Impl::ToolSlot::counters() const noexcept {
  SafetyCounters c;
  c.non_finite = non_finite.get(), c.step_failed = step_failed.get(), c.clamped = clamped.get();
  c.rate_limited = rate_limited.get(), c.overrun = overrun.get(), c.stalled = stalled.get();
  c.device_failed = device_failed.get();
  c.blade_teleport = blade_teleport.get();
  return c;
}

// Zero force to every extra tool (the loop's last word to each device).
void HapticLoop::Impl::zero_tools() noexcept {
  for (size_t i = 1; i < tools.size(); ++i) tools[i]->def.device->write(Vec3::Zero(), Vec3::Zero());
}

void HapticLoop::Impl::publish_metrics() noexcept {
  const TrainingMetrics& m = outcome.metrics;
  m_outcome.set(std::uint64_t(m.outcome)), m_skin_punctures.set(std::uint64_t(m.skin_punctures));
  m_passes.set(std::uint64_t(m.passes)), m_redirections.set(std::uint64_t(m.redirections));
  m_flashback.set(m.flashback ? 1 : 0), m_flashback_time.set(m.flashback_time);
  m_first_skin.set(m.first_skin_puncture), m_time_to_flashback.set(m.time_to_flashback);
  m_deepest.set(m.deepest_depth);
  m_arterial.set(m.arterial_flashback ? 1 : 0), m_arterial_time.set(m.arterial_flashback_time);
}

void HapticLoop::Impl::thread_main() noexcept {
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
  // ticks; a device that allows no faster change gets the zero then). Every tool (the probe too)
  // ramps down through its own filter.
  const auto any_force = [&] {
    for (auto& tp : tools)
      if (!tp->safety.last().isZero()) return true;
    return false;
  };
  for (std::int64_t i = 0; i * period < 1'000'000'000 && any_force(); ++i) {
    sleep_until_ns(next, spin);
    for (auto& tp : tools) tp->def.device->write(tp->safety.ramp_down(s.dt), Vec3::Zero());
    next += period;
  }
  needle().def.device->write(Vec3::Zero(), Vec3::Zero());
  needle().fx.set(0), needle().fy.set(0), needle().fz.set(0);
  zero_tools();
  running.store(false, std::memory_order_release);
}

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
  auto impl = std::make_unique<Impl>(settings);
  Impl& m = *impl;
  m.coupling = make_coupling(device.limits(), settings.proxy_mass, settings.coupling_stiffness);
  m.tool.radius = settings.tool.radius;
  m.tool.needle = settings.tool.kind == "needle";
  m.blade_tool = settings.tool.kind == "blade";
  m.tool.blade = m.blade_tool;
  m.tool.length = m.tool.needle || m.blade_tool ? settings.tool.length : 0.0;
  // A blade is an edge: one of no length would cut along a point (the scene loader refuses it too).
  if (m.blade_tool && !(settings.tool.length > 0 && std::isfinite(settings.tool.length)))
    return Error{"haptic loop: a blade tool needs an edge length > 0 m (tool.length)"};
  if (m.blade_tool && !(settings.blade_max_speed > 0 && std::isfinite(settings.blade_max_speed)))
    return Error{"haptic loop: blade_max_speed must be a positive number of m/s"};
  if (settings.tool.axis.allFinite() && settings.tool.axis.norm() > 0)
    m.scene_axis = settings.tool.axis.normalized();
  m.tool.axis = m.scene_axis;
  m.columns = {"t", "tool_x", "tool_y", "tool_z", "force_x", "force_y", "force_z", "force_N",
               "tick", "tool_qw", "tool_qx", "tool_qy", "tool_qz", "buttons", "events",
               "passivity_energy", "passivity_damping"};
  if (settings.coupling == Coupling::virtual_) {
    m.proxy_col = m.columns.size();
    for (const char* c : {"proxy_x", "proxy_y", "proxy_z"}) m.columns.push_back(c);
  }
  // Tool 0: the scene's tool on `device`, its force the tissues'. Each tool holds its pose at
  // start if its first reads fail; the proxy starts where the device is.
  m.tools.push_back(std::make_unique<Impl::ToolSlot>(LoopTool{"tool", &device, nullptr, settings.ramp_in, std::nullopt, settings.passivity}, settings.ramp_in));
  auto start_pose = [](Impl::ToolSlot& x) {
    DeviceState at_start;
    if (!x.def.device->read(0.0, at_start) || !at_start.position.allFinite()) return false;
    x.last_good_position = at_start.position;
    const double qn = at_start.orientation.norm();
    if (std::isfinite(qn) && qn > 1e-6) x.last_good_orientation = Quat(at_start.orientation.coeffs() / qn);
    return true;
  };
  if (start_pose(m.needle())) m.proxy.position = m.needle().last_good_position;
  for (size_t i = 0; i < tissues.size(); ++i) {
    const LoopTissue& lt = tissues[i];
    if (!lt.tissue) return Error{"haptic loop: tissue " + std::to_string(i) + " is null"};
    if (lt.physics_dt < 0 || !std::isfinite(lt.physics_dt))
      return Error{"haptic loop: tissue '" + lt.tissue->name() + "': physics_dt must be >= 0 s"};
    Impl::Slot sl;
    sl.tissue = lt.tissue;
    lt.tissue->set_real_time(settings.realtime);  // off-thread work (a cut's correction) waits for no tick
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
    if (!t.device || (!t.model && !t.tissue_tool)) return Error{which + ": needs a device and a force model"};
    if (t.tissue_tool) {
      for (size_t u = 1; u < m.tools.size(); ++u)
        if (m.tools[u]->def.tissue_tool) return Error{which + ": a second tool already acts on the tissues (one may)"};
      for (const auto& sl : m.slots)
        if (sl.worker)
          return Error{which + ": acts on the tissues, but tissue '" + sl.tissue->name() +
                       "' is stepped on its own thread (physics_rate > 0); a second tissue tool needs every "
                       "tissue stepped on the haptic thread"};
      if (!(t.tissue_tool->radius > 0) || !std::isfinite(t.tissue_tool->radius))
        return Error{which + ": a tool acting on the tissues needs a radius > 0 m"};
    }
    if (t.name.empty()) return Error{"haptic loop: tool " + std::to_string(i + 1) + " needs a name"};
    for (size_t u = 1; u < m.tools.size(); ++u)
      if (m.tools[u]->def.name == t.name) return Error{which + ": two tools have that name"};
    if (!(t.ramp_in >= 0) || !std::isfinite(t.ramp_in)) return Error{which + ": ramp_in must be >= 0 s"};
    auto slot = std::make_unique<Impl::ToolSlot>(t, t.ramp_in);
    slot->col = m.columns.size();
    for (const char* c : {"_x", "_y", "_z", "_qw", "_qx", "_qy", "_qz", "_force_x", "_force_y",
                          "_force_z", "_force_N", "_events", "_passivity_energy", "_passivity_damping"})
      m.columns.push_back(t.name + c);
    start_pose(*slot);
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
    for (size_t i = 1; i < m.tools.size(); ++i) {
      const size_t col = m.tools[i]->col;
      formats[col + Impl::kToolEvents] = ColumnFormat::safety_events;
      for (size_t c = 0; c < Impl::kToolEvents; ++c) ro.keep_columns.push_back(col + c);
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
  // The tick's work: the stage clock's whole span when the stages are timed (no second clock).
  const double spc = StageClock::seconds_per_count();
  for (std::uint64_t i = 0; i < ticks; ++i) {
    if (m.s.time_stages) {
      m.step_h.add(double(m.tick(0)) * spc);
      continue;
    }
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
  const double spc = StageClock::seconds_per_count();
  for (size_t i = 0; i < kTickStageCount; ++i)
    st.stages[i] = {m.stages.h[i].percentile(0.5, spc), m.stages.h[i].percentile(0.99, spc), m.stages.h[i].max(spc)};
  st.safety = m.needle().counters();
  st.passivity = m.needle().passivity_counters();
  st.passivity_energy = m.needle().pc_energy.get();
  st.recorder_dropped = m.recorder ? m.recorder->dropped() : 0;
  st.max_force = m.needle().max_force.get();
  TrainingMetrics& tm = st.metrics;
  tm.outcome = static_cast<Outcome>(m.m_outcome.get());
  tm.skin_punctures = int(m.m_skin_punctures.get()), tm.passes = int(m.m_passes.get());
  tm.redirections = int(m.m_redirections.get()), tm.flashback = m.m_flashback.get() != 0;
  tm.flashback_time = m.m_flashback_time.get(), tm.first_skin_puncture = m.m_first_skin.get();
  tm.time_to_flashback = m.m_time_to_flashback.get(), tm.deepest_depth = m.m_deepest.get();
  tm.arterial_flashback = m.m_arterial.get() != 0, tm.arterial_flashback_time = m.m_arterial_time.get();
  tm.peak_force = st.max_force;
  st.last_force = Vec3(m.needle().fx.get(), m.needle().fy.get(), m.needle().fz.get());
  st.last_position = Vec3(m.needle().px.get(), m.needle().py.get(), m.needle().pz.get());
  st.realtime_priority = m.priority.load();
  st.running = m.running.load();
  for (size_t i = 1; i < m.tools.size(); ++i) {
    const Impl::ToolSlot& x = *m.tools[i];
    LoopToolStats ts;
    ts.name = x.def.name;
    ts.max_force = x.max_force.get();
    ts.max_force_limit = x.def.device->limits().max_force;
    ts.safety = x.counters();
    ts.passivity = x.passivity_counters();
    ts.passivity_enabled = x.def.passivity.enabled;
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
  return i < m.tools.size() ? m.tools[i]->sample.read() : ToolSample{};
}

size_t HapticLoop::tool_count() const noexcept { return impl_->tools.size(); }

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
