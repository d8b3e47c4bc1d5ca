// palpate/run.h — a run of a scene at a fixed tick (headless, or wall-clock paced), with its outputs.
#pragma once

#include <palpate/core.h>
#include <palpate/haptics.h>
#include <palpate/render.h>
#include <palpate/safety.h>
#include <palpate/scene_def.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace palpate {

struct RunOptions {
  std::filesystem::path out;                         // output directory; "" = the scene's
  std::filesystem::path cache;                       // predictor cache; "" = default_predictor_cache()
  std::function<void(double fraction)> progress;     // called now and then, off the tick path
  bool plots = true;                                 // force_time.png, force_depth.png (gnuplot)
  bool realtime = false;          // wall-clock paced on the haptic thread (1 tick per dt of real time)
  bool realtime_priority = true;  // realtime: ask for SCHED_FIFO (ignored when not permitted)
  std::vector<double> physics_dt; // s per tissue (by index); > 0 steps it on its own thread at
                                  // that period (multi-rate); missing or 0 = every haptic tick
  // Frames: `frames` PNG images (frame_000.png, ...) evenly spaced over the run, the first after
  // its first tick and the last at its end, drawn off-screen from the tissues' snapshots with the
  // tool and force of that tick. In a realtime run they are drawn on this thread while the haptic
  // thread runs (hand-over through SnapshotTissue: the loop never waits for them).
  int frames = 0;
  // Frames at these times instead (s, ascending, within the run; `frames` is then ignored): each
  // after the tick that ends nearest it (the first tick at the earliest), no two on one tick.
  std::vector<double> frame_times;
  FrameOptions frame_options;
  // Set it (from any thread, or a signal handler: a lock-free atomic) to end the run early: it stops
  // at a tick boundary, the force ramps to zero within the rate limit, and the outputs are written
  // as for a whole run, up to the last tick run (summary.json: "interrupted": true). Null: never.
  const std::atomic<bool>* interrupt = nullptr;
  // Ultrasound: `ultrasound` B-mode PNGs (us_000.png, ...) of the plane under the scene's probe,
  // spaced over the run as the frames are, each from the probe's and the needle's pose at its tick
  // and that tick's time (the arterial pulse), the vein's wall tented where the needle's tissue
  // pushes it (the scene's `vein` tissue handed over through a SnapshotTissue, as frames are);
  // drawn on this thread, off the haptic thread. Needs the scene's `probe`.
  int ultrasound = 0;
  // Ultrasound images at these times instead (s; as frame_times).
  std::vector<double> ultrasound_times;
  // Exports (docs/export.md), written off the tick path as frames are (the same hand-over):
  // "vtu": run.pvd and vtu/<part>_NNNN.vtu (binary appended, float64) for each tissue and the
  // tools; "gltf": run.glb, the run as one animated glTF 2.0 scene. Saved at t = 0 (the rest
  // state, before the first tick), then after the tick nearest every `export_every` s, and at the
  // run's end. Into `out`; an unwritable folder is refused before the first tick.
  std::vector<std::string> exports;
  double export_every = 0.1;  // s, > 0
  // Every tick's kept series row in full precision (double): the needle's time, pose and force and
  // each extra tool's pose and force (HapticLoop::finish_recording lists them;
  // RunSummary::series_columns names them), streamed back from the recorder's file after the run,
  // off the tick path, before the plots. For golden force traces (tests/golden) and analyses that
  // need more than run.csv's nine significant digits. Null: not called.
  std::function<void(std::span<const double> row)> series_row;
};

struct RunFrame {
  double time = 0;               // s, the tick the frame shows
  std::filesystem::path file;
};

struct RunEvent {
  double time = 0;     // s
  std::string kind;    // "puncture", "flashback", ...
  std::string tissue;  // the tissue's name
  double depth = 0;    // m
  double force = 0;    // N
};

