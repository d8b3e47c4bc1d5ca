// offscreen_osmesa.cpp — the headless renderer's drawing: software OpenGL (OSMesa) draws a checked
// RenderScene to memory (render/offscreen.h). Built with PALPATE_WITH_OSMESA; offscreen_none.cpp
// replaces it without; the only file that includes OSMesa's headers.
#define GL_GLEXT_PROTOTYPES 1
#include <GL/osmesa.h>
#include <GL/gl.h>
#include <GL/glext.h>

#include "render/offscreen.h"

#include "core/blade_shape.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace palpate::render {
namespace {

// --- geometry ------------------------------------------------------------------------------------

// A small lit triangle mesh built at render time (tool, arrow).
struct Mesh {
  std::vector<float> positions, normals;  // (#P x 3)
  std::vector<uint32_t> triangles;        // (#T x 3)
  uint32_t add(const Vec3& p, const Vec3& n) {
    const uint32_t i = uint32_t(positions.size() / 3);
    positions.insert(positions.end(), {float(p.x()), float(p.y()), float(p.z())});
    normals.insert(normals.end(), {float(n.x()), float(n.y()), float(n.z())});
    return i;
  }
};

// Two unit vectors perpendicular to `axis` and to each other.
void perpendiculars(const Vec3& axis, Vec3& a, Vec3& b) {
  const Vec3 helper = std::abs(axis.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  a = axis.cross(helper).normalized();
  b = axis.cross(a);
}

void add_sphere(Mesh& m, const Vec3& centre, double radius) {
  constexpr int kStacks = 16, kSlices = 24;
  const uint32_t first = uint32_t(m.positions.size() / 3);
  for (int i = 0; i <= kStacks; ++i) {
    const double theta = kPi * i / kStacks;
    for (int j = 0; j <= kSlices; ++j) {
      const double phi = 2 * kPi * j / kSlices;
      const Vec3 n(std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi));
      m.add(centre + radius * n, n);
    }
  }
  for (int i = 0; i < kStacks; ++i)
    for (int j = 0; j < kSlices; ++j) {
      const uint32_t a = first + uint32_t(i * (kSlices + 1) + j), b = a + 1, c = a + kSlices + 1, d = c + 1;
      m.triangles.insert(m.triangles.end(), {a, b, d, a, d, c});
    }
}

// A cone or cylinder along base → apex with radii r0 at the base and r1 at the other end, with
// a cap over the base; outward normals.
void add_frustum(Mesh& m, const Vec3& base, const Vec3& end, double r0, double r1) {
  constexpr int kSides = 24;
  const Vec3 axis = (end - base).normalized();
  const double len = (end - base).norm();
  Vec3 a, b;
  perpendiculars(axis, a, b);
  const double slope = (r0 - r1) / len;  // normal tilt towards the axis for a cone
  const uint32_t first = uint32_t(m.positions.size() / 3);
  for (int j = 0; j <= kSides; ++j) {
    const double phi = 2 * kPi * j / kSides;
    const Vec3 radial = std::cos(phi) * a + std::sin(phi) * b;
    const Vec3 n = (radial + slope * axis).normalized();
    m.add(base + r0 * radial, n);
    m.add(end + r1 * radial, n);
  }
  for (int j = 0; j < kSides; ++j) {
    const uint32_t p = first + uint32_t(2 * j);
    m.triangles.insert(m.triangles.end(), {p, p + 3, p + 1, p, p + 2, p + 3});
  }
  // Base cap, facing −axis.
  const uint32_t centre = m.add(base, -axis);
  const uint32_t ring = uint32_t(m.positions.size() / 3);
  for (int j = 0; j <= kSides; ++j) {
    const double phi = 2 * kPi * j / kSides;
    m.add(base + r0 * (std::cos(phi) * a + std::sin(phi) * b), -axis);
  }
  for (int j = 0; j < kSides; ++j) m.triangles.insert(m.triangles.end(), {centre, ring + j + 1, ring + j});
}

// Area-weighted vertex normals of a triangle surface (for a RenderSurface given without them).
std::vector<float> vertex_normals(std::span<const float> p, std::span<const uint32_t> t) {
  std::vector<float> n(p.size(), 0.0f);
  for (size_t f = 0; f + 2 < t.size(); f += 3) {
    const Vec3f a(p[3 * t[f]], p[3 * t[f] + 1], p[3 * t[f] + 2]);
    const Vec3f b(p[3 * t[f + 1]], p[3 * t[f + 1] + 1], p[3 * t[f + 1] + 2]);
    const Vec3f c(p[3 * t[f + 2]], p[3 * t[f + 2] + 1], p[3 * t[f + 2] + 2]);
    const Vec3f fn = (b - a).cross(c - a);
    for (int k = 0; k < 3; ++k)
      for (int d = 0; d < 3; ++d) n[3 * t[f + k] + d] += fn[d];
  }
  for (size_t i = 0; i + 2 < n.size(); i += 3) {
    const float len = std::sqrt(n[i] * n[i] + n[i + 1] * n[i + 1] + n[i + 2] * n[i + 2]);
    if (len > 0) n[i] /= len, n[i + 1] /= len, n[i + 2] /= len;
  }
  return n;
}

// --- OpenGL --------------------------------------------------------------------------------------

// Blinn-Phong per pixel, lit from a light fixed to the camera; two-sided (a back face is lit with
// its normal flipped, so both sides of an open patch read as surfaces), keeping the colour's alpha
// (see-through surfaces). `lit` = 0 draws flat colour (lines, points); `round_points` cuts point
// sprites to discs.
const char* kVertexShader = R"(#version 120
varying vec3 n_eye;
varying vec3 p_eye;
void main() {
  p_eye = vec3(gl_ModelViewMatrix * gl_Vertex);
  n_eye = gl_NormalMatrix * gl_Normal;
  gl_FrontColor = gl_Color;
  gl_Position = ftransform();
}
)";

