// tick.cpp — one haptic tick as a sequence of named, timed stages over one array of tools:
// read devices → step tissues → render forces → watchdog → safety and write → record → live figures
// (as mj_step's pipeline). No allocation, locks, exceptions or I/O: the recorder's ring takes the row.
#include "haptics/loop_impl.h"

#include "haptics/pacing.h"

#include <algorithm>
#include <cmath>

#if defined(__x86_64__)
#include <x86intrin.h>
#endif

namespace palpate {

const char* tick_stage_name(TickStage stage) noexcept {
  switch (stage) {
    case TickStage::read_devices: return "read_devices";
    case TickStage::step_tissues: return "step_tissues";
    case TickStage::render_forces: return "render_forces";
    case TickStage::watchdog: return "watchdog";
    case TickStage::safety_and_write: return "safety_and_write";
    case TickStage::record: return "record";
    case TickStage::live_figures: return "live_figures";
  }
  return "?";
}

std::uint64_t StageClock::now() noexcept {
#if defined(__x86_64__)
  return __rdtsc();
#else
  return static_cast<std::uint64_t>(monotonic_ns());
#endif
}

double StageClock::seconds_per_count() noexcept {
#if defined(__x86_64__)
  static const double spc = [] {
    const std::int64_t n0 = monotonic_ns();
    const std::uint64_t c0 = __rdtsc();
    std::int64_t n1 = n0;
    while (n1 - n0 < 1'000'000) n1 = monotonic_ns();
    const std::uint64_t c1 = __rdtsc();
    return c1 > c0 ? double(n1 - n0) * 1e-9 / double(c1 - c0) : 1e-9;
  }();
  return spc;
#else
  return 1e-9;
#endif
}

// A device's pose this tick. A failed read, a non-finite pose or velocity, or a degenerate
// orientation (no rotation can be read from it) holds the last good pose at rest: the needle
// neither jumps back to the scene's axis inside the tissue nor turns on garbage. That tool's force
// goes to zero this tick (its own fault only).
static void read_pose(HapticLoop::Impl::ToolSlot& x, double t) noexcept {
  const bool ok = x.def.device->read(t, x.state);
  const double qn = x.state.orientation.norm();
  if (!ok || !x.state.position.allFinite() || !x.state.velocity.allFinite() || !std::isfinite(qn) || !(qn > 1e-6)) {
    x.read_fault = TickFault::device_failed;
    x.state.position = x.last_good_position;
    x.state.velocity.setZero();
    x.state.orientation = x.last_good_orientation;
  } else {
    if (qn != 1.0) x.state.orientation.coeffs() /= qn;
    x.read_fault = TickFault::none;
    x.last_good_position = x.state.position;
    x.last_good_orientation = x.state.orientation;
  }
}

// 1. Every device's pose; the tool the tissues see (the HIP, or the proxy with virtual coupling).
void HapticLoop::Impl::read_devices(TickState& ts) noexcept {
  for (auto& x : tools) read_pose(*x, ts.t);
  const ToolSlot& n = needle();
  ts.fault = n.read_fault;
  const bool virtual_coupling = s.coupling == Coupling::virtual_;
  tool.time = ts.t;
  tool.tip = virtual_coupling ? proxy.position : n.state.position;
  tool.velocity = virtual_coupling ? proxy.velocity : n.state.velocity;
  // The needle points along the device's orientation applied to its device-frame axis, for the
  // HIP and the proxy alike. With no rotation it is the scene's axis exactly (no round-off), so
  // a device without orientation gives the same ticks as a fixed axis, bit for bit.
  tool.axis = needle_axis(scene_axis, n.state.orientation);
  tool.grasp = (n.state.buttons & 1u) != 0;
  if (blade_tool) gate_blade(ts);
}

// A blade cuts only on a tick the hand could have made: either end of its edge moving farther than
// blade_max_speed · dt since the last tick (realtime: · the time since it, if longer; a device's glitch, a tracking jump, the proxy restarted
// at the device), a held pose (a failed or NaN read) or a non-finite edge gives the tissues a blade
// that presses but does not cut (ToolState::blade false) this tick; a jump is counted
// (SafetyCounters::blade_teleport, the `blade_teleport` event). The force is not zeroed: the tool
// still presses, and the tissues' force of it is as safe as a probe's.
void HapticLoop::Impl::gate_blade(const TickState& ts) noexcept {
  ToolSlot& n = needle();
  n.loop_events = 0;
  const Vec3 heel = tool.tip - tool.length * tool.axis;
  if (!tool.tip.allFinite() || !heel.allFinite()) {  // cannot happen after read_pose; never cut on it
    tool.blade = false;
    blade_prev_valid = false;
    return;
  }
  // The hand moves for as long as the tick took: a realtime loop that stalled (a loaded machine)
  // finds the blade as far along as the stall let it go, which is not a jump. Headless: one dt.
  const std::int64_t now = ts.deadline_ns ? monotonic_ns() : 0;
  double span = s.dt;
  if (now && blade_prev_ns) span = std::max(span, double(now - blade_prev_ns) * 1e-9);
  blade_prev_ns = now;
  const double reach = s.blade_max_speed * span;
  const bool jumped = blade_prev_valid && !((tool.tip - blade_prev_tip).norm() <= reach &&
                                            (heel - blade_prev_heel).norm() <= reach);
  if (jumped) {
    ++n.blade_teleports;
    n.loop_events |= kEventBladeTeleport;
  }
  tool.blade = !jumped && n.read_fault == TickFault::none;
  blade_prev_tip = tool.tip, blade_prev_heel = heel;
  blade_prev_valid = true;
}

// Where the shaft enters the skin at rest (the outcome's skin tissue): the point of the segment
// handle → tip on the skin's rest surface, when the tip is more than 1 mm under it; else 1 mm
// behind the tip.
static Vec3 shaft_entry(const OutcomeModel& m, const ToolState& tool, double length) noexcept {
  const Vec3 behind = tool.tip - 0.001 * tool.axis;
  if (m.skin < 0 || !(length > 0.001)) return behind;
  const OutcomeTissue& skin = m.tissues[size_t(m.skin)];
  if (!(depth_below(skin, tool.tip) > 0.001) || !(depth_below(skin, tool.tip - length * tool.axis) < 0)) return behind;
  double lo = 0, hi = length;  // depth_below > 0 at lo (the tip), < 0 at hi (the handle)
  for (int k = 0; k < 40; ++k) {
    const double mid = 0.5 * (lo + hi);
    (depth_below(skin, tool.tip - mid * tool.axis) > 0 ? lo : hi) = mid;
  }
  return tool.tip - hi * tool.axis;
}

// 2. Tissues: inline ones step now; multi-rate ones render their linearised contact. They meet the
// tool where it lies in them at rest: a tool that deforms them (the probe pressing the neck,
// ToolForceModel::to_rest, posed by last tick's force) maps the needle there — its tip, and its
// direction as the chord from where its shaft enters the skin to the tip (so a needle that went in
// straight through tissue the probe had already deformed stays on its tracks; one the tissue moves
// against is pushed sideways) — so both tools act on one neck (docs/ultrasound.md). Without one,
// the tool as it is.
void HapticLoop::Impl::step_tissues(TickState& ts) noexcept {
  const std::int64_t now = ts.deadline_ns ? monotonic_ns() : 0;
  seen = tool;
  for (size_t i = 1; i < tools.size(); ++i) {
    const ToolSlot& x = *tools[i];
    if (!x.def.model || x.read_fault != TickFault::none) continue;
    Vec3 tip, entry;
    if (!x.def.model->to_rest(tool.tip, tip) || !x.def.model->to_rest(shaft_entry(s.outcome, tool, tool.length), entry))
      continue;
    const Vec3 along = tip - entry;
    if (tip.allFinite() && along.allFinite() && along.norm() > 1e-9) seen.tip = tip, seen.axis = along.normalized();
    break;  // one tool deforms the tissues
  }
  // The other hand's tool on the tissues (a grasper): posed into each before its step. A failed read
  // holds its last good pose at rest (read_pose) and its grasp as it was.
  ToolSlot* second = nullptr;
  for (size_t i = 1; i < tools.size(); ++i)
    if (tools[i]->def.tissue_tool) second = tools[i].get();
  if (second) {
    const ToolDef& d = *second->def.tissue_tool;
    if (second->read_fault == TickFault::none) second->grasp = (second->state.buttons & 1u) != 0;
    ToolState st;
    st.time = ts.t;
    st.tip = second->state.position;
    st.velocity = second->state.velocity;
    st.axis = needle_axis(d.axis.allFinite() && d.axis.norm() > 0 ? Vec3(d.axis.normalized()) : Vec3(0, -1, 0),
                          second->state.orientation);
    st.radius = d.radius;
    st.grasp = second->grasp;
    for (Slot& sl : slots) sl.tissue->set_second_tool(st);
  }
  Vec3 f_rendered = Vec3::Zero();
  for (Slot& sl : slots) {
    std::span<double> figs(row.data() + sl.figure_offset, sl.figure_count);
    if (sl.worker) {
      Vec3 f;
      const TickFault tf = sl.worker->render(seen, now, headless_now ? 0.0 : s.watchdog.stall_timeout, f, figs);
      if (tf != TickFault::none && ts.fault == TickFault::none) ts.fault = tf;
      f_rendered += f;
      ts.j_rendered += sl.worker->jacobian();
    } else {
      ts.f_inline += sl.tissue->step(seen, s.dt);
      // A step that reset its tissue returns an ordinary zero: count it and restart the ramp.
      if (sl.tissue->last_step_failed() && ts.fault == TickFault::none) ts.fault = TickFault::step_failed;
      sl.tissue->figures(figs);
      if (second) ts.f_second += sl.tissue->second_tool_force();
    }
  }
  ts.f_tissue = ts.f_inline + f_rendered;
}

// 3. Each tool's force: tool 0 the HIP's (or the proxy's coupling force), the others their own law.
void HapticLoop::Impl::render_forces(TickState& ts) noexcept {
  ToolSlot& n = needle();
  n.request = ts.f_tissue;
  if (s.coupling == Coupling::virtual_) {
    if (ts.f_tissue.allFinite()) {
      proxy_estimator.update(tool.tip, ts.f_inline);
      n.request = step_proxy(coupling, proxy, n.state.position, n.state.velocity, ts.f_tissue,
                             proxy_estimator.jacobian() + ts.j_rendered, s.dt);
    }
    if (!ts.f_tissue.allFinite() || !proxy.position.allFinite() || ts.fault != TickFault::none) {
      proxy.position = n.state.position;  // start again at the device, at rest
      proxy.velocity.setZero();
      proxy_estimator.reset();
    }
  }
  for (size_t i = 1; i < tools.size(); ++i) {
    ToolSlot& x = *tools[i];
    if (x.read_fault != TickFault::none) x.request = Vec3::Zero();
    else if (x.def.tissue_tool) x.request = ts.f_second;
    else x.request = x.def.model->force(x.state.position, x.state.orientation, ts.t);
  }
}

// 4. Watchdog: work past its deadline by more than the margin sends zero.
void HapticLoop::Impl::watchdog(TickState& ts) noexcept {
  if (ts.deadline_ns && ts.fault == TickFault::none &&
      double(monotonic_ns() - ts.deadline_ns) * 1e-9 > s.watchdog.overrun_margin)
    ts.fault = TickFault::overrun;
}

// 5. Each tool's force through its own safety filter (finite, clamped, rate-limited, ramped in,
// zero on a fault), then to its device. An overrun (the tick as a whole ran late) zeroes every
// tool; tool 0's other faults (a failed step, a stalled physics thread, its device) only tool 0.
//
// Before its filter, each tool's passivity controller observes the work the hand did since the last
// tick and adds the damping that keeps that energy (its E) from going below zero; what leaves the
// filter is what it holds until the next tick (safety.h, PassivityController).
void HapticLoop::Impl::safety_and_write(TickState& ts) noexcept {
  ToolSlot& n = needle();
  const Vec3 f0 = n.passivity.control(n.request, n.state.position, n.state.velocity, s.dt);
  n.sent = n.safety.filter(f0, s.dt, ts.fault);
  n.passivity.sent(n.sent, s.dt);
  n.def.device->write(n.sent, Vec3::Zero());
  for (size_t i = 1; i < tools.size(); ++i) {
    ToolSlot& x = *tools[i];
    TickFault f = x.read_fault;
    if (f == TickFault::none && ts.fault == TickFault::overrun) f = TickFault::overrun;
    const Vec3 fx = x.passivity.control(f == TickFault::none ? x.request : Vec3(Vec3::Zero()), x.state.position,
                                        x.state.velocity, s.dt);
    x.sent = x.safety.filter(fx, s.dt, f);
    x.passivity.sent(x.sent, s.dt);
    x.def.device->write(x.sent, Vec3::Zero());
  }
}

// 6. The tick's row to the recorder, the tissues' events, the outcome after them.
void HapticLoop::Impl::record(TickState& ts) noexcept {
  const ToolSlot& n = needle();
  const DeviceState& st = n.state;
  double* r = row.data();
  r[kT] = ts.t;
  r[kToolX] = st.position.x(), r[kToolY] = st.position.y(), r[kToolZ] = st.position.z();
  r[kForceX] = n.sent.x(), r[kForceY] = n.sent.y(), r[kForceZ] = n.sent.z();
  ts.force_norm = n.sent.norm();
  r[kForceN] = ts.force_norm;
  r[kTick] = double(k);
  r[kQw] = st.orientation.w(), r[kQx] = st.orientation.x();
  r[kQy] = st.orientation.y(), r[kQz] = st.orientation.z();
  r[kButtons] = double(st.buttons);
  r[kEvents] = double(n.safety.last_events() | n.loop_events);
  r[kPassivityEnergy] = n.passivity.energy(), r[kPassivityDamping] = n.passivity.damping();
  if (proxy_col) {
    r[proxy_col] = proxy.position.x(), r[proxy_col + 1] = proxy.position.y();
    r[proxy_col + 2] = proxy.position.z();
  }
  for (size_t i = 1; i < tools.size(); ++i) {
    const ToolSlot& x = *tools[i];
    double* c = row.data() + x.col;
    c[0] = x.state.position.x(), c[1] = x.state.position.y(), c[2] = x.state.position.z();
    c[3] = x.state.orientation.w(), c[4] = x.state.orientation.x();
    c[5] = x.state.orientation.y(), c[6] = x.state.orientation.z();
    c[7] = x.sent.x(), c[8] = x.sent.y(), c[9] = x.sent.z();
    c[10] = x.sent.norm();
    c[11] = double(x.safety.last_events());
    c[12] = x.passivity.energy(), c[13] = x.passivity.damping();
  }
  if (recorder) {
    if (headless_now)
      recorder->push_wait(row);
    else
      recorder->push(row);
  }
  for (size_t i = 0; i < slots.size(); ++i) {
    size_t n_ev = 0;
    while ((n_ev = slots[i].worker ? slots[i].worker->drain_events(event_buf) : slots[i].tissue->drain_events(event_buf)) > 0)
      for (size_t e = 0; e < n_ev; ++e) {
        const TissueEvent& ev = event_buf[e];
        // A tissue on its own thread stamps an event with its own clock, the end of the step that
        // made it (at 100 Hz up to 10 ms past this tick): it happened by this tick, which reports
        // it, and no later — so the flashback it causes is never logged before it.
        const double when = slots[i].worker ? std::min(ev.time, ts.t) : ev.time;
        outcome_event(s.outcome, outcome, ev.kind, int(i), when, seen.tip, seen.axis);
        if (recorder) (void)recorder->push_event({when, ev.kind, int(i), ev.depth, ev.force});
      }
  }
  // The outcome after this tick's events: where the tip is now (as the tissues saw it).
  const bool flashback = outcome_tick(s.outcome, outcome, ts.t, seen.tip, seen.axis, ts.force_norm);
  if (recorder && outcome.redirected)  // a new pass under the skin (docs/cvc.md, "Outcome and metrics")
    (void)recorder->push_event({ts.t, "redirect", s.outcome.skin, 0.0, ts.force_norm});
  if (recorder && outcome.left_model)  // into the body beyond the skin's edges: not scored
    (void)recorder->push_event({ts.t, "outside_model", s.outcome.skin, outcome.outside_depth, ts.force_norm});
  if (flashback && recorder)
    (void)recorder->push_event({ts.t, "flashback", outcome.flashback_tissue, outcome.flashback_depth,
                                outcome.flashback_force});
  if (outcome.arterial_now && recorder)  // pulsatile, bright red: the carotid (docs/cvc.md)
    (void)recorder->push_event({ts.t, "arterial_flashback", outcome.arterial_tissue, outcome.arterial_depth,
                                outcome.arterial_force});
}

// 7. Live figures for other threads: counts, forces, safety counters, metrics, each tool's sample.
void HapticLoop::Impl::live_figures(TickState& ts) noexcept {
  ++k;
  ticks.set(k);
  for (size_t i = 0; i < tools.size(); ++i) {
    ToolSlot& x = *tools[i];
    const double fn = i == 0 ? ts.force_norm : x.sent.norm();
    if (fn > x.max_force.get()) x.max_force.set(fn);
    x.fx.set(x.sent.x()), x.fy.set(x.sent.y()), x.fz.set(x.sent.z());
    x.px.set(x.state.position.x()), x.py.set(x.state.position.y()), x.pz.set(x.state.position.z());
    x.publish_counters();
    ToolSample smp;
    smp.time = ts.t, smp.tick = k;
    smp.position = i == 0 ? tool.tip : x.state.position;
    smp.orientation = x.state.orientation;
    if (i == 0) smp.axis = tool.axis;
    smp.force = x.sent;
    smp.buttons = x.def.tissue_tool ? (x.grasp ? 1u : 0u) : x.state.buttons;
    x.sample.publish(smp);
  }
  publish_metrics();
}

std::uint64_t HapticLoop::Impl::tick(std::int64_t deadline_ns) noexcept {
  TickState ts;
  ts.t = double(k + 1) * s.dt;
  ts.deadline_ns = deadline_ns;
  if (!s.time_stages) {
    read_devices(ts), step_tissues(ts), render_forces(ts), watchdog(ts);
    safety_and_write(ts), record(ts), live_figures(ts);
    return 0;
  }
  const std::uint64_t first = StageClock::now();
  std::uint64_t last = first;
  auto done = [&](TickStage stage) {
    const std::uint64_t now = StageClock::now();
    stages.h[size_t(stage)].add(now - last);
    last = now;
  };
  read_devices(ts), done(TickStage::read_devices);
  step_tissues(ts), done(TickStage::step_tissues);
  render_forces(ts), done(TickStage::render_forces);
  watchdog(ts), done(TickStage::watchdog);
  safety_and_write(ts), done(TickStage::safety_and_write);
  record(ts), done(TickStage::record);
  live_figures(ts), done(TickStage::live_figures);
  return last - first;
}

}  // namespace palpate
