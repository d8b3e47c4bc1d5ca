// run.cpp — run_scene: a headless run at a fixed tick, and its CSV and summary.json outputs.
#include <palpate/device.h>
#include <palpate/run.h>
#include <palpate/safety.h>
#include <palpate/tissue.h>

#include "io/plots.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <system_error>
#include <unistd.h>

namespace palpate {

Status write_file_atomic(const std::filesystem::path& file, const std::string& text) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (file.has_parent_path()) fs::create_directories(file.parent_path(), ec);
  if (ec) return Error{file.parent_path().string() + ": cannot create directory: " + ec.message()};
  const fs::path tmp = fs::path(file.string() + ".tmp." + std::to_string(::getpid()));
  {
    std::FILE* f = std::fopen(tmp.c_str(), "wb");
    if (!f) return Error{tmp.string() + ": cannot open for writing"};
    const size_t written = std::fwrite(text.data(), 1, text.size(), f);
    const bool flushed = std::fflush(f) == 0 && ::fsync(::fileno(f)) == 0;
    const bool closed = std::fclose(f) == 0;
    if (written != text.size() || !flushed || !closed) {
      fs::remove(tmp, ec);
      return Error{file.string() + ": write failed (disk full?)"};
    }
  }
  fs::rename(tmp, file, ec);
  if (ec) {
    fs::remove(tmp, ec);
    return Error{file.string() + ": cannot move the finished file into place: " + ec.message()};
  }
  return {};
}