const char* kFragmentShader = R"(#version 120
varying vec3 n_eye;
varying vec3 p_eye;
uniform int lit;
uniform int round_points;
uniform vec3 light_eye;
void main() {
  if (round_points == 1 && length(gl_PointCoord - vec2(0.5)) > 0.5) discard;
  vec3 base = gl_Color.rgb;
  if (lit == 0) { gl_FragColor = vec4(base, 1.0); return; }
  vec3 v = normalize(-p_eye);
  vec3 n = length(n_eye) > 1e-20 ? normalize(n_eye) : v;
  if (!gl_FrontFacing) n = -n;
  float diffuse = max(dot(n, light_eye), 0.0);
  vec3 h = normalize(light_eye + v);
  float spec = diffuse > 0.0 ? pow(max(dot(n, h), 0.0), 40.0) : 0.0;
  gl_FragColor = vec4(base * (0.22 + 0.78 * diffuse) + vec3(0.22 * spec), gl_Color.a);
}
)";

struct ContextDeleter {
  void operator()(osmesa_context* c) const { OSMesaDestroyContext(c); }
};

Result<GLuint> compile_program() {
  auto compile = [](GLenum kind, const char* src, std::string& log) -> GLuint {
    const GLuint sh = glCreateShader(kind);
    glShaderSource(sh, 1, &src, nullptr);
    glCompileShader(sh);
    GLint ok = 0;
    glGetShaderiv(sh, GL_COMPILE_STATUS, &ok);
    if (!ok) {
      char buf[1024] = {};
      glGetShaderInfoLog(sh, sizeof buf, nullptr, buf);
      log = buf;
      glDeleteShader(sh);
      return 0;
    }
    return sh;
  };
  std::string log;
  const GLuint vs = compile(GL_VERTEX_SHADER, kVertexShader, log);
  if (!vs) return Error{"render: vertex shader does not compile: " + log};
  const GLuint fs = compile(GL_FRAGMENT_SHADER, kFragmentShader, log);
  if (!fs) return Error{"render: fragment shader does not compile: " + log};
  const GLuint prog = glCreateProgram();
  glAttachShader(prog, vs);
  glAttachShader(prog, fs);
  glLinkProgram(prog);
  GLint ok = 0;
  glGetProgramiv(prog, GL_LINK_STATUS, &ok);
  if (!ok) {
    char buf[1024] = {};
    glGetProgramInfoLog(prog, sizeof buf, nullptr, buf);
    return Error{std::string("render: shaders do not link: ") + buf};
  }
  return prog;
}

