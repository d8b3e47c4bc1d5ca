// cmd_run.cpp — `palpate run SCENE [--out DIR] [--realtime] [--device KIND] [--coupling C]`: a run
// with the scene's device, headless (as fast as it goes) or paced by the wall clock at 1 kHz.
#include <palpate/palpate.h>
#include <palpate/report.h>

#include "commands.h"

#include <fmt/core.h>
#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <unistd.h>

namespace palpate::cli {


namespace {

// Ctrl-C (SIGINT) or SIGTERM during a run: the handler only sets these (a lock-free atomic is
// async-signal-safe); run_scene stops at a tick boundary, ramps the force out, writes the outputs.
// A second signal of the same kind ends the process at once (SA_RESETHAND).
std::atomic<bool> g_interrupt{false};
volatile std::sig_atomic_t g_signal = 0;
static_assert(std::atomic<bool>::is_always_lock_free);

extern "C" void on_interrupt(int sig) {
  g_signal = sig;
  g_interrupt.store(true, std::memory_order_relaxed);
}

// Installs the handler for SIGINT and SIGTERM for its lifetime, then puts back what was there.
class InterruptHandler {
 public:
  InterruptHandler() {
    struct sigaction sa {};
    sa.sa_handler = &on_interrupt;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESTART | SA_RESETHAND;
    ::sigaction(SIGINT, &sa, &old_int_);
    ::sigaction(SIGTERM, &sa, &old_term_);
  }
  ~InterruptHandler() {
    ::sigaction(SIGINT, &old_int_, nullptr);
    ::sigaction(SIGTERM, &old_term_, nullptr);
  }
  InterruptHandler(const InterruptHandler&) = delete;
  InterruptHandler& operator=(const InterruptHandler&) = delete;

