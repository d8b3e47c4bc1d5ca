// run_support.cpp — what a run needs around its loop (run_support.h): its output folder cleared
// of an earlier run's files, the disk it needs, and the ticks its images are taken after.
#include "simulation/run_support.h"

#include "simulation/plots.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <system_error>
#include <sys/statvfs.h>

namespace palpate {

namespace run_support {

// Whether `name` is one of the files a run writes into its output directory (or their temporary
// forms): run.csv, summary.json, the plots and their script, data and log, frame_NNN.png, and
// each of these + ".part" or ".tmp-...".
bool is_run_output(const std::string& name) {
  static const char* const kFixed[] = {"run.csv", "summary.json", "force_time.png", "force_depth.png",
                                       "force.dat", "plots.gp", "plots.log", "run.csv.part.series",
                                       "run.pvd", "run.glb"};
  for (const char* f : kFixed)
    if (name == f || name.rfind(std::string(f) + ".tmp-", 0) == 0) return true;
  // Numbered images: frame_NNN.png (frames) and us_NNN.png (ultrasound), and their temporary forms.
  for (const char* prefix : {"frame_", "us_"}) {
    const size_t p = std::char_traits<char>::length(prefix);
    if (name.rfind(prefix, 0) != 0) continue;
    if (const size_t tmp = name.find(".tmp-"); tmp != std::string::npos) return is_run_output(name.substr(0, tmp));
    if (name.size() > p + 4 && name.compare(name.size() - 4, 4, ".png") == 0)
      return std::all_of(name.begin() + std::ptrdiff_t(p), name.end() - 4, [](char c) { return c >= '0' && c <= '9'; });
  }
  if (name.size() > 5 && name.compare(name.size() - 5, 5, ".part") == 0)
    return is_run_output(name.substr(0, name.size() - 5));
  return false;
}

// A run starts with none of an earlier run's outputs beside it: a new run.csv next to an old
// summary.json or old plots (a run killed while plotting) would be read as one run.
Status clear_run_outputs(const std::filesystem::path& out) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(out, ec)) return {};
  for (const auto& e : fs::directory_iterator(out, ec)) {
    const std::string name = e.path().filename().string();
    if (!is_run_output(name) || !e.is_regular_file(ec)) continue;
    if (!fs::remove(e.path(), ec) && ec)
      return Error{e.path().string() + ": cannot remove an earlier run's output: " + ec.message()};
  }
  if (ec) return Error{out.string() + ": cannot list the output directory: " + ec.message()};
  return {};
}

std::string gigabytes(double bytes) { return fmt::format("{:.3g} GB", bytes * 1e-9); }

// Bytes free for a new file at `dir` (its nearest existing ancestor); -1 when unknown.
double free_bytes(std::filesystem::path dir) {
  std::error_code ec;
  while (!dir.empty() && !std::filesystem::exists(dir, ec) && dir.has_parent_path() && dir != dir.parent_path())
    dir = dir.parent_path();
  struct statvfs v {};
  if (dir.empty() || ::statvfs(dir.c_str(), &v) != 0) return -1;
  return double(v.f_bavail) * double(v.f_frsize);
}

// The ticks after which images 0 … n − 1 are taken: at `times` (s) when given — each the tick that
// ends nearest it, at least the first — else `count` evenly spaced, the first after the first tick
// and the last at the end. An error naming `what` for a time outside the run, out of order, or on
// the tick of the one before.
Result<std::vector<std::uint64_t>> image_ticks(int count, const std::vector<double>& times, std::uint64_t ticks,
                                               double dt, const std::string& where, const std::string& what,
                                               const std::string& times_key) {
  std::vector<std::uint64_t> out;
  if (times.empty()) {
    if (count < 0 || std::uint64_t(count) > ticks)
      return Error{where + ": " + what + " must be between 0 and the run's " + std::to_string(ticks) + " ticks, not " +
                   std::to_string(count)};
    const auto n = static_cast<size_t>(count);
    for (size_t k = 0; k < n; ++k)
      out.push_back(n == 1 ? ticks : 1 + static_cast<std::uint64_t>(std::llround(double(k) * double(ticks - 1) / double(n - 1))));
    return out;
  }
  const double end = double(ticks) * dt;
  for (size_t k = 0; k < times.size(); ++k) {
    const double t = times[k];
    if (!std::isfinite(t) || t < 0 || t > end + 0.5 * dt)
      return Error{where + ": " + times_key + ": " + fmt::format("{}", t) + " s is outside the run (0 to " +
                   fmt::format("{}", end) + " s)"};
    const auto tick = std::clamp<std::uint64_t>(static_cast<std::uint64_t>(std::llround(t / dt)), 1, ticks);
    if (!out.empty() && tick <= out.back())
      return Error{where + ": " + times_key + ": expected ascending times, each on a tick of its own: " +
                   fmt::format("{}", t) + " s comes at or before " + fmt::format("{}", times[k - 1]) + " s's tick"};
    out.push_back(tick);
  }
  return out;
}

}  // namespace run_support

RunFootprint run_footprint(std::uint64_t ticks, size_t columns) {
  RunFootprint f;
  f.ticks = ticks;
  // run.csv: ~6 characters a column (95 B a tick with the 16 columns of one charged tissue);
  // beside it, the 12 columns kept for the plots, 8 bytes each, in a temporary file (gone at the
  // end); in memory, the plotted rows only (at most PlotSeriesBuilder::kMaxRows of 4 doubles).
  f.csv_bytes = double(ticks) * 6.0 * double(columns);
  f.series_bytes = double(ticks) * 12.0 * 8.0;
  f.memory_bytes = double(std::min<std::uint64_t>(ticks, PlotSeriesBuilder::kMaxRows)) * 4.0 * 8.0;
  return f;
}

}  // namespace palpate
