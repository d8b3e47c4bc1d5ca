// yaml_read.h — internal to the scene parser (scene_yaml.cpp): where a message points (Ctx), and
// the generic readers of YAML values and of a mapping through a Def's parameter table, each
// refusing a wrong type, an out-of-range value or an unknown key with the file, line and key.
// Included by scene_yaml.cpp only (with yaml-cpp, which no other file includes).
#pragma once

#include "io/scene_params.h"

#include <palpate/scene.h>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <limits>
#include <locale.h>
#include <map>
#include <span>
#include <string>
#include <type_traits>
#include <unordered_set>
#include <variant>
#include <vector>

namespace palpate::scene_yaml {

namespace fs = std::filesystem;

// Thrown inside the parser only; parse_scene turns it into an Error.
struct ParseFailure {
  std::string message;
};

// Where messages point and what relative paths are resolved against.
struct Ctx {
  std::string name;   // the file as named in messages
  fs::path base_dir;  // "" = leave relative paths relative (to the working directory)

  // "FILE:LINE: PATH: WHAT"; line <= 0 leaves the line out, an empty path leaves it out.
  [[noreturn]] void fail(int line, const std::string& path, const std::string& what) const {
    std::string m = name;
    if (line > 0) m += ":" + std::to_string(line);
    m += ": ";
    if (!path.empty()) m += path + ": ";
    m += what;
    throw ParseFailure{m};
  }

