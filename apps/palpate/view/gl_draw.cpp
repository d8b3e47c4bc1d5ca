// gl_draw.cpp — GlDraw's shaders and stream buffers (OpenGL 3.3 core through libepoxy), and the
// CPU-built meshes of the tool and the force arrow.
#include "gl_draw.h"

#include <epoxy/gl.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace palpate::view {

namespace {

// Two-sided headlight shading: a surface is lit by a light at the eye, whichever side faces it.
constexpr const char* kLitVertex = R"(#version 330 core
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
uniform mat4 mvp;
out vec3 world_position;
out vec3 world_normal;
void main() {
  world_position = position;
  world_normal = normal;
  gl_Position = mvp * vec4(position, 1.0);
}
)";

constexpr const char* kLitFragment = R"(#version 330 core
in vec3 world_position;
in vec3 world_normal;
uniform vec3 eye;
uniform vec3 color;
out vec4 frag;
void main() {
  vec3 n = normalize(world_normal);
  vec3 v = normalize(eye - world_position);
  if (dot(n, v) < 0.0) n = -n;
  float diffuse = max(dot(n, v), 0.0);
  float specular = pow(max(dot(reflect(-v, n), v), 0.0), 32.0);
  frag = vec4(color * (0.25 + 0.75 * diffuse) + vec3(0.25 * specular), 1.0);
}
)";

constexpr const char* kFlatVertex = R"(#version 330 core
layout(location = 0) in vec3 position;
uniform mat4 mvp;
uniform float point_size;
void main() {
  gl_Position = mvp * vec4(position, 1.0);
  gl_PointSize = point_size;
}
)";

constexpr const char* kFlatFragment = R"(#version 330 core
uniform vec3 color;
uniform int round_points;
out vec4 frag;
void main() {
  if (round_points != 0 && length(gl_PointCoord - vec2(0.5)) > 0.5) discard;
  frag = vec4(color, 1.0);
}
)";

unsigned compile(GLenum kind, const char* source, std::string& error) {
  const GLuint shader = glCreateShader(kind);
  glShaderSource(shader, 1, &source, nullptr);
  glCompileShader(shader);
  GLint ok = 0;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[2048] = {};
    glGetShaderInfoLog(shader, sizeof log, nullptr, log);
    error = std::string(kind == GL_VERTEX_SHADER ? "vertex" : "fragment") + " shader: " + log;
    glDeleteShader(shader);
    return 0;
  }
  return shader;
}

unsigned link(const char* vertex, const char* fragment, std::string& error) {
  const unsigned vs = compile(GL_VERTEX_SHADER, vertex, error);
  if (!vs) return 0;
  const unsigned fs = compile(GL_FRAGMENT_SHADER, fragment, error);
  if (!fs) {
    glDeleteShader(vs);
    return 0;
  }
  const GLuint program = glCreateProgram();
  glAttachShader(program, vs);
  glAttachShader(program, fs);
  glLinkProgram(program);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(program, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[2048] = {};
    glGetProgramInfoLog(program, sizeof log, nullptr, log);
    error = std::string("shader program: ") + log;
    glDeleteProgram(program);
    return 0;
  }
  return program;
}

// Two unit vectors perpendicular to `axis` (unit) and to each other.
void basis(const Vec3& axis, Vec3& u, Vec3& v) {
  const Vec3 helper = std::abs(axis.y()) < 0.9 ? Vec3::UnitY() : Vec3::UnitX();
  u = axis.cross(helper).normalized();
  v = axis.cross(u);
}

void push(std::vector<float>& out, const Vec3& p) {
  out.push_back(static_cast<float>(p.x()));
  out.push_back(static_cast<float>(p.y()));
  out.push_back(static_cast<float>(p.z()));
}

}  // namespace

void append_sphere(TriangleMesh& mesh, const Vec3& center, double radius, int slices, int stacks) {
  const auto base = static_cast<std::uint32_t>(mesh.positions.size() / 3);
  for (int i = 0; i <= stacks; ++i) {
    const double theta = std::numbers::pi * i / stacks;
    for (int j = 0; j <= slices; ++j) {
      const double phi = 2 * std::numbers::pi * j / slices;
      const Vec3 n(std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi));
      push(mesh.positions, center + radius * n);
      push(mesh.normals, n);
    }
  }
  const auto row = static_cast<std::uint32_t>(slices + 1);
  for (std::uint32_t i = 0; i < static_cast<std::uint32_t>(stacks); ++i)
    for (std::uint32_t j = 0; j < static_cast<std::uint32_t>(slices); ++j) {
      const std::uint32_t a = base + i * row + j, b = a + row;
      mesh.triangles.insert(mesh.triangles.end(), {a, b, a + 1, a + 1, b, b + 1});
    }
}

