// trace.cpp — golden force traces: run a shipped scene for its trace, write and read trace files
// (gzip through zlib), compare two traces tick by tick.
#include "golden/trace.h"

#include <palpate/run.h>
#include <palpate/scene.h>

#include "tissue/spring/cpu.h"

#include <fmt/format.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <sstream>
#include <unistd.h>

namespace palpate::golden {

namespace {

constexpr const char* kMagic = "palpate golden trace 1";

struct GzCloser {
  void operator()(gzFile f) const { gzclose(f); }
};
using Gz = std::unique_ptr<std::remove_pointer_t<gzFile>, GzCloser>;

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::string cur;
  std::istringstream in(s);
  while (std::getline(in, cur, sep)) out.push_back(cur);
  return out;
}

bool is_force(const std::string& column) { return column.find("force") != std::string::npos; }

}  // namespace

std::string vector_path() {
  if (spring::has_avx512()) return "avx512";
  if (spring::has_avx2_fma()) return "avx2";
  return "scalar";
}

RunResult run_trace(const std::filesystem::path& scene_file, const std::function<void(SceneDef&)>& edit) {
  namespace fs = std::filesystem;
  RunResult r;
  auto scene = load_scene(scene_file);
  if (!scene) {
    r.error = scene.error().message;
    return r;
  }
  if (edit) edit(*scene);
  RunOptions o;
  o.out = fs::temp_directory_path() /
          fmt::format("palpate_golden_{}_{}", scene_file.stem().string(), ::getpid());
  o.plots = false;
  std::vector<std::vector<double>> cols;
  o.series_row = [&](std::span<const double> row) {
    if (cols.empty()) cols.resize(row.size());
    for (size_t c = 0; c < row.size() && c < cols.size(); ++c) cols[c].push_back(row[c]);
  };
  auto run = run_scene(*scene, o);
  std::error_code ec;
  fs::remove_all(o.out, ec);
  if (!run) {
    r.error = run.error().message;
    return r;
  }
  if (cols.size() != run->series_columns.size()) {
    r.error = fmt::format("{}: {} series columns named, {} recorded", scene_file.string(),
                          run->series_columns.size(), cols.size());
    return r;
  }
  r.trace.scene = scene_file.filename().string();
  r.trace.path = vector_path();
  r.trace.columns = run->series_columns;
  r.trace.values = std::move(cols);
  return r;
}

bool write_trace(const std::filesystem::path& file, const Trace& trace, std::string& error) {
  const std::string tmp = file.string() + ".tmp";
  Gz gz(gzopen(tmp.c_str(), "wb9"));
  if (!gz) {
    error = tmp + ": cannot open for writing";
    return false;
  }
  std::string header = std::string(kMagic) + "\nscene: " + trace.scene + "\npath: " + trace.path + "\ncolumns: ";
  for (size_t c = 0; c < trace.columns.size(); ++c) header += (c ? "," : "") + trace.columns[c];
  header += fmt::format("\nrows: {}\n\n", trace.rows());
  bool ok = gzwrite(gz.get(), header.data(), unsigned(header.size())) == int(header.size());
  std::vector<unsigned char> shuffled(trace.rows() * sizeof(double));
  for (const auto& col : trace.values) {
    if (!ok) break;
    const size_t n = col.size();
    for (size_t i = 0; i < n; ++i) {
      unsigned char b[sizeof(double)];
      std::memcpy(b, &col[i], sizeof(double));
      for (size_t k = 0; k < sizeof(double); ++k) shuffled[k * n + i] = b[k];
    }
    ok = gzwrite(gz.get(), shuffled.data(), unsigned(shuffled.size())) == int(shuffled.size());
  }
  ok = gzclose(gz.release()) == Z_OK && ok;
  if (!ok) {
    error = tmp + ": write failed";
    std::filesystem::remove(tmp);
    return false;
  }
  std::error_code ec;
  std::filesystem::rename(tmp, file, ec);
  if (ec) error = file.string() + ": " + ec.message();
  return !ec;
}

