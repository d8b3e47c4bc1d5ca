// camera.h — the viewer's orbit camera (orbit, pan, zoom about a target), its matrices, the ray
// under a pixel, and ray picking against triangles. Plain math: no OpenGL, no window.
#pragma once

#include <palpate/core.h>
#include <palpate/scene_def.h>

#include <cstdint>
#include <optional>
#include <span>

namespace palpate::view {

// A perspective camera looking at `target` from `distance` away, at `yaw` about +y (0 looks
// along −z, from +z) and `pitch` above the horizontal; y is up.
struct OrbitCamera {
  Vec3 target = Vec3::Zero();  // m
  double distance = 0.1;       // m, eye to target
  double yaw = 0;              // rad
  double pitch = 0.4;          // rad, in (−π/2, π/2)
  double fov = 40;             // degrees, vertical

  // From a scene's camera (position, target, fov); a camera at its target gets distance 0.1 m.
  static OrbitCamera from(const CameraDef& def);
  Vec3 eye() const;
  Vec3 forward() const;  // unit, eye to target
  Vec3 right() const;    // unit, x of the image
  Vec3 up() const;       // unit, y of the image

  // Column-major 4x4 matrices as OpenGL wants them. `aspect` = width / height.
  Eigen::Matrix4f view_matrix() const;
  Eigen::Matrix4f projection_matrix(double aspect) const;
  double near_plane() const { return distance * 0.01; }
  double far_plane() const { return distance * 100.0; }

  // Mouse drags in pixels of a window `height` pixels tall.
  void orbit(double dx, double dy);                 // left drag: turn about the target
  void pan(double dx, double dy, int height);       // middle or shift drag: move target and eye
  void zoom(double notches);                        // wheel: positive moves closer

  // The ray from the eye through window point (x, y) (pixels, top-left origin, y down) of a
  // width x height window; returns its unit direction.
  Vec3 ray_direction(double x, double y, int width, int height) const;
  // Where a point lands in the window (pixels, top-left origin); nothing when behind the eye.
  std::optional<Eigen::Vector2d> project(const Vec3& point, int width, int height) const;
};

// Nearest hit t > 0 (m along the unit ray) of the ray origin + t·dir with a triangle surface given
// as (#P x 3) float positions and (#T x 3) indices (Möller–Trumbore); nothing when it misses.
std::optional<double> pick(const Vec3& origin, const Vec3& dir, std::span<const float> positions,
                           std::span<const std::uint32_t> triangles);

}  // namespace palpate::view
