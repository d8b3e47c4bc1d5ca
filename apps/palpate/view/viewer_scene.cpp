// viewer_scene.cpp — what the `palpate view` window draws: each tissue's surface from its
// snapshot, the tools, the force arrow, the probe and its image plane; and screenshots.
#include "viewer_impl.h"

#include "core/blade_shape.h"

namespace palpate::view::detail {
namespace {

// Area-weighted vertex normals of a triangle mesh (a zero normal where no triangle touches).
void vertex_normals(const TissueSnapshot& s, std::vector<Vec3f>& out) {
  out.assign(s.points.size(), Vec3f::Zero());
  const auto n = static_cast<int>(s.points.size());
  for (const auto& t : s.triangles) {
    if (t[0] < 0 || t[1] < 0 || t[2] < 0 || t[0] >= n || t[1] >= n || t[2] >= n) continue;
    const Vec3f& a = s.points[static_cast<size_t>(t[0])];
    const Vec3f face = (s.points[static_cast<size_t>(t[1])] - a).cross(s.points[static_cast<size_t>(t[2])] - a);
    for (int k : t) out[static_cast<size_t>(k)] += face;
  }
}

}  // namespace

// The probe as a box: its footprint (width along the array × thickness) standing `height` on its
// face, flat-shaded (four vertices per side).
void append_probe_box(TriangleMesh& mesh, const Vec3& face_centre, const Vec3& beam, const Vec3& lateral,
                      double width, double thickness, double height) {
  const Vec3 elevation = beam.cross(lateral).normalized();
  const Vec3 hx = 0.5 * width * lateral, hz = 0.5 * thickness * elevation, up = -height * beam;
  auto corner = [&](int i) {
    return Vec3(face_centre + ((i & 1) ? hx : -hx) + ((i & 2) ? hz : -hz) + ((i & 4) ? up : Vec3(Vec3::Zero())));
  };
  static const int kFaces[6][4] = {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1},
                                   {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}};
  for (const auto& f : kFaces) {
    const Vec3 a = corner(f[0]), b = corner(f[1]), d = corner(f[2]);
    const Vec3 n = (b - a).cross(d - a).normalized();
    const auto base = static_cast<std::uint32_t>(mesh.positions.size() / 3);
    for (int k = 0; k < 4; ++k) {
      const Vec3 v = corner(f[k]);
      mesh.positions.insert(mesh.positions.end(), {float(v.x()), float(v.y()), float(v.z())});
      mesh.normals.insert(mesh.normals.end(), {float(n.x()), float(n.y()), float(n.z())});
    }
    mesh.triangles.insert(mesh.triangles.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
  }
}

// Bring `view` up to date with snapshot `s`; false when it has nothing to draw as a surface.
bool update_view(TissueView& view, const TissueSnapshot& s, int resolution) {
  const size_t n = s.points.size();
  if (s.rows_cols.size() == 2 && s.rows_cols[0] >= 2 && s.rows_cols[1] >= 2 &&
      static_cast<size_t>(s.rows_cols[0]) * static_cast<size_t>(s.rows_cols[1]) == n) {
    if (!view.grid || view.rows != s.rows_cols[0] || view.cols != s.rows_cols[1]) {
      SurfaceDef def;
      def.scheme = SurfaceScheme::bezier;
      def.resolution = resolution;
      auto built = SurfaceTessellator::build(s.rows_cols[0], s.rows_cols[1], def);
      if (!built) return false;
      view.grid.emplace(std::move(*built));
      view.pn.reset();
      view.rows = s.rows_cols[0];
      view.cols = s.rows_cols[1];
      view.grid_links.clear();
      for (int r = 0; r < view.rows; ++r)
        for (int c = 0; c < view.cols; ++c) {
          const int i = r * view.cols + c;
          if (c + 1 < view.cols) view.grid_links.push_back({i, i + 1});
          if (r + 1 < view.rows) view.grid_links.push_back({i, i + view.cols});
        }
      view.positions.resize(view.grid->point_count() * 3);
      view.normals.resize(view.grid->point_count() * 3);
    }
    // Drawn smooth: the lattice's ragged ends straightened, the patches' border normals shared.
    view.control.assign(s.points.begin(), s.points.end());
    straighten_grid_ends(view.control, view.rows, view.cols);
    return view.grid->tessellate(view.control, view.positions, view.normals) &&
           view.grid->smooth_border_normals(view.normals);
  }
  view.grid.reset();
  view.rows = view.cols = 0;
  view.grid_links.clear();
  if (s.triangles.empty()) {
    view.pn.reset();
    return false;
  }
  if (!view.pn || view.pn->vertex_count() != static_cast<int>(n) || view.mesh_triangles != s.triangles.size()) {
    auto built = PnTessellator::build(static_cast<int>(n), s.triangles, 3);
    if (!built) {
      view.pn.reset();
      return false;
    }
    view.pn.emplace(std::move(*built));
    view.mesh_triangles = s.triangles.size();
    view.positions.resize(view.pn->point_count() * 3);
    view.normals.resize(view.pn->point_count() * 3);
  }
  vertex_normals(s, view.vertex_normals);
  return view.pn->tessellate(s.points, view.vertex_normals, view.positions, view.normals);
}

void Viewer::update_views() {
  for (size_t i = 0; i < tissues_.size(); ++i) {
    const TissueSnapshot& s = tissues_[i]->latest();
    drawn_[i] = update_view(views_[i], s, options_.resolution);
    tissues_[i]->request();  // the next step copies a fresh one for the next frame
  }
}

void Viewer::draw_scene(int fb_width, int fb_height) {
  gl_->clear(kBackground, fb_width, fb_height);
  const double aspect = fb_height > 0 ? static_cast<double>(fb_width) / fb_height : 1.0;
  gl_->set_camera(camera_.projection_matrix(aspect) * camera_.view_matrix(), camera_.eye());
  for (size_t i = 0; i < tissues_.size(); ++i) {
    const TissueSnapshot& s = tissues_[i]->current();  // the one update_views() tessellated
    const TissueView& v = views_[i];
    const Vec3f color = kTissueColors[i % std::size(kTissueColors)];
    const bool surface = show_surface_ && drawn_[i];
    if (surface) gl_->triangles(v.positions, v.normals, v.triangles(), color);
    if (show_grid_ && !v.grid_links.empty()) gl_->lines(s.points, v.grid_links, kGridColor);
    if (show_links_ || (!drawn_[i] && !s.links.empty())) gl_->lines(s.points, s.links, kLinkColor);
    // Particles are drawn when asked, or when nothing else shows the tissue.
    if (show_particles_ || (!drawn_[i] && s.links.empty())) gl_->points(s.points, kParticleColor, 4.0f);
  }
  const Vec3 tip = feeder_->position();
  TriangleMesh mesh;
  if (show_tool_) {
    if (scene_.tool.kind == "needle") {
      const Vec3 axis = needle_axis(scene_axis(), feeder_->orientation());
      append_cylinder(mesh, tip - scene_.tool.length * axis, tip, scene_.tool.radius, scene_.tool.radius);
      append_sphere(mesh, tip, scene_.tool.radius, 10, 6);
    } else if (blade()) {
      // The scalpel as the frames draw it (core/blade_shape.h): the blade on its edge, the handle
      // behind the heel, and the edge itself in a colour of its own.
      const BladeShape b = blade_shape(tip, needle_axis(scene_axis(), feeder_->orientation()), scene_.tool.length,
                                       scene_.tool.radius);
      BladeMesh bm;
      append_blade(bm, b);
      append_blade_handle(bm, b);
      mesh.positions = std::move(bm.positions);
      mesh.normals = std::move(bm.normals);
      mesh.triangles = std::move(bm.triangles);
      Vec3 ends[4];
      blade_edge_lines(b, ends);
      const Vec3f edge[4] = {ends[0].cast<float>(), ends[1].cast<float>(), ends[2].cast<float>(), ends[3].cast<float>()};
      static const std::array<int, 2> kEdge[2] = {{0, 1}, {2, 3}};
      gl_->triangles(mesh, kToolColor);
      mesh.clear();
      gl_->lines(edge, kEdge, kBladeEdgeColor);
    } else {
      append_sphere(mesh, tip, scene_.tool.radius);
    }
    gl_->triangles(mesh, kToolColor);
  }
  if (probe_feeder_) {
    const ProbeDef& p = *scene_.probe;
    const Quat q = probe_feeder_->orientation();
    const Vec3 c = probe_feeder_->position(), beam = probe_beam(), lateral = (q * p.lateral).normalized();
    mesh.clear();
    append_probe_box(mesh, c, beam, lateral, p.width, p.thickness, 0.03);
    gl_->triangles(mesh, kProbeColor);
    if (show_plane_) {
      const double w = 0.5 * p.width;
      const Vec3 corners[4] = {c - w * lateral, c + w * lateral, c + w * lateral + p.depth * beam,
                               c - w * lateral + p.depth * beam};
      Vec3f pts[4];
      for (int k = 0; k < 4; ++k) pts[k] = corners[k].cast<float>();
      static const std::array<int, 2> kOutline[4] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}};
      gl_->lines(pts, kOutline, kPlaneColor);
    }
  }
  if (show_arrow_ && force_.norm() > 1e-4) {
    mesh.clear();
    // Length ∝ √|F|, so 0.05 N still shows and the device's 3.3 N stays on screen.
    const double length = arrow_metres_per_newton_ * std::sqrt(force_.norm());
    append_arrow(mesh, tip, force_.normalized() * length, 0.004 * scene_size_);
    gl_->triangles(mesh, kArrowColor, /*on_top=*/true);
  }
}

bool Viewer::take_screenshot(const std::filesystem::path& file, int fb_width, int fb_height) {
  const auto rgba = read_framebuffer(fb_width, fb_height);
  Status st = write_png_atomic(file, fb_width, fb_height, rgba);
  if (!st) {
    fmt::print(stderr, "palpate view: screenshot: {}\n", st.error().message);
    return false;
  }
  fmt::print("screenshot: {}\n", file.string());
  std::fflush(stdout);
  return true;
}

}  // namespace palpate::view::detail
