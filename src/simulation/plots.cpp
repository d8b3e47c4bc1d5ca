// plots.cpp — gnuplot-drawn PNG plots of force against time and depth, with events marked.
#include "simulation/plots.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <fstream>
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

// Whether `file` is a whole PNG: the signature first and the IEND chunk last. gnuplot may exit 0
// on a full disk, leaving a PNG of 0 bytes or one cut short: such a file is never put in place.
bool whole_png(const std::filesystem::path& file, std::string& why) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return why = "missing", false;
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  static constexpr unsigned char kSig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  static constexpr unsigned char kEnd[12] = {0, 0, 0, 0, 'I', 'E', 'N', 'D', 0xae, 0x42, 0x60, 0x82};
  if (size < std::streamoff(sizeof kSig + sizeof kEnd)) return why = fmt::format("{} bytes", size), false;
  unsigned char head[8], tail[12];
  in.seekg(0);
  in.read(reinterpret_cast<char*>(head), sizeof head);
  in.seekg(size - std::streamoff(sizeof tail));
  in.read(reinterpret_cast<char*>(tail), sizeof tail);
  if (!in || std::memcmp(head, kSig, sizeof kSig) != 0) return why = "not a PNG", false;
  if (std::memcmp(tail, kEnd, sizeof kEnd) != 0)
    return why = fmt::format("{} bytes without the PNG's end chunk (IEND)", size), false;
  return true;
}

}  // namespace

PlotSeriesBuilder::PlotSeriesBuilder(std::uint64_t ticks) {
  if (ticks > kMaxRows) stride_ = (ticks + kMaxRows / 4 - 1) / (kMaxRows / 4);  // ≤ 4 rows a block
  const std::uint64_t rows = stride_ == 1 ? ticks : 4 * ((ticks + stride_ - 1) / stride_);
  for (auto* v : {&out_.time, &out_.depth, &out_.force, &out_.axial}) v->reserve(static_cast<size_t>(rows));
}

void PlotSeriesBuilder::add(double time, double depth, double force, double axial, double probe) {
  const Row r{time, depth, force, axial, probe, seen_++};
  if (stride_ == 1) {
    out_.time.push_back(time), out_.depth.push_back(depth), out_.force.push_back(force), out_.axial.push_back(axial);
    if (!std::isnan(probe)) out_.probe.push_back(probe);
    return;
  }
  if (in_block_ == 0) lo_f_ = hi_f_ = lo_a_ = hi_a_ = r;
  if (force < lo_f_.force) lo_f_ = r;
  if (force > hi_f_.force) hi_f_ = r;
  if (axial < lo_a_.axial) lo_a_ = r;
  if (axial > hi_a_.axial) hi_a_ = r;
  if (++in_block_ == stride_) flush();
}

void PlotSeriesBuilder::flush() {
  if (in_block_ == 0) return;
  Row rows[4] = {lo_f_, hi_f_, lo_a_, hi_a_};
  std::sort(std::begin(rows), std::end(rows), [](const Row& a, const Row& b) { return a.k < b.k; });
  for (int i = 0; i < 4; ++i) {
    if (i > 0 && rows[i].k == rows[i - 1].k) continue;
    out_.time.push_back(rows[i].time), out_.depth.push_back(rows[i].depth);
    out_.force.push_back(rows[i].force), out_.axial.push_back(rows[i].axial);
    if (!std::isnan(rows[i].probe)) out_.probe.push_back(rows[i].probe);
  }
  in_block_ = 0;
}

PlotSeries PlotSeriesBuilder::finish() {
  flush();
  return std::move(out_);
}

