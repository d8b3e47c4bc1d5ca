// gl_draw.h — the viewer's OpenGL 3.3 core drawing (through libepoxy, in the GLFW window's
// context): lit triangles, lines, round points, and the tool and force-arrow meshes.
#pragma once

#include <palpate/core.h>

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace palpate::view {

// Triangles with per-vertex normals, built on the CPU (tool, arrow), in world coordinates.
struct TriangleMesh {
  std::vector<float> positions;        // (#P x 3) m
  std::vector<float> normals;          // (#P x 3) unit
  std::vector<std::uint32_t> triangles;  // (#T x 3)
  void clear() {
    positions.clear();
    normals.clear();
    triangles.clear();
  }
};

// Append a sphere of `radius` about `center` (UV sphere, `slices` x `stacks`).
void append_sphere(TriangleMesh& mesh, const Vec3& center, double radius, int slices = 20, int stacks = 12);
// Append a closed cylinder from a to b (radius r) or, with r_b = 0, a cone; `slices` around.
void append_cylinder(TriangleMesh& mesh, const Vec3& a, const Vec3& b, double r_a, double r_b, int slices = 16);
// An arrow from `origin` of length |direction| along it: a shaft and a cone head.
void append_arrow(TriangleMesh& mesh, const Vec3& origin, const Vec3& direction, double shaft_radius);

// GPU programs and stream buffers; one per GL context. All calls need that context current.
class GlDraw {
 public:
  GlDraw() = default;
  ~GlDraw();
  GlDraw(const GlDraw&) = delete;
  GlDraw& operator=(const GlDraw&) = delete;

  // Compile the shaders and make the buffers; false with `error` filled when GL refuses.
  bool init(std::string& error);
  // Per frame: the combined projection·view matrix (column-major) and the eye position (m).
  void set_camera(const Eigen::Matrix4f& projection_view, const Vec3& eye);
  void clear(const Vec3f& background, int width, int height);

  // Lit, two-sided triangles; normals (#P x 3) matching positions.
  void triangles(std::span<const float> positions, std::span<const float> normals,
                 std::span<const std::uint32_t> indices, const Vec3f& color, bool on_top = false);
  void triangles(const TriangleMesh& mesh, const Vec3f& color, bool on_top = false) {
    triangles(mesh.positions, mesh.normals, mesh.triangles, color, on_top);
  }
  // Line segments between points (1 pixel wide: core profile has no wide lines).
  void lines(std::span<const Vec3f> points, std::span<const std::array<int, 2>> segments, const Vec3f& color);
  // Round dots of `size` pixels.
  void points(std::span<const Vec3f> points, const Vec3f& color, float size);

 private:
  unsigned lit_program_ = 0, flat_program_ = 0;
  int lit_mvp_ = -1, lit_eye_ = -1, lit_color_ = -1;
  int flat_mvp_ = -1, flat_color_ = -1, flat_size_ = -1, flat_round_ = -1;
  unsigned vao_ = 0, position_buffer_ = 0, normal_buffer_ = 0, index_buffer_ = 0;
  Eigen::Matrix4f projection_view_ = Eigen::Matrix4f::Identity();
  Vec3f eye_ = Vec3f::Zero();
  std::vector<std::uint32_t> line_indices_;  // scratch for lines(), reused every frame
};

}  // namespace palpate::view
