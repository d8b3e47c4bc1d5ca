// frame.cpp — a scene's frame from tissue snapshots: smooth surfaces over the physics, tool, force.
#include <palpate/mesh.h>
#include <palpate/render.h>
#include <palpate/surface.h>
#include <palpate/tissue.h>

#include <algorithm>
#include <numbers>

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

// The probe's box (24 vertices: flat faces) and its image plane's outline (4 points), appended to
// `storage` (positions, normals, outline points as floats) and `index_storage` (the box's triangles).
void add_probe(const FrameProbe& p, RenderScene& rs, std::vector<std::vector<float>>& storage,
               std::vector<std::vector<uint32_t>>& index_storage) {
  const Quat q = p.orientation.normalized();
  const Vec3 beam = (q * p.def.axis).normalized();
  const Vec3 lateral = (q * p.def.lateral).normalized();
  const Vec3 elevation = beam.cross(lateral).normalized();
  const Vec3 hx = 0.5 * p.def.width * lateral, hz = 0.5 * p.def.thickness * elevation;
  const Vec3 up = -p.height * beam;  // the box stands on its face, away from the skin
  const Vec3 c = p.position;
  // Corners: bit 0 lateral ±, bit 1 elevation ±, bit 2 face (0) or top (1).
  auto corner = [&](int i) {
    return Vec3(c + ((i & 1) ? hx : -hx) + ((i & 2) ? hz : -hz) + ((i & 4) ? up : Vec3(Vec3::Zero())));
  };
  static const int kFaces[6][4] = {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1},
                                   {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}};
  std::vector<float> pos, nrm;
  std::vector<uint32_t> tri;
  const Vec3 centre = c + 0.5 * up;
  for (const auto& f : kFaces) {
    const Vec3 a = corner(f[0]), b = corner(f[1]), d = corner(f[2]);
    Vec3 n = (b - a).cross(d - a).normalized();
    const Vec3 mid = 0.25 * (a + b + d + corner(f[3]));
    const bool outward = n.dot(mid - centre) > 0;
    if (!outward) n = -n;
    const auto base = uint32_t(pos.size() / 3);
    for (int k = 0; k < 4; ++k) {
      const Vec3 v = corner(f[k]);
      pos.insert(pos.end(), {float(v.x()), float(v.y()), float(v.z())});
      nrm.insert(nrm.end(), {float(n.x()), float(n.y()), float(n.z())});
    }
    // Counter-clockwise seen from outside.
    if (outward)
      tri.insert(tri.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
    else
      tri.insert(tri.end(), {base, base + 2, base + 1, base, base + 3, base + 2});
  }
  storage.push_back(std::move(pos));
  storage.push_back(std::move(nrm));
  index_storage.push_back(std::move(tri));
  RenderSurface box;
  box.positions = storage[storage.size() - 2];
  box.normals = storage.back();
  box.triangles = index_storage.back();
  box.color = Vec3f(0.55f, 0.62f, 0.72f);  // the transducer's grey-blue plastic
  box.opacity = 0.45f;  // see-through: it stands over the vein, where the needle's tip ends
  rs.surfaces.push_back(box);
  // The image plane: the face's width along the array, the imaging depth along the beam.
  const double w = 0.5 * p.def.width;
  const Vec3 outline[4] = {c - w * lateral, c + w * lateral, c + w * lateral + p.def.depth * beam,
                           c - w * lateral + p.def.depth * beam};
  std::vector<float> pts, pn;
  for (const Vec3& v : outline) pts.insert(pts.end(), {float(v.x()), float(v.y()), float(v.z())});
  const Vec3 pnormal = elevation;
  for (int k = 0; k < 4; ++k) pn.insert(pn.end(), {float(pnormal.x()), float(pnormal.y()), float(pnormal.z())});
  storage.push_back(std::move(pts));
  storage.push_back(std::move(pn));
  index_storage.push_back({0, 1, 2, 0, 2, 3});  // lit from both sides
  RenderSurface plane;  // the plane itself, faintly: where the image is
  plane.positions = storage[storage.size() - 2];
  plane.normals = storage.back();
  plane.triangles = index_storage.back();
  plane.color = Vec3f(0.3f, 0.95f, 0.85f);
  plane.opacity = 0.18f;
  rs.surfaces.push_back(plane);
  static const std::array<int, 2> kOutline[4] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}};
  RenderLines lines;
  // Vec3f is three packed floats (Eigen's fixed-size vectors have no padding).
  static_assert(sizeof(Vec3f) == 3 * sizeof(float));
  lines.points = std::span<const Vec3f>(reinterpret_cast<const Vec3f*>(storage[storage.size() - 2].data()), 4);
  lines.segments = kOutline;
  lines.color = Vec3f(0.3f, 0.95f, 0.85f);  // cyan: the beam's plane
  lines.width = 2.0f;
  rs.lines.push_back(lines);
}

