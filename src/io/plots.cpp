// plots.cpp — gnuplot-drawn PNG plots of force against time and depth, with events marked.
#include "io/plots.h"

#include <fmt/format.h>

#include <cstdlib>
#include <sys/wait.h>

namespace palpate {

namespace {

std::string quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += (c == '\'') ? std::string("''") : std::string(1, c);
  return q + "'";
}

// Depth at time t, by the sample nearest in time (events come from the same ticks).
double depth_at(const PlotSeries& s, double t) {
  size_t best = 0;
  for (size_t i = 0; i < s.time.size(); ++i)
    if (std::abs(s.time[i] - t) < std::abs(s.time[best] - t)) best = i;
  return s.depth.empty() ? 0.0 : s.depth[best];
}

std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += (c == '\'') ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

}  // namespace

Status plot_run(const std::filesystem::path& dir, const std::string& title, const PlotSeries& s,
                std::span<const RunEvent> events, std::vector<std::filesystem::path>* written) {
  const auto data = dir / "force.dat";
  std::string text = "# time_s depth_mm force_N axial_N\n";
  for (size_t i = 0; i < s.time.size(); ++i)
    fmt::format_to(std::back_inserter(text), "{:.6f} {:.6f} {:.6f} {:.6f}\n", s.time[i],
                   s.depth[i] * 1e3, s.force[i], s.axial[i]);
  if (Status st = write_file_atomic(data, text); !st) return st;

  std::string gp;
  gp += "set terminal pngcairo size 900,540 enhanced font 'sans,11'\n";
  gp += "set grid\nset key top left noenhanced\n";
  gp += fmt::format("data = {}\n", quote(data.string()));
  // Events: a dashed vertical line and a label each.
  std::string marks_t, marks_d;
  int n = 1;
  for (const RunEvent& e : events) {
    const std::string label = quote(e.kind + " " + e.tissue);
    marks_t += fmt::format(
        "set arrow {} from {:.6f}, graph 0 to {:.6f}, graph 1 nohead dt 2 lc rgb '#c03030'\n"
        "set label {} {} at {:.6f}, graph 0.95 rotate by 90 right noenhanced font ',9' tc rgb '#c03030'\n",
        n, e.time, e.time, n, label, e.time);
    const double d = depth_at(s, e.time) * 1e3;
    marks_d += fmt::format(
        "set arrow {} from {:.6f}, graph 0 to {:.6f}, graph 1 nohead dt 2 lc rgb '#c03030'\n"
        "set label {} {} at {:.6f}, graph 0.95 rotate by 90 right noenhanced font ',9' tc rgb '#c03030'\n",
        n, d, d, n, label, d);
    ++n;
  }
  const auto png_t = dir / "force_time.png";
  const auto png_d = dir / "force_depth.png";
  gp += fmt::format("set output {}\n", quote(png_t.string() + ".part"));
  gp += fmt::format("set title {}\n", quote(title + ": force against time"));
  gp += "set title noenhanced\n";
  gp += "set xlabel 'time (s)'\nset ylabel 'force (N)'\n";
  gp += marks_t;
  gp += "plot data using 1:3 with lines lw 2 lc rgb '#1f5fa0' title '|F| sent to the device', \\\n"
        "     data using 1:4 with lines lw 1 lc rgb '#50a050' title 'F against the tool axis'\n";
  gp += "unset arrow\nunset label\n";
  gp += fmt::format("set output {}\n", quote(png_d.string() + ".part"));
  gp += fmt::format("set title {}\n", quote(title + ": force against depth"));
  gp += "set title noenhanced\n";
  gp += "set xlabel 'depth past first contact, along the tool (mm)'\nset ylabel 'force (N)'\n";
  gp += marks_d;
  gp += "plot data using 2:3 with lines lw 2 lc rgb '#1f5fa0' title '|F| sent to the device'\n";
  gp += "set output\n";
  const auto script = dir / "plots.gp";
  if (Status st = write_file_atomic(script, gp); !st) return st;

  const std::string cmd =
      "gnuplot " + shell_quote(script.string()) + " 2>" + shell_quote((dir / "plots.log").string());
  const int rc = std::system(cmd.c_str());
  if (rc != 0 || !WIFEXITED(rc) || WEXITSTATUS(rc) != 0)
    return Error{fmt::format("gnuplot failed on {} (exit {}); see {} — is gnuplot installed? "
                             "(scripts/install-deps installs it)",
                             script.string(), WIFEXITED(rc) ? WEXITSTATUS(rc) : -1,
                             (dir / "plots.log").string())};
  std::error_code ec;
  std::filesystem::rename(png_t.string() + ".part", png_t, ec);
  if (!ec) std::filesystem::rename(png_d.string() + ".part", png_d, ec);
  if (ec) return Error{dir.string() + ": cannot move finished plots into place: " + ec.message()};
  std::filesystem::remove(dir / "plots.log", ec);
  if (written) *written = {png_t, png_d};
  return {};
}

}  // namespace palpate