void append_cylinder(TriangleMesh& mesh, const Vec3& a, const Vec3& b, double r_a, double r_b, int slices) {
  const Vec3 axis_vec = b - a;
  const double length = axis_vec.norm();
  if (!(length > 0)) return;
  const Vec3 axis = axis_vec / length;
  Vec3 u, v;
  basis(axis, u, v);
  // The side's normal tilts towards the narrow end by the cone's slope.
  const double slope = (r_a - r_b) / length;
  const auto base = static_cast<std::uint32_t>(mesh.positions.size() / 3);
  for (int j = 0; j <= slices; ++j) {
    const double phi = 2 * std::numbers::pi * j / slices;
    const Vec3 radial = std::cos(phi) * u + std::sin(phi) * v;
    const Vec3 n = (radial + slope * axis).normalized();
    push(mesh.positions, a + r_a * radial);
    push(mesh.normals, n);
    push(mesh.positions, b + r_b * radial);
    push(mesh.normals, n);
  }
  for (std::uint32_t j = 0; j < static_cast<std::uint32_t>(slices); ++j) {
    const std::uint32_t k = base + 2 * j;
    mesh.triangles.insert(mesh.triangles.end(), {k, k + 2, k + 1, k + 1, k + 2, k + 3});
  }
  // Caps (flat discs) where the radius is not zero.
  for (int end = 0; end < 2; ++end) {
    const double r = end == 0 ? r_a : r_b;
    if (r <= 0) continue;
    const Vec3 c = end == 0 ? a : b;
    const Vec3 n = end == 0 ? Vec3(-axis) : axis;
    const auto centre = static_cast<std::uint32_t>(mesh.positions.size() / 3);
    push(mesh.positions, c);
    push(mesh.normals, n);
    for (int j = 0; j <= slices; ++j) {
      const double phi = 2 * std::numbers::pi * j / slices;
      push(mesh.positions, c + r * (std::cos(phi) * u + std::sin(phi) * v));
      push(mesh.normals, n);
    }
    for (std::uint32_t j = 0; j < static_cast<std::uint32_t>(slices); ++j)
      mesh.triangles.insert(mesh.triangles.end(), {centre, centre + 1 + j, centre + 2 + j});
  }
}

void append_arrow(TriangleMesh& mesh, const Vec3& origin, const Vec3& direction, double shaft_radius) {
  const double length = direction.norm();
  if (!(length > 0) || !std::isfinite(length)) return;
  const Vec3 axis = direction / length;
  // The head is 3 shaft radii wide and at most a quarter of the arrow long.
  const double head = std::min(0.25 * length, 8 * shaft_radius);
  const Vec3 neck = origin + (length - head) * axis;
  append_cylinder(mesh, origin, neck, shaft_radius, shaft_radius);
  append_cylinder(mesh, neck, origin + direction, 3 * shaft_radius, 0.0);
}

GlDraw::~GlDraw() {
  // Only when init() ran (and so a context existed); the caller destroys us before the context.
  if (vao_) glDeleteVertexArrays(1, &vao_);
  if (position_buffer_) glDeleteBuffers(1, &position_buffer_);
  if (normal_buffer_) glDeleteBuffers(1, &normal_buffer_);
  if (index_buffer_) glDeleteBuffers(1, &index_buffer_);
  if (lit_program_) glDeleteProgram(lit_program_);
  if (flat_program_) glDeleteProgram(flat_program_);
}

bool GlDraw::init(std::string& error) {
  lit_program_ = link(kLitVertex, kLitFragment, error);
  if (!lit_program_) return false;
  flat_program_ = link(kFlatVertex, kFlatFragment, error);
  if (!flat_program_) return false;
  lit_mvp_ = glGetUniformLocation(lit_program_, "mvp");
  lit_eye_ = glGetUniformLocation(lit_program_, "eye");
  lit_color_ = glGetUniformLocation(lit_program_, "color");
  flat_mvp_ = glGetUniformLocation(flat_program_, "mvp");
  flat_color_ = glGetUniformLocation(flat_program_, "color");
  flat_size_ = glGetUniformLocation(flat_program_, "point_size");
  flat_round_ = glGetUniformLocation(flat_program_, "round_points");
  glGenVertexArrays(1, &vao_);
  glGenBuffers(1, &position_buffer_);
  glGenBuffers(1, &normal_buffer_);
  glGenBuffers(1, &index_buffer_);
  glBindVertexArray(vao_);
  glBindBuffer(GL_ARRAY_BUFFER, position_buffer_);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
  glEnableVertexAttribArray(0);
  glBindBuffer(GL_ARRAY_BUFFER, normal_buffer_);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
  glBindVertexArray(0);
  const GLenum status = glGetError();
  if (status != GL_NO_ERROR) {
    error = "OpenGL error " + std::to_string(status) + " while making the viewer's buffers";
    return false;
  }
  return true;
}

