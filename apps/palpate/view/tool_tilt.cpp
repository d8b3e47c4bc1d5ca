// tool_tilt.cpp — the viewer's needle tilt from a mouse drag, and the rate-limited turn towards it.
#include "tool_tilt.h"

#include <cmath>

namespace palpate::view {

Quat tilt_by_drag(const Quat& orientation, const Vec3& handle, double dx, double dy, const Vec3& right,
                  const Vec3& up, double radians_per_pixel) {
  const Vec3 drag = dx * right - dy * up;  // pixels, in the world's image plane
  const Vec3 rotation = radians_per_pixel * handle.cross(drag);
  const double angle = rotation.norm();
  if (!(angle > 0) || !std::isfinite(angle)) return orientation;
  return (Quat(Eigen::AngleAxisd(angle, rotation / angle)) * orientation).normalized();
}

Quat turn_towards(const Quat& from, const Quat& to, double max_angle) {
  const double angle = from.angularDistance(to);
  if (!(angle > max_angle)) return to;
  return from.slerp(max_angle / angle, to).normalized();
}

}  // namespace palpate::view
