// viewer_scene.cpp — what the `palpate view` window draws: each tissue's surface from its
// snapshot, the tools, the force arrow, the probe and its image plane; and screenshots.
#include "viewer_impl.h"

#include "core/blade_shape.h"

namespace palpate::view::detail {

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

void Viewer::update_views() {
  for (size_t i = 0; i < tissues_.size(); ++i) {
    const TissueSnapshot& s = tissues_[i]->latest();
    drawn_[i] = update_view(views_[i], s, options_.resolution, static_cast<float>(wound_wall_depth(scene_, i)));
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
    if (surface) gl_->triangles(v.positions(), v.normals(), v.triangles(), color);
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
