// replay_device.cpp — the replay backend: a run's CSV read once, then played back tick for tick.
#include <palpate/device.h>

#include "io/csv_rows.h"
#include "io/text_lines.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <string_view>

namespace palpate {

Result<std::vector<RecordedSample>> load_recording_csv(const std::filesystem::path& file) {
  auto rows = io::CsvRows::open(file, "recording");
  if (!rows) return rows.error();
  std::vector<std::string_view> fields;
  // Header: find the columns by name.
  if (!rows->next(fields))
    return Error{file.string() + ": recording is empty (expected a header t,tool_x,tool_y,tool_z,...)"};
  std::vector<std::string> header(fields.begin(), fields.end());  // owned: the line is reused
  auto find = [&](std::string_view name) -> int {
    for (size_t i = 0; i < header.size(); ++i)
      if (header[i] == name) return int(i);
    return -1;
  };
  static constexpr std::array<const char*, 4> kNeeded = {"t", "tool_x", "tool_y", "tool_z"};
  std::array<int, 4> need{};
  for (size_t i = 0; i < kNeeded.size(); ++i) {
    need[i] = find(kNeeded[i]);
    if (need[i] < 0)
      return Error{rows->where() + "no column '" + kNeeded[i] +
                   "' in the header (a recording needs t, tool_x, tool_y, tool_z: a run's run.csv)"};
  }
  const std::array<int, 4> quat = {find("tool_qw"), find("tool_qx"), find("tool_qy"), find("tool_qz")};
  const bool has_quat = std::all_of(quat.begin(), quat.end(), [](int c) { return c >= 0; });
  const int buttons = find("buttons");

  std::vector<RecordedSample> samples;
  while (rows->next(fields)) {
    auto number = [&](int col, double& out) -> Status {
      if (col >= int(fields.size()))
        return Error{rows->where() + "row has " + std::to_string(fields.size()) + " fields, column '" +
                     header[size_t(col)] + "' is number " + std::to_string(col + 1)};
      const std::string_view text = fields[size_t(col)];
      if (!io::csv_number(text, out))
        return Error{rows->where() + "column '" + header[size_t(col)] + "': expected a number, got '" +
                     io::printable(text) + "'"};
      if (!std::isfinite(out))
        return Error{rows->where() + "column '" + header[size_t(col)] + "' is NaN or infinite"};
      return {};
    };
    RecordedSample s;
    double v[4];
    for (size_t i = 0; i < 4; ++i)
      if (Status st = number(need[i], v[i]); !st) return st.error();
    s.t = v[0];
    s.position = Vec3(v[1], v[2], v[3]);
    if (has_quat) {
      double q[4];
      for (size_t i = 0; i < 4; ++i)
        if (Status st = number(quat[i], q[i]); !st) return st.error();
      s.orientation = Quat(q[0], q[1], q[2], q[3]);
      if (s.orientation.norm() < 1e-9) return Error{rows->where() + "orientation quaternion is zero"};
      s.orientation.normalize();
    }
    if (buttons >= 0) {
      double b = 0;
      if (Status st = number(buttons, b); !st) return st.error();
      s.buttons = static_cast<std::uint32_t>(std::clamp(b, 0.0, 4294967295.0));
    }
    if (!samples.empty() && s.t < samples.back().t)
      return Error{rows->where() + "time " + fmt::format("{}", s.t) + " s goes back (previous " +
                   fmt::format("{}", samples.back().t) + " s)"};
    samples.push_back(s);
  }
  if (samples.empty()) return Error{file.string() + ": recording has a header but no rows"};
  return samples;
}

Result<std::vector<std::int32_t>> load_recording_counts(const std::filesystem::path& file, std::string_view column) {
  auto rows = io::CsvRows::open(file, "recording");
  if (!rows) return rows.error();
  std::vector<std::string_view> fields;
  std::vector<std::int32_t> counts;
  if (!rows->next(fields)) return Error{file.string() + ": recording is empty (expected a header t,tool_x,tool_y,tool_z,...)"};
  int col = -1, tick_col = -1;
  for (size_t i = 0; i < fields.size(); ++i) {
    if (fields[i] == column) col = int(i);
    if (fields[i] == "tick") tick_col = int(i);
  }
  if (col < 0) return counts;
  const std::string name(column);
  // A value read as a whole number in [0, 2^31): the recorder prints counts as integers ("12"), and
  // the {:.9g} of a figure column prints them so too (up to 9 digits).
  auto whole = [&](int c, const char* what, double& out) -> Status {
    if (c >= int(fields.size()))
      return Error{rows->where() + "row has " + std::to_string(fields.size()) + " fields, column '" + what +
                   "' is number " + std::to_string(c + 1)};
    const std::string_view text = fields[size_t(c)];
    if (!io::csv_number(text, out) || !(out >= 0) || out >= 2147483648.0 || out != std::floor(out))
      return Error{rows->where() + "column '" + what + "': expected a whole number >= 0, got '" + io::printable(text) + "'"};
    return {};
  };
  double last_tick = -1;
  while (rows->next(fields)) {
    double v = 0;
    if (Status st = whole(col, name.c_str(), v); !st) return st.error();
    const auto value = static_cast<std::int32_t>(v);
    if (!counts.empty() && value < counts.back())
      return Error{rows->where() + "column '" + name + "': " + std::to_string(value) + " is below the row before (" +
                   std::to_string(counts.back()) + "): what took effect is never taken back"};
    size_t at = counts.size();
    if (tick_col >= 0) {
      double tick = 0;
      if (Status st = whole(tick_col, "tick", tick); !st) return st.error();
      if (!(tick > last_tick))
        return Error{rows->where() + "column 'tick': " + fmt::format("{}", tick) + " does not follow tick " +
                     fmt::format("{}", last_tick) + " (a recording's ticks rise)"};
      if (tick >= double(counts.size()) + 1e7)  // a hole of hours: not a recording of this run
        return Error{rows->where() + "column 'tick': " + fmt::format("{}", tick) + " jumps from tick " +
                     fmt::format("{}", last_tick)};
      last_tick = tick;
      at = static_cast<size_t>(tick);
    }
    // Ticks the recorder dropped (a real-time run's full ring) hold the value before them: what
    // took effect during a hole is known only from the first row after it.
    const std::int32_t before = counts.empty() ? 0 : counts.back();
    counts.resize(at, before);
    counts.push_back(value);
  }
  return counts;
}

ReplayDevice::ReplayDevice(std::vector<RecordedSample> samples, DeviceLimits limits)
    : samples_(std::move(samples)), limits_(limits) {
  if (samples_.empty()) samples_.push_back(RecordedSample{});
}

bool ReplayDevice::read(double t, DeviceState& out) noexcept {
  // The last row at or before t; rows are ticks, so a half-tick tolerance absorbs the rounding
  // of the times printed in the CSV.
  const double tol = samples_.size() > 1 ? 0.5 * (samples_[1].t - samples_[0].t) : 0.0;
  if (row_ >= samples_.size() || samples_[row_].t > t + tol) row_ = 0;
  while (row_ + 1 < samples_.size() && samples_[row_ + 1].t <= t + tol) ++row_;
  const RecordedSample& s = samples_[row_];
  out.time = t;
  out.position = s.position;
  out.orientation = s.orientation;
  out.buttons = s.buttons;
  out.velocity.setZero();
  if (row_ > 0 && samples_[row_].t > t - tol) {  // moving: not held past the end
    const RecordedSample& p = samples_[row_ - 1];
    const double span = s.t - p.t;
    if (span > 0) out.velocity = (s.position - p.position) / span;
  }
  return true;
}

void ReplayDevice::write(const Vec3& force, const Vec3&) noexcept { last_force_ = force; }

}  // namespace palpate