 private:
  struct sigaction old_int_ {}, old_term_ {};
};

struct RunArgs {
  std::string scene;
  std::string out;
  std::string cache;
  bool quiet = false;
  bool verbose = false;
  bool realtime = false;
  std::string device;       // overrides device.kind
  std::string recording;    // overrides device.recording (replay)
  std::string coupling;     // overrides device.coupling
  double physics_rate = 0;  // Hz; > 0 steps every tissue on its own thread at this rate
  int frames = 0;
  int ultrasound = 0;
  std::vector<double> frame_times, ultrasound_times;  // s; instead of the counts
  std::vector<std::string> exports;  // vtu, gltf
  double export_every = 0.1;         // s
  FrameOptions frame;
  bool no_report = false;            // a needle scene writes report.html unless told not to
};

int run_command(const RunArgs& a) {
  // Stereo frames: off-screen drawing has no left and right buffers, and stereo needs frames.
  if (a.frame.stereo.mode == StereoMode::quad_buffer) {
    fmt::print(stderr, "palpate run: --stereo quad-buffer: frames are drawn off-screen (OSMesa), which has no "
                       "stereo (left and right) buffers; use anaglyph, side-by-side or top-bottom\n");
    return kExitUsage;
  }
  if (a.frame.stereo.mode != StereoMode::mono && a.frames == 0 && a.frame_times.empty()) {
    fmt::print(stderr, "palpate run: --stereo draws the frames in stereo; give --frames N or --frame-times\n");
    return kExitUsage;
  }
  auto scene = load_scene(a.scene);
  if (!scene) {
    fmt::print(stderr, "palpate run: {}\n", scene.error().message);
    return kExitFailed;
  }
  if (!a.quiet)
    for (const std::string& w : scene->warnings) fmt::print(stderr, "palpate run: warning: {}\n", w);
  if (!a.device.empty()) scene->device.kind = a.device;
  if (!a.recording.empty()) {
    scene->device.recording = a.recording;
    if (a.device.empty()) scene->device.kind = "replay";
  }
  if (!a.coupling.empty()) scene->device.coupling = a.coupling;
  // The anatomy's layers generated now (the run would do it too), so every tissue is counted below.
  if (auto expanded = expand_anatomy(*scene); !expanded) {
    fmt::print(stderr, "palpate run: {}\n", expanded.error().message);
    return kExitFailed;
  } else {
    *scene = std::move(*expanded);
  }
  RunOptions opt;
  if (!a.out.empty()) opt.out = a.out;
  if (!a.cache.empty()) opt.cache = a.cache;
  opt.realtime = a.realtime;
  if (a.realtime) prepare_realtime_process();
  if (a.physics_rate > 0) opt.physics_dt.assign(scene->tissues.size(), 1.0 / a.physics_rate);
  opt.frames = a.frames;
  opt.ultrasound = a.ultrasound;
  opt.frame_times = a.frame_times;
  opt.ultrasound_times = a.ultrasound_times;
  opt.frame_options = a.frame;
  opt.exports = a.exports;
  opt.export_every = a.export_every;
  const bool bar = !a.quiet && stderr_is_terminal();
  if (bar) {
    opt.progress = [](double f) {
      const int width = 40, filled = static_cast<int>(f * width);
      fmt::print(stderr, "\r  running [{:<{}}] {:3.0f}%", std::string(size_t(filled), '#'), width,
                 f * 100);
      if (f >= 1.0) fmt::print(stderr, "\n");
    };
  }
  // A long run says up front what it will write (from a million ticks: 1000 s at 1 ms).
  const auto ticks = static_cast<std::uint64_t>(std::llround(scene->duration / scene->dt));
  if (!a.quiet && ticks >= 1'000'000) {
    const RunFootprint fp = run_footprint(ticks, 15 + 10 * scene->tissues.size());
    fmt::print(stderr, "palpate run: {} ticks: run.csv about {:.2g} GB, and {:.2g} GB for the plots' series "
               "in a temporary file beside it while the run lasts\n", ticks, fp.csv_bytes * 1e-9, fp.series_bytes * 1e-9);
  }
  if (a.verbose) print_scene_inputs(*scene, opt.cache);
  opt.interrupt = &g_interrupt;
  auto result = [&] {
    InterruptHandler on_signal;
    return run_scene(*scene, opt);
  }();
  if (!result) {
    fmt::print(stderr, "palpate run: {}\n", result.error().message);
    return 1;
  }
  const RunSummary& s = *result;
  // The attempt as the educator reads it (docs/cvc.md, "The report"): a needle scene's report.html.
  std::filesystem::path report;
  std::string report_error;
  if (!a.no_report && scene->tool.kind == "needle") {
    auto attempt = run_report_attempt(*scene, s, opt);
    if (!attempt) {
      report_error = attempt.error().message;
    } else {
      report = (opt.out.empty() ? scene->output : opt.out) / "report.html";
      if (Status st = write_report_html({&*attempt, 1}, report); !st) report_error = st.error().message, report.clear();
    }
  }
  if (!a.quiet) {
    fmt::print("scene      {}\n", scene->name);
    fmt::print("ticks      {} at {} ms\n", s.ticks, s.dt * 1e3);
    fmt::print("step time  median {:.1f} us, p99 {:.1f} us, max {:.1f} us\n", s.step_median * 1e6,
               s.step_p99 * 1e6, s.step_max * 1e6);
    std::string stages;
    for (size_t i = 0; i < kTickStageCount; ++i)
      stages += fmt::format("{}{} {:.2f}", i ? ", " : "", tick_stage_name(TickStage(i)), s.stages[i].median * 1e6);
    fmt::print("stages     median us: {}\n", stages);
    if (a.verbose)
      for (size_t i = 0; i < kTickStageCount; ++i)
        fmt::print("stage      {:<16} median {:8.2f} us, p99 {:8.2f} us, max {:8.2f} us\n",
                   tick_stage_name(TickStage(i)), s.stages[i].median * 1e6, s.stages[i].p99 * 1e6,
                   s.stages[i].max * 1e6);
    if (s.realtime)
      fmt::print("period     median {:.3f} ms, p99 {:.3f} ms, max {:.3f} ms; {} deadline misses\n",
                 s.period.median * 1e3, s.period.p99 * 1e3, s.period.max * 1e3, s.deadline_misses);
    const SafetyCounters& c = s.safety;
    if (c.zeroed() > 0)
      fmt::print("safety     non-finite {}, step failed {}, overrun {}, stalled {}, device failed {}\n",
                 c.non_finite, c.step_failed, c.overrun, c.stalled, c.device_failed);
    if (c.blade_teleport > 0)
      fmt::print("safety     blade teleported {} ticks (pressed without cutting)\n", c.blade_teleport);
    if (s.passivity.active_ticks > 0)
      fmt::print("passivity  damping added on {} ticks (capped on {}), {:.3g} J absorbed, lowest energy {:.3g} J\n",
                 s.passivity.active_ticks, s.passivity.capped_ticks, s.passivity.dissipated, s.passivity.min_energy);
    if (s.recorder_dropped > 0) fmt::print("recorder   {} rows dropped\n", s.recorder_dropped);
    for (const LoopPhysicsStats& p : s.physics) {
      const std::string name = p.tissue >= 0 && size_t(p.tissue) < s.tissue_names.size() ? s.tissue_names[size_t(p.tissue)] : "?";
      fmt::print("physics    {}: {} steps at {:.0f} Hz, step median {:.2f} ms, p99 {:.2f} ms, max {:.2f} ms; {} late; "
                 "{} ticks from the contact patch, {} fell back\n",
                 name, p.steps, p.period > 0 ? 1.0 / p.period : 0.0, p.step.median * 1e3, p.step.p99 * 1e3,
                 p.step.max * 1e3, p.late, p.patch_ticks, p.patch_fallbacks);
    }
    fmt::print("max force  {:.3f} N\n", s.max_force);
    for (const LoopToolStats& t : s.tools) {
      const SafetyCounters& tc = t.safety;
      fmt::print("{:<10} max force {:.3f} N (limit {:.3f} N); clamped {}, rate-limited {}, device failed {}, overrun {}\n",
                 t.name, t.max_force, t.max_force_limit, tc.clamped, tc.rate_limited, tc.device_failed, tc.overrun);
    }
    for (const RunEvent& e : s.events)
      fmt::print("event      {:.3f} s  {:<9} {:<12} depth {:.2f} mm  force {:.3f} N\n", e.time,
                 e.kind, e.tissue, e.depth * 1e3, e.force);
    // The outcome and the trainee's metrics (docs/cvc.md, "Outcome and metrics").
    const TrainingMetrics& m = s.metrics;
    fmt::print("outcome    {}\n", outcome_name(m.outcome));
    fmt::print("metrics    skin punctures {}, passes {} (redirections {}), time to flashback {}\n",
               m.skin_punctures, m.passes, m.redirections,
               m.flashback ? fmt::format("{:.3f} s", m.time_to_flashback) : std::string("none"));
    fmt::print("           deepest tip {:.1f} mm below the skin, peak force {:.3f} N\n",
               m.deepest_depth * 1e3, m.peak_force);
    if (m.arterial_flashback)
      fmt::print("           arterial flashback at {:.3f} s: pulsatile, bright red (the carotid)\n",
                 m.arterial_flashback_time);
    fmt::print("outputs    {}\n           {}\n", s.csv.string(), s.summary_json.string());
    for (const auto& p : s.plots) fmt::print("           {}\n", p.string());
    if (!report.empty()) fmt::print("           {}\n", report.string());
    if (s.frames.size() <= 10) {
      for (const RunFrame& f : s.frames) fmt::print("           {}  (t = {:.3f} s)\n", f.file.string(), f.time);
    } else {
      fmt::print("           {} frames: {} (t = {:.3f} s) ... {} (t = {:.3f} s)\n", s.frames.size(),
                 s.frames.front().file.string(), s.frames.front().time, s.frames.back().file.string(),
                 s.frames.back().time);
    }
    auto list = [](const std::vector<RunFrame>& v) {
      if (v.size() <= 10) {
        for (const RunFrame& f : v) fmt::print("           {}  (t = {:.3f} s)\n", f.file.string(), f.time);
      } else {
        fmt::print("           {} images: {} (t = {:.3f} s) ... {} (t = {:.3f} s)\n", v.size(),
                   v.front().file.string(), v.front().time, v.back().file.string(), v.back().time);
      }
    };
    list(s.ultrasound);
    if (!s.exports.empty()) {
      fmt::print("exports    {} states, t = {:.3f} ... {:.3f} s: ", s.exports.size(), s.exports.front().time,
                 s.exports.back().time);
      std::string names;
      for (const auto& f : s.export_files)
        if (f.extension() != ".vtu") names += (names.empty() ? "" : ", ") + f.string();
      const size_t vtus = size_t(std::count_if(s.export_files.begin(), s.export_files.end(),
                                               [](const auto& f) { return f.extension() == ".vtu"; }));
      if (vtus > 0) names += fmt::format(" ({} .vtu files)", vtus);
      fmt::print("{}\n", names);
    }
  }
  if (!s.plot_error.empty()) fmt::print(stderr, "palpate run: no plots: {}\n", s.plot_error);
  if (!report_error.empty()) fmt::print(stderr, "palpate run: no report.html: {}\n", report_error);
  // A tissue whose step failed on every tick (a predictor that resets it each step) sent no force
  // at all: say so, not only count it.
  if (s.ticks > 0 && s.safety.step_failed >= s.ticks) {
    fmt::print(stderr, "palpate run: every one of the {} ticks failed its tissue step (the tissue was reset and "
               "the force was zero throughout): check the scene's material and predictor\n", s.ticks);
    return 1;
  }
  if (!s.frame_error.empty()) {
    fmt::print(stderr, "palpate run: frames: {}\n", s.frame_error);
    return 1;
  }
  if (!s.export_error.empty()) {
    fmt::print(stderr, "palpate run: exports: {}\n", s.export_error);
    return 1;
  }
  if (s.interrupted) {
    const int sig = g_signal ? int(g_signal) : SIGINT;
    if (bar) fmt::print(stderr, "\n");
    fmt::print(stderr, "palpate run: interrupted ({}) after {} ticks (t = {:.3f} s); outputs written up to "
               "the last tick (summary.json: \"interrupted\": true)\n",
               sig == SIGTERM ? "SIGTERM" : "SIGINT", s.ticks, double(s.ticks) * s.dt);
    return 128 + sig;
  }
  if (!s.ultrasound_error.empty()) {
    fmt::print(stderr, "palpate run: ultrasound: {}\n", s.ultrasound_error);
    return 1;
  }
  // The plots are among a run's outputs: a run that could not write them did not do its job
  // (the reason was printed above; run.csv and summary.json are whole).
  if (!s.plot_error.empty() || !report_error.empty()) return 1;
  return 0;
}

}  // namespace

void add_run_command(CLI::App& app) {
  auto args = std::make_shared<RunArgs>();
  CLI::App* run = app.add_subcommand("run", "Run a scene at its fixed tick (headless, or --realtime); write run.csv and summary.json");
  run->add_option("scene", args->scene, "Scene file (YAML, see docs/scene-format.md)")
      ->required()->check(CLI::ExistingFile);
  run->add_option("--out,-o", args->out, "Output directory (default: the scene's `output`)");
  run->add_option("--cache", args->cache, "Folder for the predictors a scene does not name (default: $XDG_CACHE_HOME/palpate/predictors or ~/.cache/palpate/predictors)");
  add_output_flags(run, args->quiet, args->verbose);
  run->add_flag("--realtime", args->realtime,
                "Pace the run by the wall clock on a 1 kHz haptic thread (same outputs, plus period "
                "and deadline-miss statistics)");
  run->add_option("--device", args->device, "Device backend instead of the scene's")
      ->check(CLI::IsMember({"scripted", "replay", "openhaptics", "forcedimension"}));
  run->add_option("--replay", args->recording, "Play back a recorded run.csv (implies --device replay)")
      ->check(CLI::ExistingFile);
  run->add_option("--coupling", args->coupling, "Force rendering: direct (from the HIP) or virtual")
      ->check(CLI::IsMember({"direct", "virtual"}));
  run->add_option("--physics-rate", args->physics_rate,
                  "Hz: step the tissues on their own thread at this rate, rendering the force at 1 kHz "
                  "from a linearised contact (multi-rate)")
      ->check(CLI::Range(1.0, 100000.0));
  run->add_option("--frames", args->frames,
                  "Write N PNG frames (frame_000.png, ...) evenly spaced over the run, drawn "
                  "off-screen from the scene's camera")
      ->check(CLI::NonNegativeNumber);
  run->add_option("--ultrasound", args->ultrasound,
                  "Write N ultrasound images (us_000.png, ...) of the plane under the scene's probe, "
                  "evenly spaced over the run as --frames are (needs a 'probe' in the scene)")
      ->check(CLI::NonNegativeNumber);
  CLI::Option* ft = run->add_option("--frame-times", args->frame_times,
                                    "Frames at these times instead (s, comma-separated, ascending), e.g. 0.5,2,7.25")
                        ->delimiter(',');
  CLI::Option* ut = run->add_option("--ultrasound-times", args->ultrasound_times,
                                    "Ultrasound images at these times instead (s, comma-separated, ascending)")
                        ->delimiter(',');
  ft->excludes("--frames");
  ut->excludes("--ultrasound");
  CLI::Option* ex = run->add_option("--export", args->exports,
                                    "Export the run (docs/export.md): vtu (run.pvd + vtu/*.vtu for ParaView), "
                                    "gltf (run.glb, an animated scene for a browser), or vtu,gltf")
                        ->delimiter(',')
                        ->check(CLI::IsMember({"vtu", "gltf"}));
  run->add_option("--export-every", args->export_every,
                  "Exports: a state every SECONDS of the run (default 0.1), besides t = 0 and the end")
      ->check(CLI::Validator(
          [](std::string& v) -> std::string {
            double t = 0;
            try {
              t = std::stod(v);
            } catch (...) {
              return "expected a time in seconds, not '" + v + "'";
            }
            return std::isfinite(t) && t > 0 ? std::string() : "expected a time > 0 s, not " + v;
          },
          "SECONDS > 0"))
      ->needs(ex);
  run->add_flag("--no-report", args->no_report,
                "A needle scene writes report.html (outcome, metrics against published figures, force plot, "
                "the ultrasound image at the flashback, the frames): not this time");
  run->add_flag("--frame-particles", args->frame.particles, "Frames: draw the particles / masses");
  add_stereo_flags(run, args->frame.stereo, "Frames");
  run->add_flag("--frame-links", args->frame.links, "Frames: draw neighbour links / springs");
  run->add_option("--frame-resolution", args->frame.resolution,
                  "Frames: Bézier segments per patch edge (grids) or PN level (meshes)")
      ->check(CLI::Range(1, 32));
  run->callback([args] { throw CLI::RuntimeError(run_command(*args)); });
}

}  // namespace palpate::cli