void draw_mesh(std::span<const float> positions, std::span<const float> normals,
               std::span<const uint32_t> triangles, const Vec3f& color) {
  if (triangles.empty()) return;
  glColor3f(color.x(), color.y(), color.z());
  glEnableClientState(GL_VERTEX_ARRAY);
  glEnableClientState(GL_NORMAL_ARRAY);
  glVertexPointer(3, GL_FLOAT, 0, positions.data());
  glNormalPointer(GL_FLOAT, 0, normals.data());
  glDrawElements(GL_TRIANGLES, GLsizei(triangles.size()), GL_UNSIGNED_INT, triangles.data());
  glDisableClientState(GL_NORMAL_ARRAY);
  glDisableClientState(GL_VERTEX_ARRAY);
}

// See-through surfaces (opacity < 1), drawn after everything opaque: all their triangles sorted
// far to near by the depth of their centroids along the view, blended over what is behind, without
// writing depth (so one never hides another behind it: skin over fat over the vessels all show).
// The image's alpha stays opaque. Sorting whole triangles is enough for layers a few mm apart seen
// through two or three sheets; where triangles of two sheets interleave the nearer wins anyway.
void draw_translucent(const RenderScene& scene, const CameraFrame& f) {
  struct Tri {
    double depth;
    uint32_t surface, first;  // the surface, and the triangle's first index in its triangles
  };
  std::vector<Tri> tris;
  std::vector<std::vector<float>> computed(scene.surfaces.size());
  for (size_t i = 0; i < scene.surfaces.size(); ++i) {
    const RenderSurface& m = scene.surfaces[i];
    if (m.opacity >= 1) continue;
    if (m.normals.empty()) computed[i] = vertex_normals(m.positions, m.triangles);
    for (size_t t = 0; t + 2 < m.triangles.size(); t += 3) {
      Vec3 c = Vec3::Zero();
      for (int k = 0; k < 3; ++k) {
        const size_t v = 3 * size_t(m.triangles[t + k]);
        c += Vec3(m.positions[v], m.positions[v + 1], m.positions[v + 2]);
      }
      tris.push_back({(c / 3 - f.eye).dot(f.forward), uint32_t(i), uint32_t(t)});
    }
  }
  if (tris.empty()) return;
  std::stable_sort(tris.begin(), tris.end(), [](const Tri& a, const Tri& b) { return a.depth > b.depth; });
  std::vector<float> p, n, c;  // (3 #T x 3), (3 #T x 3), (3 #T x 4): one vertex per corner
  p.reserve(tris.size() * 9), n.reserve(tris.size() * 9), c.reserve(tris.size() * 12);
  for (const Tri& t : tris) {
    const RenderSurface& m = scene.surfaces[t.surface];
    const std::span<const float> normals = m.normals.empty() ? std::span<const float>(computed[t.surface]) : m.normals;
    for (int k = 0; k < 3; ++k) {
      const size_t v = 3 * size_t(m.triangles[t.first + k]);
      p.insert(p.end(), {m.positions[v], m.positions[v + 1], m.positions[v + 2]});
      n.insert(n.end(), {normals[v], normals[v + 1], normals[v + 2]});
      c.insert(c.end(), {m.color.x(), m.color.y(), m.color.z(), m.opacity});
    }
  }
  glEnable(GL_BLEND);
  glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ZERO, GL_ONE);
  glDepthMask(GL_FALSE);
  glEnable(GL_POLYGON_OFFSET_FILL);
  glPolygonOffset(1.0f, 1.0f);
  glEnableClientState(GL_VERTEX_ARRAY);
  glEnableClientState(GL_NORMAL_ARRAY);
  glEnableClientState(GL_COLOR_ARRAY);
  glVertexPointer(3, GL_FLOAT, 0, p.data());
  glNormalPointer(GL_FLOAT, 0, n.data());
  glColorPointer(4, GL_FLOAT, 0, c.data());
  glDrawArrays(GL_TRIANGLES, 0, GLsizei(p.size() / 3));
  glDisableClientState(GL_COLOR_ARRAY);
  glDisableClientState(GL_NORMAL_ARRAY);
  glDisableClientState(GL_VERTEX_ARRAY);
  glDisable(GL_POLYGON_OFFSET_FILL);
  glDepthMask(GL_TRUE);
  glDisable(GL_BLEND);
}

