// plots.h — force-versus-time and force-versus-depth PNG plots of a run, drawn by gnuplot.
#pragma once

#include <palpate/core.h>
#include <palpate/run.h>

#include <filesystem>
#include <span>
#include <vector>

namespace palpate {

struct PlotSeries {
  std::vector<double> time;   // s
  std::vector<double> depth;  // m, tool travel along its axis past first contact (< 0 before)
  std::vector<double> force;  // N, magnitude of the force sent to the device
  std::vector<double> axial;  // N, component resisting the tool's advance (along −axis)
};

// Write force_time.png and force_depth.png (and the gnuplot script and data beside them) into
// `dir`, marking each event. Runs `gnuplot`; an error names what failed.
Status plot_run(const std::filesystem::path& dir, const std::string& title, const PlotSeries& s,
                std::span<const RunEvent> events, std::vector<std::filesystem::path>* written);

}  // namespace palpate
