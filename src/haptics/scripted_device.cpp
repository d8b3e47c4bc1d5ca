// scripted_device.cpp — the scripted backend: timed waypoints or a CSV trajectory, interpolated.
#include <palpate/device.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <cstdlib>
#include <sstream>

namespace palpate {

namespace {
std::string fmt_number(double x) {
  std::ostringstream ss;
  ss << x;
  return ss.str();
}
}  // namespace

ScriptedDevice::ScriptedDevice(std::vector<Waypoint> waypoints, DeviceLimits limits)
    : waypoints_(std::move(waypoints)), limits_(limits) {
  if (waypoints_.empty()) waypoints_.push_back(Waypoint{});
}

bool ScriptedDevice::read(double t, DeviceState& out) noexcept {
  const size_t n = waypoints_.size();
  out.time = t;
  out.orientation = Quat::Identity();
  out.buttons = 0;
  if (n == 1 || t <= waypoints_.front().t) {
    out.position = waypoints_.front().position;
    out.velocity.setZero();
    return true;
  }
  if (t >= waypoints_.back().t) {
    out.position = waypoints_.back().position;
    out.velocity.setZero();
    return true;
  }
  // Ticks move forward, so the cached segment is almost always right; rewind if time went back.
  if (segment_ >= n - 1 || waypoints_[segment_].t > t) segment_ = 0;
  while (segment_ + 1 < n - 1 && waypoints_[segment_ + 1].t <= t) ++segment_;
  const Waypoint& a = waypoints_[segment_];
  const Waypoint& b = waypoints_[segment_ + 1];
  const double span = b.t - a.t;
  const double s = span > 0 ? (t - a.t) / span : 1.0;
  out.position = a.position + s * (b.position - a.position);
  out.velocity = span > 0 ? Vec3((b.position - a.position) / span) : Vec3::Zero();
  return true;
}

void ScriptedDevice::write(const Vec3& force, const Vec3&) noexcept { last_force_ = force; }

Result<std::vector<Waypoint>> load_trajectory_csv(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) return Error{file.string() + ": cannot open trajectory file"};
  std::vector<Waypoint> points;
  std::string line;
  int lineno = 0;
  bool header_allowed = true;
  while (std::getline(in, line)) {
    ++lineno;
    if (line.empty() || line[0] == '#') continue;
    std::replace(line.begin(), line.end(), ',', ' ');
    // strtod, not >>: it reads "nan" and "inf", which are then refused by name.
    double v[4];
    int n = 0;
    const char* p = line.c_str();
    for (; n < 4; ++n) {
      char* end = nullptr;
      v[n] = std::strtod(p, &end);
      if (end == p) break;
      p = end;
    }
    const bool first = header_allowed;
    header_allowed = false;
    if (n == 0 && first) continue;  // a header line such as "t,x,y,z"
    if (n < 4)
      return Error{file.string() + ":" + std::to_string(lineno) +
                   ": expected four numbers t,x,y,z (s, m, m, m)"};
    Waypoint w{v[0], Vec3(v[1], v[2], v[3])};
    if (!std::isfinite(w.t) || !w.position.allFinite())
      return Error{file.string() + ":" + std::to_string(lineno) + ": value is NaN or infinite"};
    if (!points.empty() && w.t < points.back().t)
      return Error{file.string() + ":" + std::to_string(lineno) + ": time " + fmt_number(w.t) +
                   " s goes back (previous " + fmt_number(points.back().t) + " s)"};
    points.push_back(w);
  }
  if (points.empty()) return Error{file.string() + ": trajectory has no rows (expected t,x,y,z)"};
  return points;
}

}  // namespace palpate