void GlDraw::set_camera(const Eigen::Matrix4f& projection_view, const Vec3& eye) {
  projection_view_ = projection_view;
  eye_ = eye.cast<float>();
}

void GlDraw::clear(const Vec3f& background, int width, int height) {
  glViewport(0, 0, width, height);
  glClearColor(background.x(), background.y(), background.z(), 1.0f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDisable(GL_CULL_FACE);
  glEnable(GL_PROGRAM_POINT_SIZE);
}

void GlDraw::triangles(std::span<const float> positions, std::span<const float> normals,
                       std::span<const std::uint32_t> indices, const Vec3f& color, bool on_top) {
  if (indices.empty() || positions.empty() || normals.size() != positions.size()) return;
  glUseProgram(lit_program_);
  glUniformMatrix4fv(lit_mvp_, 1, GL_FALSE, projection_view_.data());
  glUniform3fv(lit_eye_, 1, eye_.data());
  glUniform3fv(lit_color_, 1, color.data());
  glBindVertexArray(vao_);
  glBindBuffer(GL_ARRAY_BUFFER, position_buffer_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(positions.size_bytes()), positions.data(), GL_STREAM_DRAW);
  glBindBuffer(GL_ARRAY_BUFFER, normal_buffer_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(normals.size_bytes()), normals.data(), GL_STREAM_DRAW);
  glEnableVertexAttribArray(1);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, index_buffer_);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(indices.size_bytes()), indices.data(), GL_STREAM_DRAW);
  if (on_top) glDisable(GL_DEPTH_TEST);
  glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(indices.size()), GL_UNSIGNED_INT, nullptr);
  if (on_top) glEnable(GL_DEPTH_TEST);
  glDisableVertexAttribArray(1);
  glBindVertexArray(0);
}

void GlDraw::lines(std::span<const Vec3f> points, std::span<const std::array<int, 2>> segments,
                   const Vec3f& color) {
  if (points.empty() || segments.empty()) return;
  line_indices_.clear();
  const auto n = static_cast<int>(points.size());
  for (const auto& s : segments)
    if (s[0] >= 0 && s[1] >= 0 && s[0] < n && s[1] < n) {
      line_indices_.push_back(static_cast<std::uint32_t>(s[0]));
      line_indices_.push_back(static_cast<std::uint32_t>(s[1]));
    }
  glUseProgram(flat_program_);
  glUniformMatrix4fv(flat_mvp_, 1, GL_FALSE, projection_view_.data());
  glUniform3fv(flat_color_, 1, color.data());
  glUniform1f(flat_size_, 1.0f);
  glUniform1i(flat_round_, 0);
  glBindVertexArray(vao_);
  glBindBuffer(GL_ARRAY_BUFFER, position_buffer_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(points.size() * sizeof(Vec3f)), points.data(), GL_STREAM_DRAW);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, index_buffer_);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(line_indices_.size() * sizeof(std::uint32_t)),
               line_indices_.data(), GL_STREAM_DRAW);
  glDrawElements(GL_LINES, static_cast<GLsizei>(line_indices_.size()), GL_UNSIGNED_INT, nullptr);
  glBindVertexArray(0);
}

void GlDraw::points(std::span<const Vec3f> pts, const Vec3f& color, float size) {
  if (pts.empty()) return;
  glUseProgram(flat_program_);
  glUniformMatrix4fv(flat_mvp_, 1, GL_FALSE, projection_view_.data());
  glUniform3fv(flat_color_, 1, color.data());
  glUniform1f(flat_size_, size);
  glUniform1i(flat_round_, 1);
  glBindVertexArray(vao_);
  glBindBuffer(GL_ARRAY_BUFFER, position_buffer_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(pts.size() * sizeof(Vec3f)), pts.data(), GL_STREAM_DRAW);
  glDrawArrays(GL_POINTS, 0, static_cast<GLsizei>(pts.size()));
  glBindVertexArray(0);
}

}  // namespace palpate::view
