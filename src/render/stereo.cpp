// stereo.cpp — stereo's pure side: the modes' names, the off-axis eyes' matrices, the closed-form
// disparity, an eye's projection of a point, and the composition of two eye images into one
// (anaglyph, side by side, top and bottom). The eyes are drawn by offscreen_osmesa.cpp.
#include "render/offscreen.h"

#include <cmath>
#include <cstring>
#include <string>

namespace palpate {

namespace {

struct ModeName {
  StereoMode mode;
  const char* name;
};
constexpr ModeName kModes[] = {{StereoMode::anaglyph, "anaglyph"},
                               {StereoMode::side_by_side, "side-by-side"},
                               {StereoMode::top_bottom, "top-bottom"},
                               {StereoMode::quad_buffer, "quad-buffer"}};

}  // namespace

Result<StereoMode> parse_stereo_mode(const std::string& text) {
  for (const ModeName& m : kModes)
    if (text == m.name) return m.mode;
  return Error{"stereo mode '" + text + "'; expected " + kStereoModeNames};
}

const char* stereo_mode_name(StereoMode mode) {
  for (const ModeName& m : kModes)
    if (m.mode == mode) return m.name;
  return "mono";
}

Status check_stereo(const StereoOptions& s) {
  if (!std::isfinite(s.eye_separation) || s.eye_separation < 0 || s.eye_separation > 1)
    return Error{"stereo: eye separation " + std::to_string(s.eye_separation) + " m; expected 0 to 1 m"};
  if (!std::isfinite(s.convergence) || s.convergence < 0)
    return Error{"stereo: convergence " + std::to_string(s.convergence) +
                 " m; expected > 0 m (or 0: the camera's distance to its target)"};
  return {};
}

EyeMatrices stereo_eye_matrices(const Vec3& position, const Vec3& right, const Vec3& up, const Vec3& forward,
                                double fov, double aspect, double near, double far, double separation,
                                double convergence, Eye eye) {
  const double e = eye == Eye::left ? -1.0 : 1.0;
  EyeMatrices m;
  m.position = position + e * 0.5 * separation * right;
  m.view.block<1, 3>(0, 0) = right.transpose();
  m.view.block<1, 3>(1, 0) = up.transpose();
  m.view.block<1, 3>(2, 0) = -forward.transpose();
  m.view.block<3, 1>(0, 3) = -m.view.block<3, 3>(0, 0) * m.position;
  const double focal = 1.0 / std::tan(0.5 * fov * render::kPi / 180.0);
  Eigen::Matrix4d& p = m.projection;
  p.setZero();
  p(0, 0) = focal / aspect;
  // x_ndc = (focal/aspect)·x_eye/depth − p(0,2) with depth = −z_eye: a point the centre camera sees
  // at x_c = x_eye + e·s/2 and depth D lands at (focal/aspect)·x_c/D, as the centre camera has it.
  p(0, 2) = convergence > 0 ? -e * (focal / aspect) * separation / (2.0 * convergence) : 0.0;
  p(1, 1) = focal;
  p(2, 2) = (far + near) / (near - far);
  p(2, 3) = 2 * far * near / (near - far);
  p(3, 2) = -1;
  return m;
}

double stereo_convergence(const CameraDef& camera, const StereoOptions& stereo) {
  return stereo.convergence > 0 ? stereo.convergence : (camera.target - camera.position).norm();
}

double stereo_disparity_px(const CameraDef& camera, const StereoOptions& stereo, double z) {
  const double f_px = 0.5 * camera.height / std::tan(0.5 * camera.fov * render::kPi / 180.0);
  const double d = stereo_convergence(camera, stereo);
  return f_px * stereo.eye_separation * (1.0 / d - 1.0 / z);
}

std::optional<Eigen::Vector2d> project_to_pixel(const CameraDef& camera, const StereoOptions& stereo, Eye eye,
                                                const Vec3& point) {
  if (!check_stereo(stereo)) return std::nullopt;
  const std::optional<Eigen::Vector2d> centre = project_to_pixel(camera, point);  // checks the camera
  if (!centre) return std::nullopt;
  const render::CameraFrame f = render::camera_frame(camera);
  const EyeMatrices m = stereo_eye_matrices(f.eye, f.right, f.up, f.forward, camera.fov, f.aspect, 1e-3, 1.0,
                                            stereo.eye_separation, stereo_convergence(camera, stereo), eye);
  const Eigen::Vector4d clip = m.projection * m.view * point.homogeneous();
  if (!(clip.w() > 0)) return std::nullopt;
  return Eigen::Vector2d((clip.x() / clip.w() + 1) * 0.5 * camera.width,
                         (1 - clip.y() / clip.w()) * 0.5 * camera.height);
}

namespace render {

Image compose_stereo(StereoMode mode, const Image& left, const Image& right) {
  const int w = left.width, h = left.height;
  Image out;
  const size_t row = size_t(w) * 4;
  switch (mode) {
    case StereoMode::side_by_side:
      out.width = 2 * w, out.height = h;
      out.rgba.resize(size_t(out.width) * h * 4);
      for (int y = 0; y < h; ++y) {
        std::memcpy(&out.rgba[size_t(y) * 2 * row], &left.rgba[size_t(y) * row], row);
        std::memcpy(&out.rgba[size_t(y) * 2 * row + row], &right.rgba[size_t(y) * row], row);
      }
      break;
    case StereoMode::top_bottom:
      out.width = w, out.height = 2 * h;
      out.rgba = left.rgba;
      out.rgba.insert(out.rgba.end(), right.rgba.begin(), right.rgba.end());
      break;
    default:  // anaglyph: red from the left eye, green and blue from the right
      out = left;
      for (size_t i = 0; i < out.rgba.size(); i += 4) {
        out.rgba[i + 1] = right.rgba[i + 1];
        out.rgba[i + 2] = right.rgba[i + 2];
      }
      break;
  }
  return out;
}

}  // namespace render

}  // namespace palpate
