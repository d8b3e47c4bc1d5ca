// report.cpp — report.html (palpate/report.h): the page, its metrics table, its SVG force plot, and
// the attempt a finished run gives.
#include <palpate/report.h>

#include <palpate/run.h>

#include "io/csv_rows.h"

#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>

namespace palpate {

std::string base64(std::string_view bytes) {
  static constexpr char kDigits[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const unsigned v = (unsigned(std::uint8_t(bytes[i])) << 16) | (unsigned(std::uint8_t(bytes[i + 1])) << 8) |
                       unsigned(std::uint8_t(bytes[i + 2]));
    out += kDigits[(v >> 18) & 63], out += kDigits[(v >> 12) & 63], out += kDigits[(v >> 6) & 63], out += kDigits[v & 63];
  }
  if (i + 1 == bytes.size()) {
    const unsigned v = unsigned(std::uint8_t(bytes[i])) << 16;
    out += kDigits[(v >> 18) & 63], out += kDigits[(v >> 12) & 63], out += "==";
  } else if (i + 2 == bytes.size()) {
    const unsigned v = (unsigned(std::uint8_t(bytes[i])) << 16) | (unsigned(std::uint8_t(bytes[i + 1])) << 8);
    out += kDigits[(v >> 18) & 63], out += kDigits[(v >> 12) & 63], out += kDigits[(v >> 6) & 63], out += '=';
  }
  return out;
}

namespace {

std::string seconds(double s) { return s >= 0 ? fmt::format("{:.1f} s", s) : "—"; }

// How many punctures of tissues whose name is one of `names`' (events carry the tissue's name).
int punctures_of(const ReportAttempt& a, const std::vector<std::string>& names) {
  return int(std::count_if(a.events.begin(), a.events.end(), [&](const RunEvent& e) {
    return e.kind == "puncture" && std::find(names.begin(), names.end(), e.tissue) != names.end();
  }));
}

}  // namespace

// The figures are C1's of ../shared/data/measurements/cvc_ultrasound_and_metrics.md, each quoted
// with its source; docs/cvc.md ("The report") lists them with how sure each one is.
std::vector<ReportCriterion> report_criteria(const ReportAttempt& a) {
  const TrainingMetrics& m = a.metrics;
  std::vector<ReportCriterion> c;
  c.push_back({"outcome", outcome_name(m.outcome), "the tip in the IJV's lumen: 76 % of physicians without needle guidance, 97 % with",
               "eZono phantom study, Anesthesiology 123(3):535, 2015", m.outcome == Outcome::vein ? 1 : -1});
  c.push_back({"skin punctures (insertion attempts)", std::to_string(m.skin_punctures),
               "1 (a mean of 1.13 attempts, cross-sectional view; 1.30 longitudinal)",
               "Griffiths et al., Crit Ultrasound J 9:9, 2017", m.skin_punctures == 1 ? 1 : -1});
  c.push_back({"needle passes", std::to_string(m.passes), "1: fewer passes after mastery training (p < .0005)",
               "Barsuk et al., Crit Care Med 37(10):2697, 2009", m.passes <= 1 ? 1 : -1});
  c.push_back({"redirections", std::to_string(m.redirections), "0: the long-axis view cut them (RR 0.4 at the IJ)",
               "Vogel et al., Crit Care Med 2015 (PMC4436655)", m.redirections == 0 ? 1 : -1});
  const bool back_wall = m.outcome == Outcome::posterior_wall || punctures_of(a, {"ijv", "vein"}) >= 2;
  c.push_back({"posterior wall punctured", back_wall ? "yes" : "no",
               "no: 49 % of physicians without guidance, 13 % with; 64 % of residents (short axis)",
               "eZono 2015; Blaivas & Adhikari, Crit Care Med 37(8):2345, 2009", back_wall ? -1 : 1});
  const bool artery = m.outcome == Outcome::artery || m.arterial_flashback;
  c.push_back({"carotid punctured", artery ? fmt::format("yes{}", m.arterial_flashback ? fmt::format(" (arterial flashback at {:.1f} s)", m.arterial_flashback_time) : "") : "no",
               "no: 21 % of physicians without guidance, 2 % with; 5.0–9.4 % of real IJ CVCs",
               "eZono 2015; Barsuk et al., J Hosp Med 2009 (C2)", artery ? -1 : 1});
  const bool timed = m.flashback && m.time_to_flashback >= 0;
  c.push_back({"skin puncture to flashback", timed ? seconds(m.time_to_flashback) : "no flashback",
               "≤ 45.1 s (phantom means: 45.1 s cross-sectional, 52.8 s longitudinal)",
               "Griffiths et al. 2017", timed ? (m.time_to_flashback <= 45.1 ? 1 : -1) : -1});
  c.push_back({"deepest tip below the skin", fmt::format("{:.1f} mm", 1e3 * m.deepest_depth), "", "", 0});
  c.push_back({"peak force", fmt::format("{:.2f} N", m.peak_force), fmt::format("the device's limit: {:.1f} N", a.max_force), "", 0});
  return c;
}

namespace {

const char* outcome_colour(Outcome o) {
  switch (o) {
    case Outcome::vein: return "#2e7d32";
    case Outcome::artery: return "#c62828";
    case Outcome::posterior_wall: return "#ef6c00";
    default: return "#546e7a";
  }
}

const char* event_colour(const std::string& kind) {
  if (kind == "puncture") return "#ef6c00";
  if (kind == "flashback") return "#2e7d32";
  if (kind == "arterial_flashback") return "#c62828";
  if (kind == "redirect") return "#6a1b9a";
  return "#78909c";
}

// The force over time: |F| (blue) and the probe's (grey) against the device's limit, the events as
// vertical lines labelled from the bottom up.
std::string force_svg(const ReportAttempt& a) {
  constexpr double W = 900, H = 300, L = 50, R = 10, T = 10, B = 30;
  const double t1 = a.duration > 0 ? a.duration : (a.force.empty() ? 1.0 : a.force.back()[0]);
  double top = 0.5;  // N, the smallest scale
  for (const auto& p : a.force) top = std::max(top, p[1]);
  for (const auto& p : a.probe_force) top = std::max(top, p[1]);
  top = std::ceil(top * 1.1 * 2) / 2;
  const auto X = [&](double t) { return L + (W - L - R) * std::clamp(t / t1, 0.0, 1.0); };
  const auto Y = [&](double f) { return T + (H - T - B) * (1 - std::clamp(f / top, 0.0, 1.0)); };
  std::string s = fmt::format(
      "<svg class=\"plot\" width=\"{0}\" height=\"{1}\" viewBox=\"0 0 {0} {1}\" "
      "role=\"img\" aria-label=\"force over time\">\n<rect x=\"{2}\" y=\"{3}\" width=\"{4}\" height=\"{5}\" fill=\"#fafafa\" stroke=\"#999\"/>\n",
      W, H, L, T, W - L - R, H - T - B);
  for (int k = 0; k <= 4; ++k) {  // the force axis
    const double f = top * k / 4;
    s += fmt::format("<line x1=\"{0}\" x2=\"{1}\" y1=\"{2:.1f}\" y2=\"{2:.1f}\" stroke=\"#e0e0e0\"/><text x=\"{3}\" y=\"{4:.1f}\" "
                     "font-size=\"11\" text-anchor=\"end\">{5:.2g} N</text>\n",
                     L, W - R, Y(f), L - 4, Y(f) + 4, f);
  }
  for (int k = 0; k <= 8; ++k) {  // the time axis
    const double t = t1 * k / 8;
    s += fmt::format("<text x=\"{:.1f}\" y=\"{}\" font-size=\"11\" text-anchor=\"middle\">{:.{}f} s</text>\n", X(t), H - 10, t,
                     t1 < 0.8 ? 3 : t1 < 8 ? 2 : 1);
  }
  // The events: a line each; labels stacked up from the bottom, so none covers a peak.
  int stack = 0;
  double last_x = -1e9;
  for (const RunEvent& e : a.events) {
    if (e.kind == "exit") continue;
    const double x = X(e.time);
    stack = x - last_x < 60 ? stack + 1 : 0;
    last_x = x;
    s += fmt::format("<line class=\"event\" x1=\"{0:.1f}\" x2=\"{0:.1f}\" y1=\"{1}\" y2=\"{2}\" stroke=\"{3}\" stroke-dasharray=\"4 3\"/>"
                     "<text x=\"{4:.1f}\" y=\"{5:.1f}\" font-size=\"10\" fill=\"{3}\">{6} {7}</text>\n",
                     x, T, H - B, event_colour(e.kind), x + 3, H - B - 6 - 12.0 * stack, markup_escape(e.kind), markup_escape(e.tissue));
  }
  const auto polyline = [&](const std::vector<std::array<double, 2>>& pts, const char* colour, const char* cls) {
    if (pts.empty()) return;
    s += fmt::format("<polyline class=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"2\" points=\"", cls, colour);
    for (const auto& p : pts) s += fmt::format("{:.1f},{:.1f} ", X(p[0]), Y(p[1]));
    s += "\"/>\n";
  };
  polyline(a.probe_force, "#9e9e9e", "probe-force");
  polyline(a.force, "#1f5fbf", "force");
  s += fmt::format("<text x=\"{}\" y=\"{}\" font-size=\"12\" fill=\"#1f5fbf\">|F| needle</text>", L + 8, T + 16);
  if (!a.probe_force.empty())
    s += fmt::format("<text x=\"{}\" y=\"{}\" font-size=\"12\" fill=\"#757575\">|F| probe</text>", L + 90, T + 16);
  s += "</svg>\n";
  return s;
}

std::string image_html(const ReportImage& img, const char* cls, int width) {
  return fmt::format("<figure class=\"{}\"><img alt=\"{}\" width=\"{}\" src=\"data:image/png;base64,{}\"><figcaption>{}</figcaption></figure>\n",
                     cls, markup_escape(img.caption), width, base64(img.png), markup_escape(img.caption));
}

std::string table_cell(const std::string& text) { return "<td>" + markup_escape(text) + "</td>"; }

}  // namespace

std::string report_html(std::span<const ReportAttempt> attempts) {
  std::string h;
  h += "<!doctype html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
       // Nothing from anywhere else: no script, no font, no image but the page's own data: URIs.
       "<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; img-src data:; style-src 'unsafe-inline'\">\n";
  const std::string title = attempts.empty() ? std::string("no attempt") : attempts.front().scene;
  h += "<title>palpate report: " + markup_escape(title) + "</title>\n";
  h += "<style>\nbody{font-family:sans-serif;margin:16px;color:#212121;background:#fff;max-width:960px}\n"
       "table{border-collapse:collapse;margin:8px 0}td,th{border:1px solid #bdbdbd;padding:3px 6px;font-size:13px;text-align:left}\n"
       "th{background:#eceff1}.met{background:#c8e6c9}.notmet{background:#ffcdd2}\n"
       ".outcome{color:#fff;padding:10px 14px;font-size:22px;font-weight:bold;margin:8px 0}\n"
       "figure{display:inline-block;margin:4px}figcaption{font-size:12px;color:#616161}\n"
       ".note{color:#795548;font-size:13px}\n</style>\n</head>\n<body>\n";
  h += "<h1>palpate: " + markup_escape(title) + "</h1>\n";
  h += fmt::format("<p>{} attempt{}. Metrics are judged against published figures ({}); "
                   "docs/cvc.md says how sure each one is.</p>\n",
                   attempts.size(), attempts.size() == 1 ? "" : "s",
                   "cvc_ultrasound_and_metrics.md, C1");
  // The attempts side by side.
  h += "<h2>Attempts</h2>\n<table class=\"attempts\"><tr><th>attempt</th><th>scene</th><th>outcome</th><th>skin punctures</th>"
       "<th>passes</th><th>redirections</th><th>to flashback</th><th>carotid</th><th>deepest</th><th>peak force</th><th>criteria met</th></tr>\n";
  for (const ReportAttempt& a : attempts) {
    const auto crit = report_criteria(a);
    const long met = std::count_if(crit.begin(), crit.end(), [](const ReportCriterion& c) { return c.verdict > 0; });
    const long judged = std::count_if(crit.begin(), crit.end(), [](const ReportCriterion& c) { return c.verdict != 0; });
    const TrainingMetrics& m = a.metrics;
    h += "<tr>" + table_cell(a.label) + table_cell(a.scene) +
         fmt::format("<td style=\"color:{}\"><b>{}</b></td>", outcome_colour(m.outcome), outcome_name(m.outcome)) +
         table_cell(std::to_string(m.skin_punctures)) + table_cell(std::to_string(m.passes)) +
         table_cell(std::to_string(m.redirections)) +
         table_cell(m.flashback && m.time_to_flashback >= 0 ? seconds(m.time_to_flashback) : "—") +
         table_cell(m.arterial_flashback || m.outcome == Outcome::artery ? "punctured" : "no") +
         table_cell(fmt::format("{:.1f} mm", 1e3 * m.deepest_depth)) + table_cell(fmt::format("{:.2f} N", m.peak_force)) +
         table_cell(fmt::format("{} of {}", met, judged)) + "</tr>\n";
  }
  h += "</table>\n";
  for (size_t i = 0; i < attempts.size(); ++i) {
    const ReportAttempt& a = attempts[i];
    h += fmt::format("<section class=\"attempt\" id=\"attempt-{}\">\n", i + 1);
    h += "<h2>" + markup_escape(a.label) + "</h2>\n";
    h += "<p>scene <b>" + markup_escape(a.scene) + "</b>" +
         (a.scene_file.empty() ? std::string() : " (" + markup_escape(a.scene_file) + ")") +
         fmt::format(", {:.1f} s</p>\n", a.duration);
    h += fmt::format("<div class=\"outcome\" style=\"background:{}\">outcome: {}</div>\n", outcome_colour(a.metrics.outcome),
                     outcome_name(a.metrics.outcome));
    h += "<table class=\"criteria\"><tr><th>metric</th><th>this attempt</th><th>judged against</th><th>source</th></tr>\n";
    for (const ReportCriterion& c : report_criteria(a))
      h += std::string("<tr class=\"") + (c.verdict > 0 ? "met" : c.verdict < 0 ? "notmet" : "info") + "\">" +
           table_cell(c.metric) + table_cell(c.value) + table_cell(c.reference) + table_cell(c.source) + "</tr>\n";
    h += "</table>\n<h3>Force</h3>\n" + force_svg(a);
    if (!a.events.empty()) {
      h += "<table class=\"events\"><tr><th>t (s)</th><th>event</th><th>tissue</th><th>depth (mm)</th><th>force (N)</th></tr>\n";
      for (const RunEvent& e : a.events)
        h += "<tr>" + table_cell(fmt::format("{:.3f}", e.time)) + table_cell(e.kind) + table_cell(e.tissue) +
             table_cell(fmt::format("{:.2f}", 1e3 * e.depth)) + table_cell(fmt::format("{:.3f}", e.force)) + "</tr>\n";
      h += "</table>\n";
    }
    if (a.ultrasound) h += "<h3>Ultrasound at the flashback</h3>\n" + image_html(*a.ultrasound, "ultrasound", 384);
    if (!a.frames.empty()) {
      h += "<h3>3-D frames</h3>\n";
      for (const ReportImage& f : a.frames) h += image_html(f, "frame", 300);
    }
    for (const std::string& n : a.notes) h += "<p class=\"note\">" + markup_escape(n) + "</p>\n";
    h += "</section>\n";
  }
  h += "<p class=\"note\">Written by palpate " + markup_escape(std::string(version())) + ".</p>\n</body>\n</html>\n";
  return h;
}

Status write_report_html(std::span<const ReportAttempt> attempts, const std::filesystem::path& file) {
  return write_file_atomic(file, report_html(attempts), /*create_directories=*/true);
}

namespace {

Result<std::string> read_bytes(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return Error{file.string() + ": cannot be read for the report"};
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

}  // namespace

std::vector<std::array<double, 2>> thin_trace(const std::vector<std::array<double, 2>>& pts, size_t most) {
  if (pts.size() <= most) return pts;
  std::vector<std::array<double, 2>> out;
  const size_t buckets = most / 2;
  for (size_t b = 0; b < buckets; ++b) {
    const size_t i0 = b * pts.size() / buckets, i1 = (b + 1) * pts.size() / buckets;
    if (i0 >= i1) continue;
    auto [lo, hi] = std::minmax_element(pts.begin() + std::ptrdiff_t(i0), pts.begin() + std::ptrdiff_t(i1),
                                        [](const auto& p, const auto& q) { return p[1] < q[1]; });
    if (lo - pts.begin() < hi - pts.begin()) out.push_back(*lo), out.push_back(*hi);
    else out.push_back(*hi), out.push_back(*lo);
  }
  return out;
}

namespace {

std::string folder_label(const std::filesystem::path& dir) {
  return dir.filename().empty() ? dir.parent_path().filename().string() : dir.filename().string();
}

// The traces from run.csv: t, force_N and, with a probe, probe_force_N.
Status read_force_traces(const std::filesystem::path& csv, ReportAttempt& a) {
  auto rows = io::CsvRows::open(csv, "run.csv");
  if (!rows) return rows.error();
  std::vector<std::string_view> f;
  if (!rows->next(f)) return Error{csv.string() + ": empty; expected run.csv's header"};
  int ct = -1, cf = -1, cp = -1;
  for (size_t i = 0; i < f.size(); ++i) {
    if (f[i] == "t") ct = int(i);
    if (f[i] == "force_N") cf = int(i);
    if (f[i] == "probe_force_N") cp = int(i);
  }
  if (ct < 0 || cf < 0) return Error{csv.string() + ":1: expected the columns t and force_N"};
  std::vector<std::array<double, 2>> force, probe;
  while (rows->next(f)) {
    double t = 0, v = 0, p = 0;
    if (size_t(std::max({ct, cf, cp})) >= f.size() || !io::csv_number(f[size_t(ct)], t) || !io::csv_number(f[size_t(cf)], v))
      return Error{rows->where() + "expected numbers in the columns t and force_N"};
    force.push_back({t, v});
    if (cp >= 0 && io::csv_number(f[size_t(cp)], p)) probe.push_back({t, p});
  }
  a.force = thin_trace(force, 4000);
  a.probe_force = thin_trace(probe, 4000);
  return {};
}

constexpr const char* kFlashbackImage = "flashback_us.png";

}  // namespace

bool outcome_from_name(std::string_view name, Outcome& out) noexcept {
  for (Outcome o : {Outcome::none, Outcome::vein, Outcome::posterior_wall, Outcome::artery, Outcome::outside_model})
    if (name == outcome_name(o)) {
      out = o;
      return true;
    }
  return false;
}

Result<ReportAttempt> run_report_attempt(const SceneDef& scene, const RunSummary& summary, const RunOptions& options) {
  namespace fs = std::filesystem;
  ReportAttempt a;
  const fs::path out = options.out.empty() ? scene.output : options.out;
  a.label = folder_label(out);
  a.scene = scene.name;
  a.scene_file = scene.file.string();
  a.duration = double(summary.ticks) * summary.dt;
  a.metrics = summary.metrics;
  a.events = summary.events;
  a.max_force = scene.device.max_force;
  if (Status s = read_force_traces(summary.csv, a); !s) return s.error();
  for (const RunFrame& fr : summary.frames) {
    auto png = read_bytes(fr.file);
    if (!png) return png.error();
    a.frames.push_back({fr.time, std::move(*png), fmt::format("t = {:.2f} s", fr.time)});
  }
  if (summary.frames.empty()) a.notes.push_back("No 3-D frames: run with --frames N (or --frame-times) to have them here.");
  // The ultrasound image at the flashback (the arterial one when that came first or alone).
  const TrainingMetrics& m = summary.metrics;
  const bool any = m.flashback || m.arterial_flashback;
  if (scene.probe && any) {
    const bool arterial = m.arterial_flashback && (!m.flashback || m.arterial_flashback_time < m.flashback_time);
    const double t = arterial ? m.arterial_flashback_time : m.flashback_time;
    if (summary.interrupted || options.realtime || scene.device.kind == "openhaptics" || scene.probe->device.kind == "openhaptics") {
      a.notes.push_back("No ultrasound image at the flashback: only a headless run of scripted or replayed tools is run again to draw it.");
    } else {
      // Headless runs are deterministic: the same scene, run again to the flashback's tick, is in
      // the same state there. Into a folder of its own beside the run's outputs, removed after.
      SceneDef again = scene;
      again.duration = t + 0.5 * scene.dt;
      RunOptions ro;
      ro.out = out / ".report-flashback";
      ro.cache = options.cache;
      ro.plots = false;
      ro.physics_dt = options.physics_dt;
      ro.ultrasound_times = {t};
      auto rerun = run_scene(again, ro);
      std::error_code ec;
      if (!rerun) {
        a.notes.push_back("No ultrasound image at the flashback: " + rerun.error().message);
      } else if (rerun->ultrasound.empty()) {
        a.notes.push_back("No ultrasound image at the flashback: " + rerun->ultrasound_error);
      } else {
        auto png = read_bytes(rerun->ultrasound.front().file);
        if (png) fs::copy_file(rerun->ultrasound.front().file, out / kFlashbackImage, fs::copy_options::overwrite_existing, ec);
        if (png)
          a.ultrasound = ReportImage{rerun->ultrasound.front().time, std::move(*png),
                                     fmt::format("{} at t = {:.3f} s: the needle's tip as the probe shows it",
                                                 arterial ? "arterial flashback" : "flashback", rerun->ultrasound.front().time)};
      }
      fs::remove_all(ro.out, ec);
    }
  } else if (scene.probe) {
    a.notes.push_back("No ultrasound image at the flashback: there was no flashback.");
  }
  if (!a.ultrasound) {
    std::error_code ec;
    fs::remove(out / kFlashbackImage, ec);  // not an earlier run's
  }
  return a;
}

Result<ReportAttempt> read_report_attempt(const std::filesystem::path& dir) {
  namespace fs = std::filesystem;
  const fs::path file = dir / "summary.json";
  std::ifstream in(file);
  if (!in) return Error{file.string() + ": cannot be read; expected a run's output folder (palpate run writes summary.json)"};
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const std::exception& e) {
    return Error{file.string() + ": not JSON: " + e.what()};
  }
  ReportAttempt a;
  a.label = folder_label(dir);
  try {
    a.scene = j.at("scene").get<std::string>();
    a.scene_file = j.value("scene_file", std::string());
    a.duration = j.at("duration_s").get<double>();
    const std::string outcome = j.at("outcome").get<std::string>();
    if (!outcome_from_name(outcome, a.metrics.outcome))
      return Error{file.string() + ": outcome: '" + outcome + "' is not one of none, vein, posterior_wall, artery, outside_model"};
    const auto& m = j.at("metrics");
    TrainingMetrics& t = a.metrics;
    t.skin_punctures = m.at("skin_punctures").get<int>();
    t.passes = m.at("passes").get<int>();
    t.redirections = m.at("redirections").get<int>();
    t.deepest_depth = m.at("deepest_depth_m").get<double>();
    t.peak_force = m.at("peak_force_N").get<double>();
    const auto time = [&](const char* key, bool& set, double& value) {
      set = m.contains(key) && m.at(key).is_number();
      if (set) value = m.at(key).get<double>();
    };
    bool first = false;
    time("flashback_s", t.flashback, t.flashback_time);
    time("arterial_flashback_s", t.arterial_flashback, t.arterial_flashback_time);
    time("first_skin_puncture_s", first, t.first_skin_puncture);
    bool timed = false;
    time("time_to_flashback_s", timed, t.time_to_flashback);
    if (!timed) t.time_to_flashback = -1;
    if (!first) t.first_skin_puncture = -1;
    for (const auto& e : j.at("events"))
      a.events.push_back({e.at("time_s").get<double>(), e.at("kind").get<std::string>(), e.at("tissue").get<std::string>(),
                          e.at("depth_m").get<double>(), e.at("force_N").get<double>()});
    if (j.contains("safety")) a.max_force = j.at("safety").value("max_force_N", a.max_force);
    const auto& outputs = j.at("outputs");
    const fs::path csv = dir / outputs.at("csv").get<std::string>();
    if (Status s = read_force_traces(csv, a); !s) return s.error();
    if (outputs.contains("frames"))
      for (const auto& f : outputs.at("frames")) {
        const double t_s = f.at("time_s").get<double>();
        auto png = read_bytes(dir / f.at("file").get<std::string>());
        if (!png) return png.error();
        a.frames.push_back({t_s, std::move(*png), fmt::format("t = {:.2f} s", t_s)});
      }
  } catch (const nlohmann::json::exception& e) {
    return Error{file.string() + ": " + e.what() + " (expected palpate run's summary.json)"};
  }
  if (fs::exists(dir / kFlashbackImage)) {
    auto png = read_bytes(dir / kFlashbackImage);
    if (!png) return png.error();
    const double t = a.metrics.flashback ? a.metrics.flashback_time : a.metrics.arterial_flashback_time;
    a.ultrasound = ReportImage{t, std::move(*png), fmt::format("flashback at t = {:.3f} s: the needle's tip as the probe shows it", t)};
  }
  if (a.frames.empty()) a.notes.push_back("No 3-D frames: the run had none (palpate run --frames N).");
  return a;
}

}  // namespace palpate
