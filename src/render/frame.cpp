// frame.cpp — a scene's frame from tissue snapshots: smooth surfaces over the physics, tool, force.
#include <palpate/mesh.h>
#include <palpate/render.h>
#include <palpate/surface.h>
#include <palpate/tissue.h>

#include <algorithm>

namespace palpate {

namespace {

// Tissue colours by layer: skin, fat, vessel wall, then organ tones.
const Vec3f kPalette[] = {Vec3f(0.86f, 0.62f, 0.52f), Vec3f(0.93f, 0.82f, 0.45f),
                          Vec3f(0.72f, 0.18f, 0.2f), Vec3f(0.55f, 0.25f, 0.22f),
                          Vec3f(0.6f, 0.45f, 0.6f)};

// Colours by role, as anatomy atlases draw them: the vein dark blue-purple, the artery bright red.
// Skin and fat cover what the frame is about (the needle, the vessels): drawn see-through, the fat
// fainter than the skin since it lies under it and both are crossed on the way to a vessel. The
// vessels are nearly opaque, enough to read as solid tubes and to show the needle's tip in the
// lumen (the moment of the flashback).
struct RoleLook {
  const char* role;
  Vec3f color;
  float cover_opacity;  // opacity when FrameOptions::translucent_cover; 1 = always opaque
};
const RoleLook kRoleLooks[] = {
    {"skin", Vec3f(0.91f, 0.70f, 0.58f), 0.30f},  {"fat", Vec3f(0.96f, 0.84f, 0.40f), 0.12f},
    {"muscle", Vec3f(0.62f, 0.24f, 0.22f), 1.0f}, {"vein", Vec3f(0.22f, 0.17f, 0.72f), 0.8f},
    {"artery", Vec3f(0.90f, 0.08f, 0.10f), 0.8f},
};

const RoleLook* role_look(const SceneDef& scene, size_t n_tissues, size_t i) {
  if (scene.tissues.size() != n_tissues) return nullptr;  // not the scene's tissues: no roles known
  for (const RoleLook& r : kRoleLooks)
    if (scene.tissues[i].role == r.role) return &r;
  return nullptr;
}

CameraDef framing_camera(std::span<const TissueSnapshot> tissues, const Vec3& tip) {
  Eigen::AlignedBox3d box;
  box.extend(tip);
  for (const TissueSnapshot& t : tissues)
    for (const Vec3f& p : t.points) box.extend(p.cast<double>());
  CameraDef c;
  const Vec3 center = box.center();
  const double extent = std::max(box.diagonal().norm(), 1e-3);
  c.target = center;
  c.position = center + Vec3(0.55, 0.6, 0.95).normalized() * extent * 1.3;
  return c;
}

}  // namespace

Result<RenderScene> frame_scene(const SceneDef& scene, std::span<const TissueSnapshot> tissues,
                                const Vec3& tip, const Vec3& force, const FrameOptions& options,
                                std::vector<std::vector<float>>& storage,
                                std::vector<std::vector<uint32_t>>& index_storage,
                                const std::optional<Vec3>& tool_axis) {
  RenderScene rs;
  rs.camera = scene.camera ? *scene.camera : framing_camera(tissues, tip);
  storage.clear();
  index_storage.clear();
  storage.reserve(tissues.size() * 2);
  index_storage.reserve(tissues.size());
  for (size_t i = 0; i < tissues.size(); ++i) {
    const TissueSnapshot& t = tissues[i];
    const RoleLook* look = role_look(scene, tissues.size(), i);
    const Vec3f color = look ? look->color : kPalette[i % std::size(kPalette)];
    if (t.rows_cols.size() == 2 && t.rows_cols[0] >= 2 && t.rows_cols[1] >= 2) {
      SurfaceDef def;
      def.resolution = std::max(1, options.resolution);
      auto tess = SurfaceTessellator::build(t.rows_cols[0], t.rows_cols[1], def);
      if (!tess) return tess.error();
      SurfaceBuffers out;
      if (!tess->tessellate(t.points, out))
        return Error{"frame: tissue " + std::to_string(i) + ": snapshot has " +
                     std::to_string(t.points.size()) + " points, its grid needs " +
                     std::to_string(t.rows_cols[0] * t.rows_cols[1])};
      storage.push_back(std::move(out.positions));
      storage.push_back(std::move(out.normals));
      index_storage.push_back(std::move(out.triangles));
    } else if (!t.triangles.empty()) {
      SurfaceMesh m;
      m.V.resize(static_cast<Eigen::Index>(t.points.size()), 3);
      for (size_t k = 0; k < t.points.size(); ++k) m.V.row(Eigen::Index(k)) = t.points[k].cast<double>().transpose();
      m.F.resize(static_cast<Eigen::Index>(t.triangles.size()), 3);
      for (size_t k = 0; k < t.triangles.size(); ++k)
        m.F.row(Eigen::Index(k)) << t.triangles[k][0], t.triangles[k][1], t.triangles[k][2];
      auto smooth = pn_triangles(m, std::clamp(options.resolution / 2, 1, 4));
      if (!smooth) return smooth.error();
      storage.push_back(std::move(smooth->positions));
      storage.push_back(std::move(smooth->normals));
      index_storage.push_back(std::move(smooth->triangles));
    } else {
      continue;  // nothing to draw as a surface (points still drawn below when asked)
    }
    RenderSurface surf;
    surf.positions = storage[storage.size() - 2];
    surf.normals = storage.back();
    surf.triangles = index_storage.back();
    surf.color = color;
    if (look && options.translucent_cover) surf.opacity = look->cover_opacity;
    rs.surfaces.push_back(surf);
  }
  for (const TissueSnapshot& t : tissues) {
    if (options.particles && !t.points.empty()) rs.points.push_back(RenderPoints{t.points});
    if (options.links && !t.links.empty()) rs.lines.push_back(RenderLines{t.points, t.links});
  }
  RenderTool tool;
  tool.kind = scene.tool.kind;
  tool.tip = tip;
  tool.axis = tool_axis ? *tool_axis : Vec3(scene.tool.axis.normalized());
  tool.radius = scene.tool.radius;
  tool.length = scene.tool.length;
  rs.tool = tool;
  if (force.norm() > 1e-6) {
    RenderArrow a;
    a.origin = tip;
    a.force = force;
    // An arrow of a fifth of the view's extent at the device's 3.3 N.
    const double view = (rs.camera.position - rs.camera.target).norm();
    a.length_per_newton = 0.2 * view / 3.3;
    rs.force = a;
  }
  return rs;
}

Status render_frame_png(const SceneDef& scene, std::span<const TissueSnapshot> tissues,
                        const Vec3& tip, const Vec3& force, const std::filesystem::path& file,
                        const FrameOptions& options, const std::optional<Vec3>& tool_axis) {
  std::vector<std::vector<float>> storage;
  std::vector<std::vector<uint32_t>> index_storage;
  auto rs = frame_scene(scene, tissues, tip, force, options, storage, index_storage, tool_axis);
  if (!rs) return rs.error();
  return render_png(*rs, file);
}

}  // namespace palpate