struct RunSummary {
  size_t ticks = 0;                               // ticks run (fewer than asked when interrupted)
  bool interrupted = false;                       // RunOptions::interrupt ended the run early
  double dt = 0;                                  // s
  double step_median = 0, step_p99 = 0, step_max = 0;  // s, wall time of one tick's work
  std::array<TimingFigures, kTickStageCount> stages{};  // s, each of the tick's stages (TickStage order)
  double max_force = 0;                           // N, largest force sent to the device
  bool realtime = false;
  TimingFigures period;                           // s, wake-up to wake-up (realtime runs)
  std::uint64_t deadline_misses = 0;              // realtime ticks that ended after the next deadline
  SafetyCounters safety;
  PassivityCounters passivity;                    // tool 0's passivity controller (safety.h)
  std::uint64_t recorder_dropped = 0;             // rows lost by the recorder (0 unless overloaded)
  std::vector<RunEvent> events;                   // the tissues' events and the "flashback"
  TrainingMetrics metrics;                        // outcome and the trainee's metrics (docs/cvc.md)
  std::filesystem::path csv, summary_json;        // where the outputs went
  std::vector<std::filesystem::path> plots;       // PNG plots written, if any
  std::string plot_error;                         // why plots are missing, if they are
  std::vector<RunFrame> frames;                   // frames written, if asked for
  std::string frame_error;                        // why frames are missing, if they are
  std::vector<RunFrame> ultrasound;               // ultrasound images written, if asked for
  std::string ultrasound_error;                   // why they are missing, if they are
  std::vector<RunFrame> exports;                  // exported states (time; the .vtu of the first part, or run.glb)
  std::vector<std::filesystem::path> export_files;  // every file the exports wrote (run.pvd, .vtu, run.glb)
  std::string export_error;                       // why exports are missing or incomplete, if they are
  std::vector<LoopToolStats> tools;               // the extra tools (the probe): force, safety
  std::vector<LoopPhysicsStats> physics;          // tissues on their own thread: steps, step time, late
  std::vector<std::string> tissue_names;          // the tissues' names, in the loop's order
  std::vector<std::string> series_columns;        // the columns RunOptions::series_row gets
};

// What a run of `ticks` ticks recording `columns` columns writes and holds (estimates): run.csv's
// size on disk, the plots' series streamed to a temporary file beside it, and the memory of the
// plotted rows (bounded: a long run's are a min/max envelope). run_scene refuses a run whose
// run.csv and series would not fit on the disk, naming the scene's duration; `palpate run` prints
// the footprint before a long run.
struct RunFootprint {
  std::uint64_t ticks = 0;
  double csv_bytes = 0;     // bytes, run.csv
  double series_bytes = 0;  // bytes, the plots' series in a temporary file beside it (gone at the end)
  double memory_bytes = 0;  // bytes, the plotted rows held in memory (bounded, whatever the length)
};
RunFootprint run_footprint(std::uint64_t ticks, size_t columns);

// Run `scene` for its duration at its fixed tick, with its device (and, when the scene has a
// probe, the probe's device as a second tool with its own safety filter, pressing the neck:
// NeckCompression); stream `run.csv` (through
// `run.csv.part`, renamed at the end) and write `summary.json` atomically into the output directory.
Result<RunSummary> run_scene(const SceneDef& scene, const RunOptions& options = {});

// The same with tissues built by the caller (a model of your own, or ones already built);
// `scene.tissues` is then not used.
class Tissue;
Result<RunSummary> run_scene(const SceneDef& scene, std::vector<std::unique_ptr<Tissue>> tissues,
                             const RunOptions& options = {});

// The two halves of run_scene: the Simulation a run builds (headless or realtime, snapshots where
// frames or ultrasound images need them), and the run of a built one (outputs under options.out).
// A Simulation built with other options runs too, as long as frames come with snapshots.
class Simulation;
struct SimulationOptions;
SimulationOptions run_simulation_options(const SceneDef& scene, const RunOptions& options);
Result<RunSummary> run_simulation(Simulation& sim, const RunOptions& options);


}  // namespace palpate