// The depth range the scene's geometry spans in front of the camera, for near and far planes.
void depth_range(const RenderScene& s, const CameraFrame& f, double& near, double& far) {
  double lo = std::numeric_limits<double>::infinity(), hi = 0;
  auto see = [&](const Vec3& p, double pad) {
    const double d = (p - f.eye).dot(f.forward);
    lo = std::min(lo, d - pad);
    hi = std::max(hi, d + pad);
  };
  for (const auto& m : s.surfaces)
    for (size_t i = 0; i + 2 < m.positions.size(); i += 3)
      see(Vec3(m.positions[i], m.positions[i + 1], m.positions[i + 2]), 0);
  for (const auto& p : s.points)
    for (const auto& x : p.points) see(x.cast<double>(), 0);
  for (const auto& l : s.lines)
    for (const auto& x : l.points) see(x.cast<double>(), 0);
  if (s.tool) {
    see(s.tool->tip, s.tool->radius);
    if (s.tool->kind == "needle") see(s.tool->tip - s.tool->length * s.tool->axis.normalized(), s.tool->radius);
    if (s.tool->kind == "blade") {
      const BladeShape b = blade_shape(s.tool->tip, s.tool->axis, s.tool->length, s.tool->radius);
      const double pad = b.depth + b.handle_width;
      see(b.heel(), pad);
      see(b.heel() - b.handle_length * b.axis, pad);
    }
  }
  if (s.force) {
    see(s.force->origin, 0);
    see(s.force->origin + s.force->length_per_newton * s.force->force, 0);
  }
  if (!(hi > 0)) hi = (s.camera.target - s.camera.position).norm() * 2;
  far = hi * 1.05 + 1e-9;
  near = std::max(lo * 0.95, far * 1e-4);
}

}  // namespace

