// trace.h — golden force traces: a shipped scene's force and tool pose at every tick, in full
// precision, recorded once (tests/golden/record.cpp, `make golden`) and compared by
// tests/test_golden_traces.cpp, so a change proves it did not change what the hand feels.
//
// File (tests/golden/<scene>.trace.gz, gzip): a text header, one "key: value" a line, ended by an
// empty line —
//   palpate golden trace 1
//   scene: cvc.yaml
//   path: avx512            (the vector path the spring step took: avx512, avx2 or scalar)
//   columns: t,tool_x,...   (HapticLoop::series_columns: the needle's time, pose and force, then
//                            each extra tool's pose and force)
//   rows: 12800             (ticks)
// — then the values column after column (rows doubles each, little-endian), each column's bytes
// shuffled (byte 0 of every value, then byte 1, ...) so that gzip finds the runs of equal sign,
// exponent and leading mantissa bytes that neighbouring ticks share (≈ 4x smaller than unshuffled).
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace palpate {
struct SceneDef;
}

namespace palpate::golden {

struct Trace {
  std::string scene;                         // the scene file's name (data/scenes/<scene>)
  std::string path;                          // the vector path the recording took
  std::vector<std::string> columns;          // column names
  std::vector<std::vector<double>> values;   // values[c][tick]
  size_t rows() const { return values.empty() ? 0 : values[0].size(); }
};

// The vector path this machine's spring step takes (the best the CPU offers): "avx512", "avx2" or
// "scalar" — a trace compares exactly only against one recorded on the same path.
std::string vector_path();

// Run data/scenes/<scene> headless (its own device, dt and duration; outputs in a temporary
// directory, no plots) and return its trace. An error text instead when the scene does not load or run.
struct RunResult {
  Trace trace;
  std::string error;
};
// `edit`, when given, changes the loaded scene before it runs (a setting turned off to compare with).
RunResult run_trace(const std::filesystem::path& scene_file, const std::function<void(SceneDef&)>& edit = {});

// Write / read a trace file. Read returns false with `error` set (naming the file) on any damage.
bool write_trace(const std::filesystem::path& file, const Trace& trace, std::string& error);
bool read_trace(const std::filesystem::path& file, Trace& trace, std::string& error);

// Tolerances: a force column (its name holds "force") may differ by `force_tolerance` N, every other
// column (time, positions, orientations) by `pose_tolerance` (m, or unitless for a quaternion).
struct Tolerance {
  double force = 1e-9;  // N
  double pose = 1e-12;  // m
};
// Compare `got` with `golden`: "" when every tick of every column is within tolerance, else a text
// naming the first tick and column that differ, both values, how many values differ and the largest
// difference of each kind.
std::string compare(const Trace& golden, const Trace& got, const Tolerance& tol);
// The largest difference of each kind over every tick (traces of the same columns and ticks).
struct Differences {
  double force = 0;  // N
  double pose = 0;   // m (or unitless, a quaternion's)
};
Differences largest_differences(const Trace& golden, const Trace& got);

}  // namespace palpate::golden
