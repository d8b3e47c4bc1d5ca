// run_support.h — internal: what run_simulation (run.cpp) needs around its loop, in
// run_support.cpp: the output folder cleared of an earlier run's files, the disk a run needs, and
// the ticks after which its images (frames, ultrasound) are taken.
#pragma once

#include <palpate/core.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace palpate::run_support {

// Whether `name` is one of the files a run writes into its output directory (or their temporary
// forms): run.csv, summary.json, the plots and their script, data and log, frame_NNN.png, and
// each of these + ".part" or ".tmp-...".
bool is_run_output(const std::string& name);
// A run starts with none of an earlier run's outputs beside it.
Status clear_run_outputs(const std::filesystem::path& out);
// "1.23 GB".
std::string gigabytes(double bytes);
// Bytes free for a new file at `dir` (its nearest existing ancestor); -1 when unknown.
double free_bytes(std::filesystem::path dir);
// The ticks after which images 0 … n − 1 are taken: at `times` (s) when given — each the tick that
// ends nearest it, at least the first — else `count` evenly spaced, the first after the first tick
// and the last at the end. An error naming `what` / `times_key` for a count out of range, or a time
// outside the run, out of order, or on the tick of the one before.
Result<std::vector<std::uint64_t>> image_ticks(int count, const std::vector<double>& times, std::uint64_t ticks,
                                               double dt, const std::string& where, const std::string& what,
                                               const std::string& times_key);

}  // namespace palpate::run_support