Status plot_run(const std::filesystem::path& dir, const std::string& title, const PlotSeries& s,
                std::span<const RunEvent> events, std::vector<std::filesystem::path>* written) {
  const auto data = dir / "force.dat";
  const bool probe = !s.probe.empty() && s.probe.size() == s.time.size();
  std::string text = probe ? "# time_s depth_mm force_N axial_N probe_force_N\n" : "# time_s depth_mm force_N axial_N\n";
  for (size_t i = 0; i < s.time.size(); ++i) {
    fmt::format_to(std::back_inserter(text), "{:.6f} {:.6f} {:.6f} {:.6f}", s.time[i], s.depth[i] * 1e3, s.force[i],
                   s.axial[i]);
    if (probe) fmt::format_to(std::back_inserter(text), " {:.6f}", s.probe[i]);
    text += '\n';
  }
  if (Status st = write_file_atomic(data, text); !st) return st;

  std::string gp;
  gp += "set terminal pngcairo size 900,540 enhanced font 'sans,11'\n";
  gp += "set grid\nset key top right noenhanced\n";
  gp += fmt::format("data = {}\n", quote(data.string()));
  // Events: a dashed vertical line and a label each. Events closer in time than 1 % of the run
  // (skin and fat giving on one tick, a vein's puncture and its flashback) share one line and one
  // label, so the labels do not print over each other; a flashback's line is green, a redirection's
  // (a new pass under the skin) violet. A label reads
  // up from the bottom of the plot: a puncture's peak is at the top, where the label used to be.
  std::string marks_t, marks_d;
  const double span = s.time.size() > 1 ? s.time.back() - s.time.front() : 0.0;
  int n = 1;
  for (size_t i = 0; i < events.size();) {
    const double t = events[i].time;
    std::string names;
    bool flashback = false, arterial = false, redirect = true;
    size_t j = i;
    for (; j < events.size() && events[j].time - t <= 0.01 * span; ++j) {
      names += (j > i ? ", " : "") + events[j].kind + (events[j].kind == "redirect" ? "" : " " + events[j].tissue);
      flashback = flashback || events[j].kind == "flashback";
      arterial = arterial || events[j].kind == "arterial_flashback";
      redirect = redirect && events[j].kind == "redirect";
    }
    i = j;
    const std::string label = quote(names);
    const char* colour = arterial ? "#ff0000" : flashback ? "#208040" : redirect ? "#6040c0" : "#c03030";
    marks_t += fmt::format(
        "set arrow {} from {:.6f}, graph 0 to {:.6f}, graph 1 nohead dt 2 lc rgb '{}'\n"
        "set label {} {} at {:.6f}, graph 0.03 rotate by 90 left noenhanced font ',9' tc rgb '{}'\n",
        n, t, t, colour, n, label, t, colour);
    const double d = depth_at(s, t) * 1e3;
    marks_d += fmt::format(
        "set arrow {} from {:.6f}, graph 0 to {:.6f}, graph 1 nohead dt 2 lc rgb '{}'\n"
        "set label {} {} at {:.6f}, graph 0.03 rotate by 90 left noenhanced font ',9' tc rgb '{}'\n",
        n, d, d, colour, n, label, d, colour);
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
        "     data using 1:4 with lines lw 1 lc rgb '#50a050' title 'F against the tool axis'";
  if (probe) gp += ", \\\n     data using 1:5 with lines lw 1 lc rgb '#e08020' title '|F| sent to the probe (the other hand)'";
  gp += "\n";
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
  std::error_code ec;
  auto remove_parts = [&] {
    for (const auto& png : {png_t, png_d}) std::filesystem::remove(png.string() + ".part", ec);
  };
  if (rc != 0 || !WIFEXITED(rc) || WEXITSTATUS(rc) != 0) {
    remove_parts();
    return Error{fmt::format("gnuplot failed on {} (exit {}); see {} — is gnuplot installed? "
                             "(scripts/install-deps installs it)",
                             script.string(), WIFEXITED(rc) ? WEXITSTATUS(rc) : -1,
                             (dir / "plots.log").string())};
  }
  for (const auto& png : {png_t, png_d}) {
    std::string why;
    if (!whole_png(png.string() + ".part", why)) {
      remove_parts();
      return Error{fmt::format("{}: gnuplot exited 0 but wrote {} (disk full?); no plots written; see {}",
                               png.string(), why, (dir / "plots.log").string())};
    }
  }
  std::filesystem::rename(png_t.string() + ".part", png_t, ec);
  if (!ec) std::filesystem::rename(png_d.string() + ".part", png_d, ec);
  if (ec) return Error{dir.string() + ": cannot move finished plots into place: " + ec.message()};
  std::filesystem::remove(dir / "plots.log", ec);
  if (written) *written = {png_t, png_d};
  return {};
}

}  // namespace palpate
