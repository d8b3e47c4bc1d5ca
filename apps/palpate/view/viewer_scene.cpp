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

EyeMatrices Viewer::eye_matrices(Eye eye, double aspect) const {
  const double convergence = options_.stereo.convergence > 0 ? options_.stereo.convergence : camera_.distance;
  return stereo_eye_matrices(camera_.eye(), camera_.right(), camera_.up(), camera_.forward(), camera_.fov, aspect,
                             camera_.near_plane(), camera_.far_plane(), options_.stereo.eye_separation, convergence,
                             eye);
}

void Viewer::pointer_view(double& x, double& y, int& width, int& height) const {
  if (options_.stereo.mode == StereoMode::side_by_side) {
    const int left = width / 2;
    if (x >= left) x -= left, width -= left;
    else width = left;
  } else if (options_.stereo.mode == StereoMode::top_bottom) {
    const int top = height / 2;
    if (y >= top) y -= top, height -= top;
    else height = top;
  }
  width = std::max(width, 1);
  height = std::max(height, 1);
}

void Viewer::draw_scene(int fb_width, int fb_height) {
  const StereoMode mode = options_.stereo.mode;
  auto aspect_of = [](int w, int h) { return h > 0 ? static_cast<double>(w) / h : 1.0; };
  auto draw_eye = [&](Eye eye, double aspect) {
    const EyeMatrices m = eye_matrices(eye, aspect);
    draw_world((m.projection * m.view).cast<float>(), m.position);
  };
  if (mode == StereoMode::quad_buffer) {
    // The left and right back buffers (the window was made with GLFW_STEREO and has them: init_window).
    glDrawBuffer(GL_BACK_LEFT);
    gl_->clear(kBackground, fb_width, fb_height);
    draw_eye(Eye::left, aspect_of(fb_width, fb_height));
    glDrawBuffer(GL_BACK_RIGHT);
    gl_->clear(kBackground, fb_width, fb_height);
    draw_eye(Eye::right, aspect_of(fb_width, fb_height));
    glDrawBuffer(GL_BACK);  // the panels over both
    return;
  }
  gl_->clear(kBackground, fb_width, fb_height);
  switch (mode) {
    case StereoMode::anaglyph:
      // Red from the left eye, green and blue from the right; each eye hides only its own surfaces.
      glColorMask(GL_TRUE, GL_FALSE, GL_FALSE, GL_TRUE);
      draw_eye(Eye::left, aspect_of(fb_width, fb_height));
      glClear(GL_DEPTH_BUFFER_BIT);
      glColorMask(GL_FALSE, GL_TRUE, GL_TRUE, GL_TRUE);
      draw_eye(Eye::right, aspect_of(fb_width, fb_height));
      glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
      break;
    case StereoMode::side_by_side: {  // the left eye on the left half
      const int left = fb_width / 2;
      glViewport(0, 0, left, fb_height);
      draw_eye(Eye::left, aspect_of(left, fb_height));
      glViewport(left, 0, fb_width - left, fb_height);
      draw_eye(Eye::right, aspect_of(fb_width - left, fb_height));
      glViewport(0, 0, fb_width, fb_height);
      break;
    }
    case StereoMode::top_bottom: {  // the left eye on the top half (GL's rows run bottom up)
      const int top = fb_height / 2, bottom = fb_height - top;
      glViewport(0, bottom, fb_width, top);
      draw_eye(Eye::left, aspect_of(fb_width, top));
      glViewport(0, 0, fb_width, bottom);
      draw_eye(Eye::right, aspect_of(fb_width, bottom));
      glViewport(0, 0, fb_width, fb_height);
      break;
    }
    default: {
      const double aspect = aspect_of(fb_width, fb_height);
      draw_world(camera_.projection_matrix(aspect) * camera_.view_matrix(), camera_.eye());
      break;
    }
  }
}

void Viewer::draw_world(const Eigen::Matrix4f& projection_view, const Vec3& eye) {
  gl_->set_camera(projection_view, eye);
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