  fs::path resolve(const fs::path& p) const {
    if (p.empty() || p.is_absolute() || base_dir.empty()) return p;
    return (base_dir / p).lexically_normal();
  }
};

// yaml-cpp's marks are 0-based; messages use 1-based lines. Nodes without a mark use `fallback`.
inline int line_of(const YAML::Node& n, int fallback) {
  const YAML::Mark m = n.Mark();
  return m.line >= 0 ? m.line + 1 : fallback;
}

inline std::string join(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}

inline std::string indexed(const std::string& path, size_t i) { return path + "[" + std::to_string(i) + "]"; }

// What a node holds, for "got ..." in messages.
inline std::string describe(const YAML::Node& n) {
  if (!n.IsDefined() || n.IsNull()) return "nothing";
  if (n.IsScalar()) return "'" + n.Scalar() + "'";
  if (n.IsSequence()) return "a list of " + std::to_string(n.size());
  return "a mapping";
}

inline std::string unit_note(const char* unit) {
  return (unit && *unit) ? std::string(" (") + unit + ")" : std::string();
}

// A large count or size for a message, two significant digits ("1.2e+08", "35").
inline std::string fmt_count(double x) { return fmt::format("{:.2g}", x); }

// A YAML number: decimal or exponent form, plus YAML's .inf/.nan spellings (rejected later as
// not finite, with their own message).
inline bool scalar_to_double(const std::string& s, double& x) {
  static const char* const nans[] = {".nan", ".NaN", ".NAN"};
  static const char* const infs[] = {".inf", ".Inf", ".INF", "+.inf", "+.Inf", "+.INF"};
  static const char* const ninfs[] = {"-.inf", "-.Inf", "-.INF"};
  for (const char* k : nans)
    if (s == k) return x = std::numeric_limits<double>::quiet_NaN(), true;
  for (const char* k : infs)
    if (s == k) return x = std::numeric_limits<double>::infinity(), true;
  for (const char* k : ninfs)
    if (s == k) return x = -std::numeric_limits<double>::infinity(), true;
  const char* b = s.data();
  const char* e = b + s.size();
  if (b != e && *b == '+') ++b;
  if (b == e) return false;
  const auto [end, ec] = std::from_chars(b, e, x);
  if (end != e) return false;
  // Out of double's range (1e400): strtod gives +-HUGE_VAL (rejected as not finite) or a tiny value;
  // in the C locale, so that a process's comma-decimal locale does not stop it at the '.'.
  if (ec == std::errc::result_out_of_range) {
    static const locale_t c_locale = ::newlocale(LC_ALL_MASK, "C", locale_t(nullptr));
    x = c_locale ? ::strtod_l(s.c_str(), nullptr, c_locale) : std::strtod(s.c_str(), nullptr);
  }
  return ec == std::errc() || ec == std::errc::result_out_of_range;
}

inline double read_number(const Ctx& c, const YAML::Node& v, const std::string& path, int line, double min,
                   double max, const char* unit) {
  double x = 0;
  if (!v.IsScalar() || !scalar_to_double(v.Scalar(), x))
    c.fail(line, path, "expected a number" + unit_note(unit) + ", got " + describe(v));
  if (!std::isfinite(x)) c.fail(line, path, "expected a finite number" + unit_note(unit) + ", got " + describe(v));
  if (x < min || x > max) {
    const std::string u = (unit && *unit) ? std::string(" ") + unit : std::string();
    c.fail(line, path, format_number(x) + u + " is out of range; expected " + range_text(min, max, unit));
  }
  return x;
}

inline int read_int(const Ctx& c, const YAML::Node& v, const std::string& path, int line, double min, double max,
             const char* unit) {
  long long x = 0;
  bool ok = v.IsScalar();
  if (ok) {
    const std::string& s = v.Scalar();
    const char* b = s.data();
    const char* e = b + s.size();
    if (b != e && *b == '+') ++b;
    const auto [end, ec] = std::from_chars(b, e, x);
    ok = b != e && ec == std::errc() && end == e;
  }
  if (!ok) c.fail(line, path, "expected an integer" + unit_note(unit) + ", got " + describe(v));
  if (static_cast<double>(x) < min || static_cast<double>(x) > max) {
    const std::string u = (unit && *unit) ? std::string(" ") + unit : std::string();
    c.fail(line, path, std::to_string(x) + u + " is out of range; expected an integer in " + range_text(min, max, unit));
  }
  return static_cast<int>(x);
}

inline bool read_bool(const Ctx& c, const YAML::Node& v, const std::string& path, int line) {
  if (v.IsScalar()) {
    static const char* const yes[] = {"true", "True", "TRUE", "yes", "Yes", "YES", "on", "On", "ON"};
    static const char* const no[] = {"false", "False", "FALSE", "no", "No", "NO", "off", "Off", "OFF"};
    for (const char* k : yes)
      if (v.Scalar() == k) return true;
    for (const char* k : no)
      if (v.Scalar() == k) return false;
  }
  c.fail(line, path, "expected true or false, got " + describe(v));
}

inline Vec3 read_vec3(const Ctx& c, const YAML::Node& v, const std::string& path, int line, double min, double max,
               const char* unit) {
  if (!v.IsSequence() || v.size() != 3)
    c.fail(line, path, "expected 3 numbers [x, y, z]" + unit_note(unit) + ", got " + describe(v));
  Vec3 out;
  for (size_t i = 0; i < 3; ++i) {
    const YAML::Node e = v[i];
    out[static_cast<Eigen::Index>(i)] = read_number(c, e, indexed(path, i), line_of(e, line), min, max, unit);
  }
  return out;
}

inline std::string read_string(const Ctx& c, const YAML::Node& v, const std::string& path, int line,
                        const char* choices) {
  if (!v.IsScalar()) {
    if (*choices) c.fail(line, path, "expected one of: " + choices_text(choices) + ", got " + describe(v));
    c.fail(line, path, "expected a string, got " + describe(v));
  }
  const std::string& s = v.Scalar();
  if (*choices) {
    std::string all = std::string("|") + choices + "|";
    if (s.empty() || s.find('|') != std::string::npos || all.find("|" + s + "|") == std::string::npos)
      c.fail(line, path, "'" + s + "' is not one of: " + choices_text(choices));
  }
  return s;
}

// Edit distance with transpositions (optimal string alignment), for "did you mean" on unknown
// keys: "widht" is one edit from "width".
inline size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::vector<size_t>> d(a.size() + 1, std::vector<size_t>(b.size() + 1));
  for (size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    for (size_t j = 1; j <= b.size(); ++j) {
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  }
  return d[a.size()][b.size()];
}

// The keys of one mapping that a table did not take (sections parsed by hand), and every key's line.
struct Keys {
  std::map<std::string, YAML::Node> sections;
  std::map<std::string, int> lines;
  int line_or(const std::string& key, int fallback) const {
    const auto it = lines.find(key);
    return it == lines.end() ? fallback : it->second;
  }
  // Line of a section's value; a null value's mark points past it, so it takes its key's line.
  int value_line(const std::string& key, int fallback) const {
    const auto it = sections.find(key);
    const int kline = line_or(key, fallback);
    return it == sections.end() || it->second.IsNull() ? kline : line_of(it->second, kline);
  }
};

// Read a mapping into `def` through its parameter table. `sections` are keys the caller parses;
// `other_hint(key)` may explain an unknown key (e.g. that it belongs to the other model's table).
template <class Def>
Keys read_table(const Ctx& c, const YAML::Node& map, const std::string& path, int line, const char* what,
                Def& def, std::span<const SectionKey> sections = {}, std::span<const char* const> required = {},
                const std::function<std::string(const std::string&)>& other_hint = {}) {
  if (!map.IsMap()) c.fail(line, path, std::string("expected a mapping of ") + what + " keys, got " + describe(map));
  const std::span<const Param<Def>> table = param_table(static_cast<const Def*>(nullptr));
  Keys keys;
  for (auto it = map.begin(); it != map.end(); ++it) {
    const YAML::Node k = it->first;
    const YAML::Node v = it->second;
    const int kline = line_of(k, line);
    if (!k.IsScalar()) c.fail(kline, path, "expected a key name, got " + describe(k));
    const std::string key = k.Scalar();
    const std::string kpath = join(path, key);
    if (const auto seen = keys.lines.find(key); seen != keys.lines.end())
      c.fail(kline, kpath, "duplicate key (first on line " + std::to_string(seen->second) + ")");
    keys.lines[key] = kline;
    // A null value (`key:` with nothing after it) carries the mark of whatever follows: use the key's line.
    const int vline = v.IsNull() ? kline : line_of(v, kline);

    const auto row = std::find_if(table.begin(), table.end(),
                                  [&](const Param<Def>& p) { return key == p.key; });
    if (row != table.end()) {
      const Param<Def>& p = *row;
      std::visit(
          [&](auto member) {
            auto& field = def.*member;
            using T = std::remove_cvref_t<decltype(field)>;
            if constexpr (std::is_same_v<T, double>) field = read_number(c, v, kpath, vline, p.min, p.max, p.unit);
            else if constexpr (std::is_same_v<T, int>) field = read_int(c, v, kpath, vline, p.min, p.max, p.unit);
            else if constexpr (std::is_same_v<T, bool>) field = read_bool(c, v, kpath, vline);
            else if constexpr (std::is_same_v<T, Vec3>) field = read_vec3(c, v, kpath, vline, p.min, p.max, p.unit);
            else if constexpr (std::is_same_v<T, std::string>) field = read_string(c, v, kpath, vline, p.choices);
            else field = c.resolve(fs::path(read_string(c, v, kpath, vline, "")));
          },
          p.field);
      continue;
    }
    const auto sec = std::find_if(sections.begin(), sections.end(),
                                  [&](const SectionKey& s) { return key == s.key; });
    if (sec != sections.end()) {
      keys.sections[key] = v;
      continue;
    }
    // Unknown: suggest the closest valid key when it is a likely typo, and list them all.
    std::vector<std::string> valid;
    for (const Param<Def>& p : table) valid.emplace_back(p.key);
    for (const SectionKey& s : sections) valid.emplace_back(s.key);
    std::string best;
    size_t best_d = std::numeric_limits<size_t>::max();
    for (const std::string& cand : valid) {
      const size_t d = edit_distance(key, cand);
      if (d < best_d) best_d = d, best = cand;
    }
    std::string msg = "unknown key";
    if (!best.empty() && best_d < key.size() && best_d <= std::max<size_t>(1, key.size() / 4)) msg += " (did you mean '" + best + "'?)";
    if (other_hint) {
      const std::string hint = other_hint(key);
      if (!hint.empty()) msg += "; " + hint;
    }
    msg += "; valid " + std::string(what) + " keys: ";
    for (size_t i = 0; i < valid.size(); ++i) msg += (i ? ", " : "") + valid[i];
    c.fail(kline, kpath, msg);
  }
  for (const char* r : required)
    if (!keys.lines.count(r)) c.fail(line, path, std::string("missing required key '") + r + "'");
  return keys;
}

// An input file a scene names must exist when the scene is loaded, not halfway through a run.
inline void require_file(const Ctx& c, const fs::path& p, int line, const std::string& path) {
  std::error_code ec;
  if (fs::exists(p, ec) && !fs::is_regular_file(p, ec))  // a directory, FIFO, /dev/zero: say what it is
    c.fail(line, path, check_regular_file(p, "a regular file").error().message);
  if (!fs::is_regular_file(p, ec))
    c.fail(line, path, "file not found: " + p.string() +
                           (c.base_dir.empty() ? std::string() : " (relative paths are resolved against " +
                                                                       c.base_dir.string() + ")"));
}

}  // namespace palpate::scene_yaml
