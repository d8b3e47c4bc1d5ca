// run.cpp — run_scene: a headless run at a fixed tick, and its CSV and summary.json outputs.
#include <palpate/device.h>
#include <palpate/haptics.h>
#include <palpate/run.h>
#include <palpate/render.h>
#include <palpate/safety.h>
#include <palpate/simulation.h>
#include <palpate/snapshot_tissue.h>
#include <palpate/tissue.h>
#include <palpate/ultrasound.h>

#include "simulation/export_run.h"
#include "simulation/plots.h"
#include "simulation/run_support.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <optional>
#include <system_error>
#include <thread>
#include <sys/statvfs.h>
#include <unistd.h>

namespace palpate {

using namespace run_support;



// A passivity controller's work for summary.json (safety.h, PassivityController).
static nlohmann::json passivity_json(const PassivityCounters& p, bool enabled) {
  return {{"enabled", enabled},
          {"active_ticks", p.active_ticks},
          {"capped_ticks", p.capped_ticks},
          {"dissipated_J", p.dissipated},
          {"min_energy_J", p.min_energy},
          {"max_damping_Ns_per_m", p.max_damping}};
}

Result<RunSummary> run_scene(const SceneDef& scene, const RunOptions& options) {
  auto sim = Simulation::build(scene, run_simulation_options(scene, options));
  if (!sim) return sim.error();
  return run_simulation(**sim, options);
}

Result<RunSummary> run_scene(const SceneDef& scene, std::vector<std::unique_ptr<Tissue>> tissues,
                             const RunOptions& options) {
  auto sim = Simulation::build(scene, std::move(tissues), run_simulation_options(scene, options));
  if (!sim) return sim.error();
  return run_simulation(**sim, options);
}

SimulationOptions run_simulation_options(const SceneDef& scene, const RunOptions& options) {
  SimulationOptions so;
  so.realtime = options.realtime;
  so.realtime_priority = options.realtime_priority;
  so.physics_dt = options.physics_dt;
  so.cache = options.cache;
  // Frames: each tissue hands its drawn state over through a SnapshotTissue (allocation-free on the
  // stepping thread). Ultrasound images show the vein's wall tented where the needle pushes it: the
  // scene's `vein` tissue hands its particles over the same way.
  bool vein = scene.anatomy.has_value();  // the neck's ijv
  for (const TissueDef& t : scene.tissues) vein = vein || t.role == "vein";
  so.snapshots = options.frames > 0 || !options.frame_times.empty() || !options.exports.empty() ||
                 ((options.ultrasound > 0 || !options.ultrasound_times.empty()) && vein);
  return so;
}


Result<RunSummary> run_simulation(Simulation& sim, const RunOptions& options) {
  namespace fs = std::filesystem;
  const SceneDef& scene = sim.scene();
  const std::string where = scene.file.empty() ? std::string("scene") : scene.file.string();
  const double dt = scene.dt;
  const std::uint64_t ticks = sim.duration_ticks();
  const fs::path out = options.out.empty() ? scene.output : options.out;
  auto frame_ticks = image_ticks(options.frames, options.frame_times, ticks, dt, where, "frames", "frame_times");
  if (!frame_ticks) return frame_ticks.error();
  auto us_ticks = image_ticks(options.ultrasound, options.ultrasound_times, ticks, dt, where, "ultrasound images",
                              "ultrasound_times");
  if (!us_ticks) return us_ticks.error();
  // Frames are drawn off-screen, at most kMaxOffscreenSide a side: say so before the run, naming
  // the scene's key (the loader allows larger cameras, for the viewer's window).
  if (!frame_ticks->empty() && scene.camera)
    for (const auto& [key, side] : {std::pair{"camera.width", scene.camera->width}, std::pair{"camera.height", scene.camera->height}})
      if (side > kMaxOffscreenSide)
        return Error{where + ": " + key + ": " + std::to_string(side) + " pixels is more than frames can be drawn "
                     "off-screen (at most " + std::to_string(kMaxOffscreenSide) + "); lower it to run with --frames"};
  if (!us_ticks->empty() && !scene.probe)
    return Error{where + ": ultrasound images need a 'probe' section in the scene (the probe's device, "
                 "footprint and imaging; docs/scene-format.md), and this scene has none"};
  const size_t nframes = frame_ticks->size();
  const size_t nus = us_ticks->size();
  if (nframes > 0 && !sim.options().snapshots)
    return Error{where + ": frames need a simulation built with snapshots (run_simulation_options)"};
  // Exports: t = 0 (before the first tick), then the tick nearest every export_every s, and the end.
  const bool exporting = !options.exports.empty();
  std::vector<std::uint64_t> export_ticks;
  if (exporting) {
    if (!sim.options().snapshots)
      return Error{where + ": exports need a simulation built with snapshots (run_simulation_options)"};
    if (!std::isfinite(options.export_every) || !(options.export_every > 0))
      return Error{where + ": export_every: " + fmt::format("{}", options.export_every) + " s, expected a time > 0"};
    for (std::uint64_t k = 1;; ++k) {
      const auto tick = static_cast<std::uint64_t>(std::llround(double(k) * options.export_every / dt));
      if (tick > ticks) break;
      if (tick >= 1 && (export_ticks.empty() || tick > export_ticks.back())) export_ticks.push_back(tick);
      if (k > ticks) break;
    }
    if (ticks > 0 && (export_ticks.empty() || export_ticks.back() != ticks)) export_ticks.push_back(ticks);
  }
  // What is taken after which tick: frames and exports, merged (a tick may have both).
  struct Capture {
    std::uint64_t tick = 0;
    long frame = -1;     // the frame's number, or −1
    bool exp = false;    // an export
    bool pose = false;   // the tools' first pose (the exports' t = 0 state has none of its own)
  };
  std::vector<Capture> captures;
  if (exporting && ticks > 0) {
    captures.push_back({1, -1, false, true});
    if (!export_ticks.empty() && export_ticks.front() == 1) captures.back().exp = true, export_ticks.erase(export_ticks.begin());
    if (nframes > 0 && (*frame_ticks)[0] == 1) captures.back().frame = 0;
  }
  for (size_t a = captures.empty() || captures[0].frame < 0 ? 0 : 1, b = 0; a < nframes || b < export_ticks.size();) {
    const std::uint64_t ta = a < nframes ? (*frame_ticks)[a] : UINT64_MAX;
    const std::uint64_t tb = b < export_ticks.size() ? export_ticks[b] : UINT64_MAX;
    Capture c;
    c.tick = std::min(ta, tb);
    if (ta == c.tick) c.frame = long(a++);
    if (tb == c.tick) c.exp = true, ++b;
    captures.push_back(c);
  }
  const size_t ncap = captures.size();
  const size_t ntissues = sim.tissue_count();
  std::vector<SnapshotTissue*> snaps;
  if (sim.options().snapshots)
    for (size_t i = 0; i < ntissues; ++i) snaps.push_back(sim.snapshot(i));
  const SimulationTool* probe_tool = sim.tool(ToolRole::ultrasound_probe);
  const SimulationTool* grasper_tool = sim.tool(ToolRole::grasper);
  // The vein (the scene's first `vein` tissue) for the ultrasound images.
  const int vein = nus > 0 && ntissues == scene.tissues.size() && sim.options().snapshots ? sim.tissue_with_role("vein") : -1;

  // Capture k (a frame, an export or both) is taken after frame_target(k) ticks.
  auto frame_target = [&](size_t k) { return captures[k].tick; };
  const int digits = nframes > 1000 ? int(std::to_string(nframes - 1).size()) : 3;
  std::vector<RunFrame> frames;
  std::string frame_error;
  HapticLoop* loop_ptr = nullptr;  // set once the loop is built: the frames draw the probe's pose
  std::vector<TissueSnapshot> frame_snaps(snaps.size());
  std::unique_ptr<RunExporter> exporter;
  std::string export_error;
  // Capture k from the newest copies: its frame drawn, its export saved; `direct`: nothing steps
  // the tissues now (headless, or the realtime loop has ended), so a tissue that has not published
  // since the request (a multi-rate one, or every tissue once the loop stopped) is copied now,
  // stamped with its last step.
  auto take_frame = [&](size_t c, bool direct) {
    SnapshotStamp tool;
    Vec3 force = Vec3::Zero();
    for (size_t i = 0; i < snaps.size(); ++i) {
      bool fresh = false;
      frame_snaps[i] = snaps[i]->latest(&fresh);
      if (!fresh && direct) {
        snaps[i]->publish_last_step();
        frame_snaps[i] = snaps[i]->latest();
      }
      const SnapshotStamp& st = snaps[i]->current_stamp();
      force += st.force;
      if (st.stepped && (!tool.stepped || st.time > tool.time)) tool = st;
    }
    if ((captures[c].exp || captures[c].pose) && exporter && export_error.empty()) {
      std::vector<ExportToolSample> ts;
      for (const SimulationTool& t : sim.tools()) {
        const ToolSample s = loop_ptr->tool_sample(t.loop_index);
        ts.push_back({s.valid, s.position, s.orientation, s.axis, s.force});
        // Realtime: the loop may have ticked on since the tissues' copy; the tool the tissues saw
        // then is the copy's own (its tip, axis, and their force on it, before the safety filter).
        if (t.loop_index == 0 && tool.stepped && std::abs(s.time - tool.time) > 0.5 * dt) {
          ts.back().valid = true;
          ts.back().position = tool.tip;
          ts.back().axis = tool.axis;
          ts.back().force = force;
        }
      }
      if (captures[c].pose)
        if (Status s = exporter->first_pose(ts); !s) export_error = s.error().message;
      // The time of the tissues' copy (the tick it was taken after); the tools' newest tick when
      // none stepped (headless: the same tick).
      const ToolSample s0 = loop_ptr->tool_sample(0);
      const double when = tool.stepped ? tool.time : s0.time;
      if (captures[c].exp && export_error.empty())
        if (Status s = exporter->add(when, frame_snaps, ts); !s) export_error = s.error().message;
    }
    if (captures[c].frame < 0 || !frame_error.empty()) return;
    const size_t k = size_t(captures[c].frame);
    const fs::path file = out / fmt::format("frame_{:0{}}.png", k, digits);
    const std::optional<Vec3> axis = tool.stepped ? std::optional<Vec3>(tool.axis) : std::nullopt;
    std::optional<FrameProbe> probe;
    if (scene.probe && probe_tool && loop_ptr) {
      const ToolSample ps = loop_ptr->tool_sample(probe_tool->loop_index);
      probe = FrameProbe{*scene.probe, ps.position, ps.orientation};
    }
    std::vector<FrameSphere> spheres;  // the grasper in the other hand
    if (scene.grasper && grasper_tool && loop_ptr) {
      const ToolSample gs = loop_ptr->tool_sample(grasper_tool->loop_index);
      spheres.push_back({gs.position, scene.grasper->radius, (gs.buttons & 1u) != 0});
    }
    if (Status s = render_frame_png(scene, frame_snaps, tool.tip, force, file, options.frame_options, axis,
                                    probe ? &*probe : nullptr, spheres);
        !s)
      frame_error = s.error().message;
    else
      frames.push_back({tool.time, file});
  };

  // What the run will write and hold, checked before the first tick: a run that cannot fit in
  // memory or on the disk is refused here, not hours in.
  {
    size_t columns = 15;
    for (size_t i = 0; i < ntissues; ++i) columns += sim.tissue(i).figure_names().size();
    const RunFootprint fp = run_footprint(ticks, columns);
    const std::string what = fmt::format("duration {} s at dt {} s is {} ticks", scene.duration, dt, ticks);
    const double disk = free_bytes(out);
    if (disk >= 0 && fp.csv_bytes + fp.series_bytes > disk)
      return Error{where + ": duration: " + what + ": run.csv would be about " + gigabytes(fp.csv_bytes) +
                   " and the plots' series beside it " + gigabytes(fp.series_bytes) + ", more than the " +
                   gigabytes(disk) + " free at " + out.string() +
                   "; shorten duration, raise dt or choose another output directory"};
  }
  if (Status s = clear_run_outputs(out); !s) return s.error();
  if (exporting) {
    // The rest state (the copies made when the tissues were wrapped), saved as t = 0 below.
    for (size_t i = 0; i < snaps.size(); ++i) frame_snaps[i] = snaps[i]->latest();
    auto e = RunExporter::open(sim, options.exports, out, options.frame_options.resolution, frame_snaps);
    if (!e) return Error{where + ": " + e.error().message};
    exporter = std::move(*e);
  }

  auto built = sim.open_loop(out / "run.csv");
  if (!built) return built.error();
  HapticLoop& loop = **built;
  loop_ptr = &loop;
  if (exporter) {  // t = 0: the rest state, before the first tick (no tool pose yet)
    std::vector<ExportToolSample> ts(sim.tools().size());
    if (Status s = exporter->add(0.0, frame_snaps, ts); !s) export_error = s.error().message;
  }
  const Device& dev = *sim.tools().front().device;

  // Ultrasound images: image k after us_target(k) ticks, from the newest tick's probe and needle
  // (the loop's tool samples; in a headless run exactly that tick), on this thread.
  auto us_target = [&](size_t k) { return (*us_ticks)[k]; };
  SnapshotTissue* vein_snap = vein >= 0 ? snaps[size_t(vein)] : nullptr;
  std::vector<Vec3f> vein_rest;  // the vein's particles before the first step
  if (vein_snap) vein_rest = vein_snap->latest().points;
  std::unique_ptr<UltrasoundImager> imager;
  if (nus > 0) imager = std::make_unique<UltrasoundImager>(*scene.anatomy, *scene.probe);
  UltrasoundImage us_image;
  std::vector<RunFrame> us_frames;
  std::string us_error;
  const int us_digits = nus > 1000 ? int(std::to_string(nus - 1).size()) : 3;
  // `swap`: take the vein's newest hand-over (false while a frame waits for its own, realtime:
  // the image then reads the one the frames have); `direct`: nothing steps now, copy it if stale.
  auto take_ultrasound = [&](size_t k, bool swap, bool direct) {
    if (!us_error.empty()) return;
    if (vein_snap) {
      bool fresh = false;
      if (swap) vein_snap->latest(&fresh);
      if (swap && direct && !fresh) {
        vein_snap->publish_last_step();
        vein_snap->latest();
      }
      imager->set_vein_wall(vein_rest, vein_snap->current().points);
    }
    const ToolSample needle = loop.tool_sample(0), probe = loop.tool_sample(probe_tool->loop_index);
    NeedlePose np;
    np.present = scene.tool.kind == "needle" && needle.valid;
    np.tip = needle.position;
    np.axis = needle.axis;
    np.radius = scene.tool.radius;
    np.length = scene.tool.length;
    imager->render({probe.position, probe.orientation}, np, probe.time, us_image);
    const fs::path file = out / fmt::format("us_{:0{}}.png", k, us_digits);
    if (Status s = write_ultrasound_png(us_image, file); !s)
      us_error = s.error().message;
    else
      us_frames.push_back({probe.time, file});
  };
  size_t next_us = 0;

  // --- the run: the loop's own thread paced by the wall clock, or ticks as fast as they go here.
  size_t next_frame = 0;
  auto interrupted = [&] { return options.interrupt && options.interrupt->load(std::memory_order_relaxed); };
  if (options.realtime) {
    // This thread reports progress and draws the frames; the haptic thread never waits for it.
    // A frame is requested a few ticks ahead of its target (the request is served by the next
    // step), and the run's last frame, if the loop ended first, is read after it stopped.
    // Mesa's software rasteriser (llvmpipe, behind OSMesa) starts one worker thread per core;
    // beside a realtime haptic thread on a small machine they take its core and push the
    // period's p99 from 1.09 to 2.6 ms (docs/benchmarks/haptics.md). Frames drawn beside the loop
    // are rasterised on this thread alone, unless the user set LP_NUM_THREADS.
    if (ncap > 0) ::setenv("LP_NUM_THREADS", "0", /*overwrite=*/0);
    if (Status s = loop.start(); !s) return s.error();
    bool requested = false, us_requested = false;
    double requested_at = 0;  // s, the last tick done when the frame's copies were requested
    std::vector<char> got(snaps.size(), 0);
    auto last_progress = std::chrono::steady_clock::now();
    for (LoopStats st = loop.stats(); st.running; st = loop.stats()) {
      if (interrupted()) {
        loop.stop();  // at a tick boundary; the loop ramps the force to zero before it returns
        break;
      }
      const auto now = std::chrono::steady_clock::now();
      if (options.progress && now - last_progress > std::chrono::milliseconds(50)) {
        options.progress(double(st.ticks) / double(std::max<std::uint64_t>(1, ticks)));
        last_progress = now;
      }
      if (vein_snap && next_us < nus && !us_requested && st.ticks + 3 >= us_target(next_us)) {
        vein_snap->request();  // served by the next step
        us_requested = true;
      }
      if (next_us < nus && st.ticks >= us_target(next_us)) {
        take_ultrasound(next_us++, !requested, false);
        us_requested = false;
        continue;
      }
      if (next_frame < ncap && !requested && st.ticks + 3 >= frame_target(next_frame)) {
        for (SnapshotTissue* t : snaps) t->request();
        std::fill(got.begin(), got.end(), 0);
        requested = true;
        requested_at = double(st.ticks) * dt;
      }
      if (requested) {
        // A copy answers the request only if it shows a tool read after it: one published
        // earlier and not read yet (the first tick's, made for no request, then the request
        // answered by the next tick) or one from a physics step that began before the request
        // would show the frame seconds early. Such a copy is passed over and asked for again.
        bool all = true;
        for (size_t i = 0; i < snaps.size(); ++i) {
          bool fresh = false;
          if (!got[i]) snaps[i]->latest(&fresh);
          if (fresh && snaps[i]->current_stamp().time >= requested_at - 0.5 * dt)
            got[i] = 1;
          else if (fresh)
            snaps[i]->request();
          all = all && got[i];
        }
        if (all) {
          take_frame(next_frame++, false);
          requested = false;
          continue;
        }
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(next_frame < ncap || next_us < nus ? 1 : 50));
    }
    loop.wait();
    if (loop.stats().ticks == ticks) {  // an interrupted run has no images past its end
      for (; next_frame < ncap; ++next_frame) take_frame(next_frame, true);
      for (; next_us < nus; ++next_us) take_ultrasound(next_us, true, true);
    }
    if (options.progress) options.progress(1.0);
  } else {
    // Ticks in runs of at most 100, looking at the interrupt between them; false when it came.
    auto run_ticks = [&](std::uint64_t n) {
      for (std::uint64_t i = 0; i < n; i += 100) {
        if (interrupted()) return false;
        loop.run_headless(std::min<std::uint64_t>(100, n - i));
      }
      return true;
    };
    const std::uint64_t chunk = std::max<std::uint64_t>(1, ticks / 100);
    for (std::uint64_t done = 0; done < ticks;) {
      std::uint64_t n = std::min(chunk, ticks - done);
      if (next_frame < ncap) n = std::min(n, frame_target(next_frame) - done);
      if (next_us < nus) n = std::min(n, us_target(next_us) - done);
      const bool frame_now = next_frame < ncap && done + n == frame_target(next_frame);
      const bool us_now = vein_snap && next_us < nus && done + n == us_target(next_us);
      if (frame_now || us_now) {
        // The last tick before an image copies what the image needs (every tissue for a frame).
        if (n > 1 && !run_ticks(n - 1)) break;
        if (interrupted()) break;
        if (frame_now)
          for (SnapshotTissue* t : snaps) t->request();
        else
          vein_snap->request();
        loop.run_headless(1);
        if (frame_now) take_frame(next_frame++, true);
      } else if (!run_ticks(n)) {
        break;
      }
      done += n;
      while (next_us < nus && us_target(next_us) == done) take_ultrasound(next_us++, true, true);
      if (options.progress) options.progress(double(done) / double(ticks));
    }
  }
  if (Status s = loop.finish_recording(); !s) return s.error();
  const LoopStats st = loop.stats();

  // --- outputs.
  RunSummary summary;
  summary.ticks = st.ticks;
  summary.interrupted = st.ticks < ticks;
  summary.dt = dt;
  summary.step_median = st.step.median;
  summary.step_p99 = st.step.p99;
  summary.step_max = st.step.max;
  summary.stages = st.stages;
  summary.max_force = st.max_force;
  summary.realtime = options.realtime;
  summary.period = st.period;
  summary.deadline_misses = st.deadline_misses;
  summary.safety = st.safety;
  summary.passivity = st.passivity;
  summary.recorder_dropped = st.recorder_dropped;
  summary.metrics = st.metrics;
  for (const HapticLoop::Event& e : loop.events())
    summary.events.push_back({e.time, e.kind,
                              e.tissue >= 0 && size_t(e.tissue) < ntissues ? sim.tissue(size_t(e.tissue)).name() : "",
                              e.depth, e.force});
  summary.csv = out / "run.csv";
  summary.summary_json = out / "summary.json";

  const SafetyCounters& sc = st.safety;
  nlohmann::json j;
  j["scene"] = scene.name;
  j["scene_file"] = scene.file.string();
  j["palpate_version"] = version();
  j["ticks"] = st.ticks;
  j["interrupted"] = summary.interrupted;  // true: stopped early (a signal); outputs up to the last tick
  j["dt_s"] = dt;
  j["duration_s"] = double(st.ticks) * dt;
  j["realtime"] = options.realtime;
  j["coupling"] = scene.device.coupling;
  j["step_time_s"] = {{"median", summary.step_median}, {"p99", summary.step_p99},
                      {"max", summary.step_max}};
  // Where the tick's time goes: each stage's median, p99 and max (docs/architecture.md).
  j["tick_stages_s"] = nlohmann::json::object();
  for (size_t i = 0; i < kTickStageCount; ++i)
    j["tick_stages_s"][tick_stage_name(TickStage(i))] = {
        {"median", st.stages[i].median}, {"p99", st.stages[i].p99}, {"max", st.stages[i].max}};
  if (options.realtime) {
    j["period_s"] = {{"median", st.period.median}, {"p99", st.period.p99}, {"max", st.period.max}};
    j["deadline_misses"] = st.deadline_misses;
    j["resyncs"] = st.resyncs;
    j["realtime_priority"] = st.realtime_priority;
  }
  j["max_force_N"] = st.max_force;
  // The outcome and the trainee's metrics (docs/cvc.md, "Outcome and metrics"); null = did not happen.
  const TrainingMetrics& tm = summary.metrics;
  auto time_or_null = [](bool happened, double t) { return happened ? nlohmann::json(t) : nlohmann::json(nullptr); };
  j["outcome"] = outcome_name(tm.outcome);
  j["metrics"] = {{"skin_punctures", tm.skin_punctures},
                  {"passes", tm.passes},
                  {"redirections", tm.redirections},
                  {"first_skin_puncture_s", time_or_null(tm.first_skin_puncture >= 0, tm.first_skin_puncture)},
                  {"flashback_s", time_or_null(tm.flashback, tm.flashback_time)},
                  {"time_to_flashback_s", time_or_null(tm.flashback, tm.time_to_flashback)},
                  {"arterial_flashback_s", time_or_null(tm.arterial_flashback, tm.arterial_flashback_time)},
                  {"deepest_depth_m", tm.deepest_depth},
                  {"peak_force_N", tm.peak_force}};
  j["safety"] = {{"non_finite", sc.non_finite}, {"step_failed", sc.step_failed},
                 {"clamped", sc.clamped}, {"rate_limited", sc.rate_limited},
                 {"overrun", sc.overrun}, {"stalled", sc.stalled},
                 {"device_failed", sc.device_failed}, {"blade_teleport", sc.blade_teleport},
                 {"max_force_N", dev.limits().max_force},
                 {"passivity", passivity_json(st.passivity, scene.device.passivity)}};
  // The probe (the other hand's tool): its largest force and its own safety filter's counters.
  summary.tools = st.tools;
  for (const LoopToolStats& t : st.tools) {
    const SafetyCounters& c = t.safety;
    j[t.name] = {{"max_force_N", t.max_force},
                 {"safety", {{"non_finite", c.non_finite}, {"step_failed", c.step_failed},
                             {"clamped", c.clamped}, {"rate_limited", c.rate_limited},
                             {"overrun", c.overrun}, {"stalled", c.stalled},
                             {"device_failed", c.device_failed}, {"max_force_N", t.max_force_limit},
                             {"passivity", passivity_json(t.passivity, t.passivity_enabled)}}}};
  }
  j["recorder_dropped"] = st.recorder_dropped;
  j["tissues"] = nlohmann::json::array();
  for (size_t i = 0; i < ntissues; ++i) {
    j["tissues"].push_back(sim.tissue(i).name());
    summary.tissue_names.push_back(sim.tissue(i).name());
  }
  // The tissues stepped on their own thread (multi-rate): did the physics keep its rate, and how
  // many haptic ticks were rendered from the compliant contact patch.
  summary.physics = st.physics;
  j["physics"] = nlohmann::json::array();
  for (const LoopPhysicsStats& p : st.physics)
    j["physics"].push_back({{"tissue", p.tissue >= 0 && size_t(p.tissue) < ntissues ? sim.tissue(size_t(p.tissue)).name() : ""},
                            {"rate_hz", p.period > 0 ? 1.0 / p.period : 0.0},
                            {"steps", p.steps},
                            {"step_time_s", {{"median", p.step.median}, {"p99", p.step.p99}, {"max", p.step.max}}},
                            {"late_steps", p.late},
                            {"patch_ticks", p.patch_ticks},
                            {"patch_fallbacks", p.patch_fallbacks}});
  j["events"] = nlohmann::json::array();
  for (const RunEvent& e : summary.events)
    j["events"].push_back({{"time_s", e.time}, {"kind", e.kind}, {"tissue", e.tissue},
                           {"depth_m", e.depth}, {"force_N", e.force}});
  // Plots of force against time and depth (a tool is always present in a scene), from the series
  // streamed back from the recorder's file in two passes (first contact, then every tick), so a run
  // of any length holds at most PlotSeriesBuilder::kMaxRows rows in memory.
  const std::uint64_t n = loop.series_rows();  // t, tool_x..z, force_x..z, force_N, tool_qw..qz
  summary.series_columns = loop.series_columns();
  if (options.series_row && n > 0)
    if (Status s = loop.for_each_series_row(options.series_row); !s) return s.error();
  if (options.plots && n > 0) {
    std::uint64_t k = 0, contact = n;
    Vec3 tip0 = Vec3::Zero(), first = Vec3::Zero();
    Status pass = loop.for_each_series_row([&](std::span<const double> r) {
      if (k == 0) first = Vec3(r[1], r[2], r[3]);
      if (contact == n && r[7] > 1e-9) contact = k, tip0 = Vec3(r[1], r[2], r[3]);
      ++k;
    });
    if (contact == n) tip0 = first;
    PlotSeriesBuilder builder(n);
    const Vec3 tool_axis = scene.tool.axis.normalized();
    // The probe's |F| (the other hand), when the scene has one.
    const auto pcol = std::find(summary.series_columns.begin(), summary.series_columns.end(), "probe_force_N");
    const size_t probe_col = pcol == summary.series_columns.end() ? 0 : size_t(pcol - summary.series_columns.begin());
    if (pass)
      pass = loop.for_each_series_row([&](std::span<const double> r) {
        // Depth and axial force along the needle as it pointed at that tick (the loop's own axis).
        const Vec3 axis = needle_axis(tool_axis, Quat(r[8], r[9], r[10], r[11]).normalized());
        builder.add(r[0], (Vec3(r[1], r[2], r[3]) - tip0).dot(axis), r[7], -Vec3(r[4], r[5], r[6]).dot(axis),
                    probe_col > 0 ? r[probe_col] : std::numeric_limits<double>::quiet_NaN());
      });
    if (!pass) {
      summary.plot_error = "plots: " + pass.error().message;
    } else if (Status s = plot_run(out, scene.name, builder.finish(), summary.events, &summary.plots); !s) {
      summary.plot_error = s.error().message;
    }
  }
  j["outputs"] = {{"csv", summary.csv.filename().string()}};
  j["outputs"]["plots"] = nlohmann::json::array();
  for (const auto& p : summary.plots) j["outputs"]["plots"].push_back(p.filename().string());
  if (!summary.plot_error.empty()) j["outputs"]["plot_error"] = summary.plot_error;
  summary.frames = std::move(frames);
  summary.frame_error = std::move(frame_error);
  if (nframes > 0) {
    j["outputs"]["frames"] = nlohmann::json::array();
    for (const RunFrame& f : summary.frames)
      j["outputs"]["frames"].push_back({{"file", f.file.filename().string()}, {"time_s", f.time}});
    if (!summary.frame_error.empty()) j["outputs"]["frame_error"] = summary.frame_error;
  }
  if (exporter) {
    // The exports' collection files (run.pvd, run.glb), also for an interrupted run (up to its end).
    if (export_error.empty())
      if (Status s = exporter->finish(summary.export_files); !s) export_error = s.error().message;
    for (const auto& [t, f] : exporter->saved()) summary.exports.push_back({t, f});
    summary.export_error = export_error;
    j["outputs"]["exports"] = nlohmann::json::array();
    for (const RunFrame& f : summary.exports) {
      std::error_code ec;
      const fs::path rel = fs::relative(f.file, out, ec);
      j["outputs"]["exports"].push_back({{"file", (ec ? f.file : rel).generic_string()}, {"time_s", f.time}});
    }
    j["outputs"]["export_files"] = summary.export_files.size();
    if (!export_error.empty()) j["outputs"]["export_error"] = export_error;
  }
  summary.ultrasound = std::move(us_frames);
  summary.ultrasound_error = std::move(us_error);
  if (nus > 0) {
    j["outputs"]["ultrasound"] = nlohmann::json::array();
    for (const RunFrame& f : summary.ultrasound)
      j["outputs"]["ultrasound"].push_back({{"file", f.file.filename().string()}, {"time_s", f.time}});
    if (!summary.ultrasound_error.empty()) j["outputs"]["ultrasound_error"] = summary.ultrasound_error;
  }
  if (Status s = write_file_atomic(summary.summary_json, j.dump(2) + "\n"); !s) return s.error();
  return summary;
}

}  // namespace palpate