Result<Image> draw_offscreen(const RenderScene& scene, std::optional<Eye> eye) {
  const int ss = scene.supersample;
  const int w = scene.camera.width * ss, h = scene.camera.height * ss;

  std::unique_ptr<osmesa_context, ContextDeleter> ctx(OSMesaCreateContextExt(OSMESA_RGBA, 24, 0, 0, nullptr));
  if (!ctx) return Error{"render: cannot create a software OpenGL (OSMesa) context"};
  std::vector<uint8_t> buffer(size_t(w) * h * 4);
  if (!OSMesaMakeCurrent(ctx.get(), buffer.data(), GL_UNSIGNED_BYTE, w, h))
    return Error{"render: OSMesa cannot draw a " + std::to_string(w) + " x " + std::to_string(h) +
                 " image; expected a smaller camera size or supersample"};
  auto program = compile_program();
  if (!program) return program.error();

  CameraFrame frame = camera_frame(scene.camera);
  double near = 0, far = 0;
  depth_range(scene, frame, near, far);  // the same for both eyes: they sit beside the camera, not ahead
  // The camera's own matrices (separation 0), or an off-axis eye's (render.h, "Stereo").
  const EyeMatrices matrices = stereo_eye_matrices(
      frame.eye, frame.right, frame.up, frame.forward, scene.camera.fov, frame.aspect, near, far,
      eye ? scene.stereo.eye_separation : 0.0, stereo_convergence(scene.camera, scene.stereo), eye.value_or(Eye::left));
  frame.eye = matrices.position;  // the translucent surfaces sort back to front from it
  const Eigen::Matrix4d& proj = matrices.projection;
  const Eigen::Matrix4d& view = matrices.view;

  glViewport(0, 0, w, h);
  glClearColor(scene.background.x(), scene.background.y(), scene.background.z(), 1.0f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LEQUAL);
  glMatrixMode(GL_PROJECTION);
  glLoadMatrixd(proj.data());
  glMatrixMode(GL_MODELVIEW);
  glLoadMatrixd(view.data());
  glUseProgram(*program);
  const GLint lit = glGetUniformLocation(*program, "lit");
  const GLint round_points = glGetUniformLocation(*program, "round_points");
  const Eigen::Vector3f light = Eigen::Vector3f(-0.35f, 0.6f, 1.0f).normalized();  // eye space: above-left, behind
  glUniform3f(glGetUniformLocation(*program, "light_eye"), light.x(), light.y(), light.z());
  glUniform1i(round_points, 0);

  // Surfaces, pushed back a little so lines and points on them stay visible.
  glUniform1i(lit, 1);
  glEnable(GL_POLYGON_OFFSET_FILL);
  glPolygonOffset(1.0f, 1.0f);
  for (const RenderSurface& m : scene.surfaces) {
    if (m.opacity < 1) continue;  // drawn after the tool, below
    std::vector<float> computed;
    std::span<const float> normals = m.normals;
    if (normals.empty()) {
      computed = vertex_normals(m.positions, m.triangles);
      normals = computed;
    }
    draw_mesh(m.positions, normals, m.triangles, m.color);
  }
  glDisable(GL_POLYGON_OFFSET_FILL);

  Mesh tool;
  std::optional<std::array<Vec3f, 4>> blade_edge;  // two segments heel → tip, drawn with the lines below
  if (scene.tool) {
    const RenderTool& t = *scene.tool;
    if (t.kind == "sphere") {
      add_sphere(tool, t.tip, t.radius);
    } else if (t.kind == "blade") {
      // The scalpel (core/blade_shape.h): the blade in steel, its handle darker, and its cutting
      // edge drawn over the blade as a bright line so the part that cuts is the part one sees.
      const BladeShape b = blade_shape(t.tip, t.axis, t.length, t.radius);
      BladeMesh blade, handle;
      append_blade(blade, b);
      append_blade_handle(handle, b);
      draw_mesh(blade.positions, blade.normals, blade.triangles, t.color);
      draw_mesh(handle.positions, handle.normals, handle.triangles, 0.45f * t.color);
      Vec3 edge[4];
      blade_edge_lines(b, edge);
      blade_edge = {edge[0].cast<float>(), edge[1].cast<float>(), edge[2].cast<float>(), edge[3].cast<float>()};
    } else {
      const Vec3 axis = t.axis.normalized();
      const double bevel = std::min(4 * t.radius, 0.5 * t.length);  // the sharpened tip
      add_frustum(tool, t.tip - t.length * axis, t.tip - bevel * axis, t.radius, t.radius);
      add_frustum(tool, t.tip - bevel * axis, t.tip, t.radius, 0.0);
    }
    if (!tool.triangles.empty()) draw_mesh(tool.positions, tool.normals, tool.triangles, t.color);
  }
  draw_translucent(scene, frame);

  // Lines and points, unlit.
  glUniform1i(lit, 0);
  glEnableClientState(GL_VERTEX_ARRAY);
  for (const RenderSurface& m : scene.surfaces) {
    if (!m.wireframe || m.triangles.empty()) continue;
    glColor3f(0.5f * m.color.x(), 0.5f * m.color.y(), 0.5f * m.color.z());
    glLineWidth(float(ss));
    glPolygonMode(GL_FRONT_AND_BACK, GL_LINE);
    glVertexPointer(3, GL_FLOAT, 0, m.positions.data());
    glDrawElements(GL_TRIANGLES, GLsizei(m.triangles.size()), GL_UNSIGNED_INT, m.triangles.data());
    glPolygonMode(GL_FRONT_AND_BACK, GL_FILL);
  }
  for (const RenderLines& l : scene.lines) {
    if (l.segments.empty()) continue;
    glColor3f(l.color.x(), l.color.y(), l.color.z());
    glLineWidth(std::max(1.0f, l.width * float(ss)));
    glVertexPointer(3, GL_FLOAT, sizeof(Vec3f), l.points.data());
    // Segment indices are validated non-negative ints, which GL reads as unsigned.
    glDrawElements(GL_LINES, GLsizei(2 * l.segments.size()), GL_UNSIGNED_INT, l.segments.data());
  }
  if (blade_edge) {  // the cutting edge, bright against the steel
    glColor3f(1.0f, 0.92f, 0.55f);
    glLineWidth(2.0f * float(ss));
    glVertexPointer(3, GL_FLOAT, sizeof(Vec3f), blade_edge->data());
    glDrawArrays(GL_LINES, 0, 4);
  }
  glEnable(GL_POINT_SPRITE);
  glUniform1i(round_points, 1);
  for (const RenderPoints& p : scene.points) {
    if (p.points.empty()) continue;
    glColor3f(p.color.x(), p.color.y(), p.color.z());
    glPointSize(std::max(1.0f, p.size * float(ss)));
    glVertexPointer(3, GL_FLOAT, sizeof(Vec3f), p.points.data());
    glDrawArrays(GL_POINTS, 0, GLsizei(p.points.size()));
  }
  glUniform1i(round_points, 0);
  glDisable(GL_POINT_SPRITE);
  glDisableClientState(GL_VERTEX_ARRAY);

  // The force arrow over everything: shaft and head, lit.
  if (scene.force) {
    const RenderArrow& a = *scene.force;
    const Vec3 span = a.length_per_newton * a.force;
    const double len = span.norm();
    if (len > 1e-12) {
      Mesh arrow;
      const Vec3 dir = span / len;
      const double head = 0.28 * len, shaft_r = 0.035 * len, head_r = 0.1 * len;
      add_frustum(arrow, a.origin, a.origin + (len - head) * dir, shaft_r, shaft_r);
      add_frustum(arrow, a.origin + (len - head) * dir, a.origin + span, head_r, 0.0);
      glClear(GL_DEPTH_BUFFER_BIT);
      glUniform1i(lit, 1);
      draw_mesh(arrow.positions, arrow.normals, arrow.triangles, a.color);
    }
  }
  glFinish();
  const GLenum err = glGetError();
  glUseProgram(0);
  glDeleteProgram(*program);
  if (err != GL_NO_ERROR) return Error{"render: OpenGL error " + std::to_string(err) + " while drawing"};

  // OSMesa's rows run bottom to top; average ss x ss blocks into the image, top row first.
  Image img;
  img.width = scene.camera.width;
  img.height = scene.camera.height;
  img.rgba.resize(size_t(img.width) * img.height * 4);
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      for (int c = 0; c < 4; ++c) {
        int sum = 0;
        for (int j = 0; j < ss; ++j)
          for (int i = 0; i < ss; ++i) {
            const int gy = h - 1 - (y * ss + j), gx = x * ss + i;
            sum += buffer[(size_t(gy) * w + gx) * 4 + c];
          }
        img.rgba[(size_t(y) * img.width + x) * 4 + c] = uint8_t((sum + ss * ss / 2) / (ss * ss));
      }
  return img;
}

}  // namespace palpate::render
