// offscreen.cpp — the headless renderer's plain side: the scene's checks, the camera's frame and
// projection, render_rgba and render_png. The drawing itself is software OpenGL (OSMesa) in
// offscreen_osmesa.cpp, or a refusal in a build without it (offscreen_none.cpp).
#include "render/offscreen.h"

#include <cmath>
#include <string>

namespace palpate {
namespace render {

CameraFrame camera_frame(const CameraDef& c) {
  CameraFrame f;
  f.eye = c.position;
  f.forward = (c.target - c.position).normalized();
  Vec3 up0 = Vec3::UnitY();
  if (std::abs(f.forward.y()) > 0.999) up0 = f.forward.y() < 0 ? Vec3(0, 0, -1) : Vec3(0, 0, 1);
  f.right = f.forward.cross(up0).normalized();
  f.up = f.right.cross(f.forward);
  f.focal = 1.0 / std::tan(0.5 * c.fov * kPi / 180.0);
  f.aspect = double(c.width) / double(c.height);
  return f;
}

}  // namespace render

namespace {

using render::CameraFrame;
using render::camera_frame;

constexpr int kMaxImageSide = kMaxOffscreenSide;  // pixels

Status check_camera(const CameraDef& c) {
  auto finite = [](const Vec3& v) { return v.allFinite(); };
  if (c.width < 1 || c.width > kMaxImageSide || c.height < 1 || c.height > kMaxImageSide)
    return Error{"render: camera size " + std::to_string(c.width) + " x " + std::to_string(c.height) +
                 " pixels; expected 1 to " + std::to_string(kMaxImageSide) + " each"};
  if (!(c.fov > 0 && c.fov < 180))
    return Error{"render: camera fov " + std::to_string(c.fov) + " degrees; expected between 0 and 180"};
  if (!finite(c.position) || !finite(c.target))
    return Error{"render: camera position or target is not finite; expected finite coordinates in m"};
  if ((c.target - c.position).norm() <= 0)
    return Error{"render: camera position equals its target; expected them apart"};
  return {};
}

// --- the scene ----------------------------------------------------------------------------------

Status check_scene(const RenderScene& s) {
  if (Status c = check_camera(s.camera); !c) return c;
  if (Status c = check_stereo(s.stereo); !c) return Error{"render: " + c.error().message};
  if (s.stereo.mode == StereoMode::quad_buffer)
    return Error{"render: stereo quad-buffer needs a window whose OpenGL context has left and right buffers; "
                 "an off-screen (OSMesa) image has none: use anaglyph, side-by-side or top-bottom"};
  if (s.supersample < 1 || s.supersample > 4)
    return Error{"render: supersample " + std::to_string(s.supersample) + "; expected 1 to 4"};
  for (size_t i = 0; i < s.surfaces.size(); ++i) {
    const RenderSurface& m = s.surfaces[i];
    const std::string where = "render: surface " + std::to_string(i) + ": ";
    if (m.positions.size() % 3 != 0)
      return Error{where + std::to_string(m.positions.size()) + " position floats; expected 3 per point"};
    if (!m.normals.empty() && m.normals.size() != m.positions.size())
      return Error{where + std::to_string(m.normals.size() / 3) + " normals for " +
                   std::to_string(m.positions.size() / 3) + " points; expected one per point (or none)"};
    if (m.triangles.size() % 3 != 0)
      return Error{where + std::to_string(m.triangles.size()) + " triangle indices; expected 3 per triangle"};
    if (!(m.opacity > 0 && m.opacity <= 1))
      return Error{where + "opacity " + std::to_string(m.opacity) + "; expected above 0 and at most 1"};
    const size_t np = m.positions.size() / 3;
    for (size_t k = 0; k < m.triangles.size(); ++k)
      if (m.triangles[k] >= np)
        return Error{where + "triangle " + std::to_string(k / 3) + " refers to point " +
                     std::to_string(m.triangles[k]) + "; expected an index below " + std::to_string(np) + " (the point count)"};
  }
  for (size_t i = 0; i < s.lines.size(); ++i) {
    const RenderLines& l = s.lines[i];
    for (size_t k = 0; k < l.segments.size(); ++k)
      for (int e : l.segments[k])
        if (e < 0 || size_t(e) >= l.points.size())
          return Error{"render: lines " + std::to_string(i) + ": segment " + std::to_string(k) +
                       " refers to point " + std::to_string(e) + "; expected an index below " +
                       std::to_string(l.points.size()) + " (the point count)"};
  }
  if (s.tool) {
    const RenderTool& t = *s.tool;
    if (t.kind != "sphere" && t.kind != "needle" && t.kind != "blade")
      return Error{"render: tool kind '" + t.kind + "'; expected sphere, needle or blade"};
    if (!(t.radius > 0) || !std::isfinite(t.radius) || !t.tip.allFinite())
      return Error{"render: tool radius " + std::to_string(t.radius) + " m at a finite tip; expected > 0"};
    if ((t.kind == "needle" || t.kind == "blade") &&
        (!(t.length > 0) || !std::isfinite(t.length) || !(t.axis.norm() > 0) || !t.axis.allFinite()))
      return Error{"render: " + t.kind + " length " + std::to_string(t.length) +
                   " m along a non-zero axis; expected > 0"};
  }
  if (s.force && (!s.force->origin.allFinite() || !s.force->force.allFinite() ||
                  !std::isfinite(s.force->length_per_newton)))
    return Error{"render: force arrow is not finite; expected finite origin (m), force (N) and scale (m/N)"};
  return {};
}

}  // namespace

std::optional<Eigen::Vector2d> project_to_pixel(const CameraDef& camera, const Vec3& point) {
  if (!check_camera(camera)) return std::nullopt;
  const CameraFrame f = camera_frame(camera);
  const Vec3 d = point - f.eye;
  const double depth = d.dot(f.forward);
  if (!(depth > 0)) return std::nullopt;
  const double ndc_x = d.dot(f.right) * f.focal / f.aspect / depth;
  const double ndc_y = d.dot(f.up) * f.focal / depth;
  return Eigen::Vector2d((ndc_x + 1) * 0.5 * camera.width, (1 - ndc_y) * 0.5 * camera.height);
}

std::vector<std::array<int, 2>> grid_lines(int rows, int cols) {
  std::vector<std::array<int, 2>> s;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      if (c + 1 < cols) s.push_back({r * cols + c, r * cols + c + 1});
      if (r + 1 < rows) s.push_back({r * cols + c, (r + 1) * cols + c});
    }
  return s;
}

Result<Image> render_rgba(const RenderScene& scene) {
  if (Status ok = check_scene(scene); !ok) return ok.error();
  if (scene.stereo.mode == StereoMode::mono) return render::draw_offscreen(scene);
  auto left = render::draw_offscreen(scene, Eye::left);
  if (!left) return left.error();
  auto right = render::draw_offscreen(scene, Eye::right);
  if (!right) return right.error();
  return render::compose_stereo(scene.stereo.mode, *left, *right);
}

Status render_png(const RenderScene& scene, const std::filesystem::path& file) {
  auto image = render_rgba(scene);
  if (!image) return Error{file.string() + ": " + image.error().message};
  return write_png(*image, file);
}

}  // namespace palpate
