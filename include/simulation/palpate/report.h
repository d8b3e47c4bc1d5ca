// palpate/report.h — report.html: each attempt at a needle scene as the educator reads it
// (docs/cvc.md, "The report"): the outcome, the metrics against the published figures they are
// judged by (../shared/data/measurements/cvc_ultrasound_and_metrics.md, part C1), the force over
// time with the events marked, the ultrasound image at the flashback and the 3-D frames; several
// attempts side by side in one table. One self-contained file: the plot is inline SVG, the images
// are data: URIs, and a Content-Security-Policy forbids the page every load from elsewhere. Every
// text that comes from a scene or a file is escaped (markup_escape, palpate/core.h).
#pragma once

#include <palpate/core.h>
#include <palpate/outcome.h>
#include <palpate/run.h>
#include <palpate/scene_def.h>

#include <array>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace palpate {

struct ReportImage {
  double time = 0;      // s, the tick it shows
  std::string png;      // the PNG file's bytes
  std::string caption;  // plain text (escaped when written)
};

// One attempt: a run of a scene, or one attempt in the viewer (from a start or a reset to the next).
struct ReportAttempt {
  std::string label;        // "attempt 1", a run's folder: plain text
  std::string scene;        // the scene's name
  std::string scene_file;   // where it was read from
  double duration = 0;      // s
  TrainingMetrics metrics;
  std::vector<RunEvent> events;
  std::vector<std::array<double, 2>> force;        // (s, N): |F| sent to the needle's device
  std::vector<std::array<double, 2>> probe_force;  // (s, N): the probe's, a scene with one
  double max_force = 3.3;                          // N, the needle's device's limit (the plot's scale)
  std::optional<ReportImage> ultrasound;           // the image at the flashback (or the arterial one)
  std::vector<ReportImage> frames;                 // 3-D frames
  std::vector<std::string> notes;                  // what is missing and why: plain text
};

// One row of the metrics table: a metric of the attempt against the published figure it is judged by.
struct ReportCriterion {
  std::string metric;     // what is measured
  std::string value;      // the attempt's
  std::string reference;  // the published figure
  std::string source;     // where it comes from (C1 of the measurements file)
  int verdict = 0;        // 1 met, −1 not met, 0 for information
};
std::vector<ReportCriterion> report_criteria(const ReportAttempt& attempt);

// RFC 4648 base64 (the data: URIs).
std::string base64(std::string_view bytes);

// The page, and the page written atomically (through <file>.part).
std::string report_html(std::span<const ReportAttempt> attempts);
Status write_report_html(std::span<const ReportAttempt> attempts, const std::filesystem::path& file);

// The attempt a finished run_scene gave: its summary (metrics, events, frames), the force traces
// read back from its run.csv (thinned to at most 4000 points each, keeping each interval's
// extremes), and — a scene with a probe and a flashback (or an arterial one) — the ultrasound image
// at that tick, drawn by running the scene again headless up to it (headless runs are
// deterministic: tests/golden). A run whose needle was a hand (openhaptics) or was interrupted has
// no such image: a note says so.
// A trace thinned to at most `most` points for the plot: per interval its extremes, in time order.
std::vector<std::array<double, 2>> thin_trace(const std::vector<std::array<double, 2>>& points, size_t most);

// The image is also written into the run's folder as flashback_us.png, for read_report_attempt.
Result<ReportAttempt> run_report_attempt(const SceneDef& scene, const RunSummary& summary, const RunOptions& options);

// The attempt a run's output folder holds (`palpate report DIR...`): its summary.json (scene,
// outcome, metrics, events, frames), run.csv (the force traces) and flashback_us.png when there is
// one. Errors name the file, and the key or line, and what was expected.
Result<ReportAttempt> read_report_attempt(const std::filesystem::path& run_dir);

// The Outcome whose outcome_name() is `name`; false when none is.
bool outcome_from_name(std::string_view name, Outcome& out) noexcept;

}  // namespace palpate