// A sphere (24 x 12 facets, smooth normals) appended to `storage` and `index_storage`.
void add_sphere(const FrameSphere& s, RenderScene& rs, std::vector<std::vector<float>>& storage,
                std::vector<std::vector<uint32_t>>& index_storage) {
  constexpr int kAround = 24, kUp = 12;
  std::vector<float> pos, nrm;
  std::vector<uint32_t> tri;
  for (int j = 0; j <= kUp; ++j) {
    const double theta = std::numbers::pi * j / kUp;
    for (int i = 0; i <= kAround; ++i) {
      const double phi = 2 * std::numbers::pi * i / kAround;
      const Vec3 n(std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi));
      const Vec3 v = s.center + s.radius * n;
      pos.insert(pos.end(), {float(v.x()), float(v.y()), float(v.z())});
      nrm.insert(nrm.end(), {float(n.x()), float(n.y()), float(n.z())});
    }
  }
  for (int j = 0; j < kUp; ++j)
    for (int i = 0; i < kAround; ++i) {
      const auto a = uint32_t(j * (kAround + 1) + i), b = a + 1, c = a + kAround + 1, d = c + 1;
      tri.insert(tri.end(), {a, b, c, b, d, c});  // counter-clockwise seen from outside
    }
  storage.push_back(std::move(pos));
  storage.push_back(std::move(nrm));
  index_storage.push_back(std::move(tri));
  RenderSurface ball;
  ball.positions = storage[storage.size() - 2];
  ball.normals = storage.back();
  ball.triangles = index_storage.back();
  ball.color = s.closed ? Vec3f(0.35f, 0.38f, 0.45f) : Vec3f(0.62f, 0.66f, 0.72f);  // steel; darker closed
  rs.surfaces.push_back(ball);
}

}  // namespace

double wound_wall_depth(const SceneDef& scene, size_t tissue) {
  return tissue < scene.tissues.size() && scene.tissues[tissue].model == "charged_particles"
             ? scene.tissues[tissue].charged.thickness
             : ChargedMaterialDef{}.thickness;
}

Result<RenderScene> frame_scene(const SceneDef& scene, std::span<const TissueSnapshot> tissues,
                                const Vec3& tip, const Vec3& force, const FrameOptions& options,
                                std::vector<std::vector<float>>& storage,
                                std::vector<std::vector<uint32_t>>& index_storage,
                                const std::optional<Vec3>& tool_axis, const FrameProbe* probe,
                                std::span<const FrameSphere> spheres) {
  RenderScene rs;
  rs.camera = scene.camera ? *scene.camera : framing_camera(tissues, tip);
  rs.stereo = options.stereo;
  storage.clear();
  index_storage.clear();
  // No reallocation: the surfaces' spans point into it.
  storage.reserve(tissues.size() * 2 + 4 + 2 * spheres.size());
  index_storage.reserve(tissues.size() + 2 + spheres.size());
  for (size_t i = 0; i < tissues.size(); ++i) {
    const TissueSnapshot& t = tissues[i];
    const RoleLook* look = role_look(scene, tissues.size(), i);
    const Vec3f color = look ? look->color : kPalette[i % std::size(kPalette)];
    if (t.rows_cols.size() == 2 && t.rows_cols[0] >= 2 && t.rows_cols[1] >= 2) {
      SurfaceDef def;
      def.resolution = std::max(1, options.resolution);
      auto drawing = GridDrawing::build(t.rows_cols[0], t.rows_cols[1], def);
      if (!drawing) return drawing.error();
      // Drawn smooth (the lattice's ragged ends straightened, the patches' border normals shared)
      // and, for a cut layer, with no triangle across its wound, whose walls show its thickness.
      if (!drawing->draw(t.points, t.cut_links, static_cast<float>(wound_wall_depth(scene, i))))
        return Error{"frame: tissue " + std::to_string(i) + ": snapshot has " +
                     std::to_string(t.points.size()) + " points, its grid needs " +
                     std::to_string(t.rows_cols[0] * t.rows_cols[1])};
      SurfaceBuffers out = std::move(*drawing).take();
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
  if (probe) add_probe(*probe, rs, storage, index_storage);
  for (const FrameSphere& s : spheres) add_sphere(s, rs, storage, index_storage);
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
                        const FrameOptions& options, const std::optional<Vec3>& tool_axis,
                        const FrameProbe* probe, std::span<const FrameSphere> spheres) {
  std::vector<std::vector<float>> storage;
  std::vector<std::vector<uint32_t>> index_storage;
  auto rs = frame_scene(scene, tissues, tip, force, options, storage, index_storage, tool_axis, probe, spheres);
  if (!rs) return rs.error();
  return render_png(*rs, file);
}

}  // namespace palpate
