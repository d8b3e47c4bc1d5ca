// plots.h — force-versus-time and force-versus-depth PNG plots of a run, drawn by gnuplot.
#pragma once

#include <palpate/core.h>
#include <palpate/run.h>

#include <cstdint>
#include <filesystem>
#include <limits>
#include <span>
#include <vector>

namespace palpate {

struct PlotSeries {
  std::vector<double> time;   // s
  std::vector<double> depth;  // m, tool travel along its axis past first contact (< 0 before)
  std::vector<double> force;  // N, magnitude of the force sent to the device
  std::vector<double> axial;  // N, component resisting the tool's advance (along −axis)
  std::vector<double> probe;  // N, |F| sent to the ultrasound probe's device; empty without a probe
};

// Builds the plotted series from a run's ticks one at a time, holding at most about kMaxRows rows
// however long the run: every tick up to kMaxRows ticks (the plots of ordinary runs, up to 200 s at
// 1 kHz, draw every tick); past that, each block of `stride` ticks keeps only its ticks where |F|
// and the axial force are smallest and largest, in time order — a min/max envelope of 50,000
// blocks across a 900-pixel plot, which draws the same picture.
class PlotSeriesBuilder {
 public:
  static constexpr std::uint64_t kMaxRows = 200000;
  explicit PlotSeriesBuilder(std::uint64_t ticks);  // how many ticks add() will be given
  // `probe`: the probe's |F| (N); NaN when the scene has none.
  void add(double time, double depth, double force, double axial, double probe = std::numeric_limits<double>::quiet_NaN());
  PlotSeries finish();
  std::uint64_t stride() const { return stride_; }

 private:
  struct Row {
    double time, depth, force, axial, probe;
    std::uint64_t k;
  };
  void flush();
  std::uint64_t stride_ = 1, in_block_ = 0, seen_ = 0;
  Row lo_f_{}, hi_f_{}, lo_a_{}, hi_a_{};
  PlotSeries out_;
};

// Write force_time.png and force_depth.png (and the gnuplot script and data beside them) into
// `dir`, marking each event. Runs `gnuplot`; an error names what failed.
Status plot_run(const std::filesystem::path& dir, const std::string& title, const PlotSeries& s,
                std::span<const RunEvent> events, std::vector<std::filesystem::path>* written);

}  // namespace palpate