bool read_trace(const std::filesystem::path& file, Trace& trace, std::string& error) {
  Gz gz(gzopen(file.c_str(), "rb"));
  if (!gz) {
    error = file.string() + ": cannot open (record it with `make golden`)";
    return false;
  }
  trace = {};
  size_t rows = 0;
  bool have_rows = false;
  std::vector<char> line(1 << 16);
  for (int n = 1;; ++n) {
    if (!gzgets(gz.get(), line.data(), int(line.size()))) {
      error = fmt::format("{}:{}: the header ends before its empty line", file.string(), n);
      return false;
    }
    std::string s(line.data());
    if (s.empty() || s.back() != '\n') {
      error = fmt::format("{}:{}: a header line longer than {} bytes", file.string(), n, line.size());
      return false;
    }
    s.pop_back();
    if (n == 1) {
      if (s != kMagic) {
        error = fmt::format("{}:1: expected '{}', found '{}'", file.string(), kMagic, s);
        return false;
      }
      continue;
    }
    if (s.empty()) break;
    const size_t colon = s.find(": ");
    if (colon == std::string::npos) {
      error = fmt::format("{}:{}: expected 'key: value', found '{}'", file.string(), n, s);
      return false;
    }
    const std::string key = s.substr(0, colon), value = s.substr(colon + 2);
    if (key == "scene") trace.scene = value;
    else if (key == "path") trace.path = value;
    else if (key == "columns") trace.columns = split(value, ',');
    else if (key == "rows") {
      char* end = nullptr;
      rows = std::strtoull(value.c_str(), &end, 10);
      have_rows = end && *end == '\0' && !value.empty();
    }
  }
  if (!have_rows || trace.columns.empty()) {
    error = file.string() + ": the header needs 'columns' and 'rows'";
    return false;
  }
  std::vector<unsigned char> shuffled(rows * sizeof(double));
  for (const std::string& name : trace.columns) {
    if (gzread(gz.get(), shuffled.data(), unsigned(shuffled.size())) != int(shuffled.size())) {
      error = fmt::format("{}: column '{}' is cut short (expected {} values)", file.string(), name, rows);
      return false;
    }
    std::vector<double> col(rows);
    for (size_t i = 0; i < rows; ++i) {
      unsigned char b[sizeof(double)];
      for (size_t k = 0; k < sizeof(double); ++k) b[k] = shuffled[k * rows + i];
      std::memcpy(&col[i], b, sizeof(double));
    }
    trace.values.push_back(std::move(col));
  }
  unsigned char extra;
  if (gzread(gz.get(), &extra, 1) != 0) {
    error = file.string() + ": bytes after the last column";
    return false;
  }
  return true;
}

Differences largest_differences(const Trace& golden, const Trace& got) {
  Differences d;
  for (size_t c = 0; c < golden.columns.size() && c < got.columns.size(); ++c) {
    double& mx = is_force(golden.columns[c]) ? d.force : d.pose;
    for (size_t i = 0; i < golden.values[c].size() && i < got.values[c].size(); ++i) {
      const double a = golden.values[c][i], b = got.values[c][i];
      const double e = std::isnan(a) && std::isnan(b) ? 0.0 : std::abs(a - b);
      if (!(e <= mx)) mx = std::isnan(e) ? INFINITY : e;
    }
  }
  return d;
}

std::string compare(const Trace& golden, const Trace& got, const Tolerance& tol) {
  if (golden.columns != got.columns) {
    std::string g, o;
    for (const auto& c : golden.columns) g += c + " ";
    for (const auto& c : got.columns) o += c + " ";
    return "the columns differ: golden [" + g + "], this run [" + o + "]";
  }
  if (golden.rows() != got.rows())
    return fmt::format("golden has {} ticks, this run {}", golden.rows(), got.rows());
  size_t differ = 0, first_tick = 0, first_col = 0;
  for (size_t c = 0; c < golden.columns.size(); ++c) {
    const double limit = is_force(golden.columns[c]) ? tol.force : tol.pose;
    for (size_t i = 0; i < golden.rows(); ++i) {
      const double a = golden.values[c][i], b = got.values[c][i];
      const double d = std::isnan(a) && std::isnan(b) ? 0.0 : std::abs(a - b);
      if (!(d <= limit)) {
        if (differ == 0 || i < first_tick) first_tick = i, first_col = c;
        ++differ;
      }
    }
  }
  if (differ == 0) return "";
  const Differences largest = largest_differences(golden, got);
  const std::string& name = golden.columns[first_col];
  return fmt::format(
      "{} values differ beyond tolerance ({} N force, {} pose); first at tick {} (t = {} s), column {}: "
      "golden {:.17g}, this run {:.17g}; largest difference: force {:.3g} N, pose {:.3g}",
      differ, tol.force, tol.pose, first_tick, golden.values[0][first_tick], name,
      golden.values[first_col][first_tick], got.values[first_col][first_tick], largest.force, largest.pose);
}

}  // namespace palpate::golden
