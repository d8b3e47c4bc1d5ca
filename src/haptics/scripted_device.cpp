// scripted_device.cpp — the scripted backend: timed waypoints or a CSV trajectory, interpolated
// (positions linearly, needle orientations by slerp).
#include <palpate/device.h>

#include "io/csv_rows.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <cstdlib>
#include <locale>
#include <sstream>

namespace palpate {

namespace {
std::string fmt_number(double x) {
  std::ostringstream ss;
  ss.imbue(std::locale::classic());  // "0.5", whatever the process's locale
  ss << x;
  return ss.str();
}
}  // namespace

Quat orientation_towards(const Vec3& tool_axis, const Vec3& direction) {
  return Quat::FromTwoVectors(tool_axis, direction).normalized();
}

ScriptedDevice::ScriptedDevice(std::vector<Waypoint> waypoints, DeviceLimits limits, const Vec3& tool_axis)
    : waypoints_(std::move(waypoints)), limits_(limits) {
  if (waypoints_.empty()) waypoints_.push_back(Waypoint{});
  // Each waypoint's orientation, once: the read path only slerps between two of them.
  const bool axis_ok = tool_axis.allFinite() && tool_axis.norm() > 0;
  Quat q = Quat::Identity();
  orientations_.reserve(waypoints_.size());
  for (const Waypoint& w : waypoints_) {
    if (axis_ok && w.direction.allFinite() && w.direction.norm() > 0)
      q = orientation_towards(tool_axis, w.direction);
    orientations_.push_back(q);
  }
}

bool ScriptedDevice::read(double t, DeviceState& out) noexcept {
  const size_t n = waypoints_.size();
  out.time = t;
  out.buttons = 0;
  if (n == 1 || t <= waypoints_.front().t) {
    out.position = waypoints_.front().position;
    out.orientation = orientations_.front();
    out.velocity.setZero();
    out.buttons = waypoints_.front().grasp ? 1u : 0u;
    return true;
  }
  if (t >= waypoints_.back().t) {
    out.position = waypoints_.back().position;
    out.orientation = orientations_.back();
    out.velocity.setZero();
    out.buttons = waypoints_.back().grasp ? 1u : 0u;
    return true;
  }
  // The segment (a, b] that holds t: at a waypoint's own time, the segment that ends there, so the
  // velocity is the motion that brought the tool to it — where an advance turns into a withdrawal,
  // the tick at the waypoint still advances (the shaft's friction reverses on the next tick, not
  // one early). Ticks move forward, so the cached segment is almost always right; rewind if time
  // went back.
  if (segment_ >= n - 1 || waypoints_[segment_].t >= t) segment_ = 0;
  while (segment_ + 1 < n - 1 && waypoints_[segment_ + 1].t < t) ++segment_;
  const Waypoint& a = waypoints_[segment_];
  const Waypoint& b = waypoints_[segment_ + 1];
  const double span = b.t - a.t;
  const double s = span > 0 ? (t - a.t) / span : 1.0;
  out.buttons = a.grasp ? 1u : 0u;  // the jaws as the segment's first waypoint set them
  const Quat& qa = orientations_[segment_];
  const Quat& qb = orientations_[segment_ + 1];
  if (t == b.t) {  // at the waypoint: exactly its position and orientation
    out.position = b.position;
    out.orientation = qb;
  } else {
    out.position = a.position + s * (b.position - a.position);
    // Equal ends (every waypoint without a direction): exactly that orientation, no round-off.
    out.orientation = qa.coeffs() == qb.coeffs() ? qa : qa.slerp(s, qb);
  }
  out.velocity = span > 0 ? Vec3((b.position - a.position) / span) : Vec3::Zero();
  return true;
}

void ScriptedDevice::write(const Vec3& force, const Vec3&) noexcept { last_force_ = force; }

Result<std::vector<Waypoint>> load_trajectory_csv(const std::filesystem::path& file) {
  auto rows = io::CsvRows::open(file, "trajectory file");
  if (!rows) return rows.error();
  std::vector<Waypoint> points;
  std::vector<std::string_view> fields;
  bool header_allowed = true;
  // Fields at commas or blanks; the numbers are the leading fields (std::from_chars: "nan" and
  // "inf" are read, then refused by name).
  while (rows->next(fields, /*whitespace_too=*/true)) {
    const auto where = [&] { return rows->where(); };
    double v[8];
    size_t n = 0;
    while (n < 8 && n < fields.size() && io::csv_number(fields[n], v[n])) ++n;
    const bool first = header_allowed;
    header_allowed = false;
    if (n == 0 && first) continue;  // a header line such as "t,x,y,z"
    if (n < fields.size() && n >= 4) {
      std::string rest;
      for (size_t i = n; i < fields.size(); ++i) {
        if (i > n) rest += ' ';
        rest += fields[i];
      }
      return Error{where() + "unexpected '" + rest + "' after the numbers; expected t,x,y,z or t,x,y,z,dx,dy,dz"};
    }
    if (n != 4 && n != 7)
      return Error{where() + "expected four numbers t,x,y,z (s, m, m, m) or seven t,x,y,z,dx,dy,dz "
                             "(a needle direction), got " + std::to_string(n) +
                   (n == 8 ? " or more" : "")};
    Waypoint w{v[0], Vec3(v[1], v[2], v[3])};
    if (!std::isfinite(w.t) || !w.position.allFinite())
      return Error{where() + "value is NaN or infinite"};
    if (n == 7) {
      const Vec3 d(v[4], v[5], v[6]);
      if (!d.allFinite()) return Error{where() + "direction dx,dy,dz is NaN or infinite"};
      if (!(d.norm() > 1e-9))
        return Error{where() + "direction dx,dy,dz is zero; expected a non-zero vector (it is normalised)"};
      w.direction = d.normalized();
    }
    if (!points.empty() && w.t < points.back().t)
      return Error{where() + "time " + fmt_number(w.t) + " s goes back (previous " +
                   fmt_number(points.back().t) + " s)"};
    points.push_back(w);
  }
  if (points.empty())
    return Error{file.string() + ": trajectory has no rows (expected t,x,y,z or t,x,y,z,dx,dy,dz)"};
  return points;
}

}  // namespace palpate
