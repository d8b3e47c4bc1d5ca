// tool_tilt.h — the viewer's needle orientation from the mouse: a drag tilts the needle about its
// tip (the handle follows the pointer), and the 1 kHz feeder turns the device towards that
// orientation at a bounded rate. Plain math: no OpenGL, no window.
#pragma once

#include <palpate/core.h>

namespace palpate::view {

// The orientation after a drag of (dx, dy) pixels (x right, y down, as the window's) seen from a
// camera with image axes `right` and `up` (unit). The needle's handle, `handle` = −axis (unit,
// world), moves along the drag's image direction: the rotation vector is
// radians_per_pixel · handle × (dx·right − dy·up), applied in the world frame before `orientation`.
// The part of the drag along the handle (pointing at or away from the eye) turns nothing.
Quat tilt_by_drag(const Quat& orientation, const Vec3& handle, double dx, double dy, const Vec3& right,
                  const Vec3& up, double radians_per_pixel);

// One step of at most `max_angle` radians from `from` towards `to` along the shortest arc (slerp);
// `to` itself once within reach.
Quat turn_towards(const Quat& from, const Quat& to, double max_angle);

}  // namespace palpate::view