namespace {

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(std::ceil(p * double(v.size())) - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

}  // namespace

Result<RunSummary> run_scene(const SceneDef& scene, const RunOptions& options) {
  std::vector<std::unique_ptr<Tissue>> tissues;
  for (int i = 0; i < static_cast<int>(scene.tissues.size()); ++i) {
    auto t = make_tissue(scene, i);
    if (!t) return t.error();
    tissues.push_back(std::move(*t));
  }
  return run_scene(scene, std::move(tissues), options);
}

Result<RunSummary> run_scene(const SceneDef& scene, std::vector<std::unique_ptr<Tissue>> tissues,
                             const RunOptions& options) {
  namespace fs = std::filesystem;
  using Clock = std::chrono::steady_clock;

  // --- build: everything that allocates or reads files happens here, before the first tick.
  auto device = make_device(scene);
  if (!device) return device.error();
  Device& dev = **device;
  ForceSafety safety(dev.limits(), scene.device.ramp_in);

  const double dt = scene.dt;
  const size_t ticks = static_cast<size_t>(std::llround(scene.duration / dt));

  std::vector<std::string> columns = {"t", "tool_x", "tool_y", "tool_z", "force_x", "force_y",
                                      "force_z", "force_N"};
  std::vector<size_t> figure_offset;
  for (const auto& t : tissues) {
    figure_offset.push_back(columns.size());
    for (const auto& f : t->figure_names()) columns.push_back(t->name() + "." + f);
  }
  const size_t ncol = columns.size();
  std::vector<double> rows(ticks * ncol);     // every tick's row, written after the run
  std::vector<double> step_time(ticks);       // s, wall time of each tick's work
  std::vector<TissueEvent> event_buf(64);
  std::vector<RunEvent> events;
  events.reserve(256);

  ToolState tool;
  tool.radius = scene.tool.radius;
  tool.needle = scene.tool.kind == "needle";
  tool.length = tool.needle ? scene.tool.length : 0.0;
  tool.axis = scene.tool.axis.normalized();
  DeviceState state;
  double max_force = 0;
  const size_t progress_every = std::max<size_t>(1, ticks / 100);

  // --- the fixed-tick loop: read device, step tissues, filter force, write device, record.
  for (size_t k = 0; k < ticks; ++k) {
    const double t = static_cast<double>(k + 1) * dt;
    const auto start = Clock::now();
    const bool read_ok = dev.read(t, state);
    tool.time = t;
    tool.tip = state.position;
    tool.velocity = state.velocity;
    tool.grasp = (state.buttons & 1u) != 0;
    Vec3 force = Vec3::Zero();
    for (auto& tissue : tissues) force += tissue->step(tool, dt);
    const Vec3 sent = safety.filter(force, dt, read_ok);
    dev.write(sent, Vec3::Zero());
    step_time[k] = std::chrono::duration<double>(Clock::now() - start).count();

    double* row = &rows[k * ncol];
    row[0] = t;
    row[1] = tool.tip.x(), row[2] = tool.tip.y(), row[3] = tool.tip.z();
    row[4] = sent.x(), row[5] = sent.y(), row[6] = sent.z(), row[7] = sent.norm();
    max_force = std::max(max_force, row[7]);
    for (size_t i = 0; i < tissues.size(); ++i) {
      const size_t nf = tissues[i]->figure_names().size();
      tissues[i]->figures(std::span<double>(row + figure_offset[i], nf));
      size_t n = 0;
      while ((n = tissues[i]->drain_events(event_buf)) > 0)
        for (size_t e = 0; e < n; ++e)
          events.push_back({event_buf[e].time, event_buf[e].kind, tissues[i]->name(),
                            event_buf[e].depth, event_buf[e].force});
    }
    if (options.progress && (k % progress_every == 0 || k + 1 == ticks))
      options.progress(double(k + 1) / double(ticks));
  }

  // --- outputs, each written atomically.
  const fs::path out = options.out.empty() ? scene.output : options.out;
  RunSummary summary;
  summary.ticks = ticks;
  summary.dt = dt;
  summary.step_median = percentile(step_time, 0.5);
  summary.step_p99 = percentile(step_time, 0.99);
  summary.step_max = step_time.empty() ? 0 : *std::max_element(step_time.begin(), step_time.end());
  summary.max_force = max_force;
  summary.events = events;
  summary.csv = out / "run.csv";
  summary.summary_json = out / "summary.json";

  std::string csv;
  csv.reserve(ticks * ncol * 14 + 256);
  for (size_t c = 0; c < ncol; ++c) csv += (c ? "," : "") + columns[c];
  csv += '\n';
  for (size_t k = 0; k < ticks; ++k) {
    for (size_t c = 0; c < ncol; ++c) {
      if (c) csv += ',';
      fmt::format_to(std::back_inserter(csv), "{:.9g}", rows[k * ncol + c]);
    }
    csv += '\n';
  }
  if (Status s = write_file_atomic(summary.csv, csv); !s) return s.error();

  size_t overruns = 0;
  for (double s : step_time) overruns += s > dt ? 1 : 0;
  const SafetyCounters& sc = safety.counters();
  nlohmann::json j;
  j["scene"] = scene.name;
  j["scene_file"] = scene.file.string();
  j["palpate_version"] = version();
  j["ticks"] = ticks;
  j["dt_s"] = dt;
  j["duration_s"] = double(ticks) * dt;
  j["step_time_s"] = {{"median", summary.step_median}, {"p99", summary.step_p99},
                      {"max", summary.step_max}, {"over_dt", overruns}};
  j["max_force_N"] = max_force;
  j["safety"] = {{"non_finite", sc.non_finite}, {"step_failed", sc.step_failed},
                 {"clamped", sc.clamped}, {"rate_limited", sc.rate_limited},
                 {"max_force_N", dev.limits().max_force}};
  j["tissues"] = nlohmann::json::array();
  for (const auto& t : tissues) j["tissues"].push_back(t->name());
  j["events"] = nlohmann::json::array();
  for (const RunEvent& e : events)
    j["events"].push_back({{"time_s", e.time}, {"kind", e.kind}, {"tissue", e.tissue},
                           {"depth_m", e.depth}, {"force_N", e.force}});
  // Plots of force against time and depth (a tool is always present in a scene).
  if (options.plots && ticks > 0) {
    PlotSeries ps;
    ps.time.resize(ticks), ps.depth.resize(ticks), ps.force.resize(ticks), ps.axial.resize(ticks);
    const Vec3 axis = scene.tool.axis.normalized();
    size_t contact = ticks;
    for (size_t k = 0; k < ticks && contact == ticks; ++k)
      if (rows[k * ncol + 7] > 1e-9) contact = k;
    const size_t ref = contact == ticks ? 0 : contact;
    const Vec3 tip0(rows[ref * ncol + 1], rows[ref * ncol + 2], rows[ref * ncol + 3]);
    for (size_t k = 0; k < ticks; ++k) {
      const double* row = &rows[k * ncol];
      ps.time[k] = row[0];
      ps.depth[k] = (Vec3(row[1], row[2], row[3]) - tip0).dot(axis);
      ps.force[k] = row[7];
      ps.axial[k] = -Vec3(row[4], row[5], row[6]).dot(axis);
    }
    if (Status st = plot_run(out, scene.name, ps, events, &summary.plots); !st)
      summary.plot_error = st.error().message;
  }
  j["outputs"] = {{"csv", summary.csv.filename().string()}};
  j["outputs"]["plots"] = nlohmann::json::array();
  for (const auto& p : summary.plots) j["outputs"]["plots"].push_back(p.filename().string());
  if (!summary.plot_error.empty()) j["outputs"]["plot_error"] = summary.plot_error;
  if (Status s = write_file_atomic(summary.summary_json, j.dump(2) + "\n"); !s) return s.error();
  return summary;
}

}  // namespace palpate
