// test_render_doc_images.cpp — writes docs/images' surface comparison; disabled, run on demand:
//   ./build/release/tests/palpate_tests --gtest_also_run_disabled_tests --gtest_filter='DocImages.*'
#include <palpate/render.h>
#include <palpate/surface.h>

#include "components.h"
#include <gtest/gtest.h>

#include <filesystem>
#include <vector>

namespace {

using namespace palpate;

// A 13 x 13 control grid (4 x 4 Bézier patches), 3 mm spacing, with control point (6,6) — the
// corner shared by four Bézier patches — pressed 8 mm down, as a probe would.
std::vector<Vec3f> dented_grid(int n) {
  std::vector<Vec3f> g(size_t(n) * n);
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) g[size_t(r) * n + c] = Vec3f(0.003f * (c - (n - 1) / 2.0f), 0, -0.003f * (r - (n - 1) / 2.0f));
  g[size_t(6) * n + 6].y() = -0.008f;
  return g;
}

void write(SurfaceScheme scheme, const std::filesystem::path& file) {
  const int n = 13;
  const auto grid = dented_grid(n);
  auto surface = tessellate_grid(grid, n, n, {scheme, scheme == SurfaceScheme::bezier ? 24 : 8});
  ASSERT_TRUE(surface.ok());
  RenderScene s;
  s.camera.position = Vec3(0.016, 0.013, 0.024);
  s.camera.target = Vec3(0, -0.003, 0);
  s.camera.fov = 40;
  s.camera.width = 360;
  s.camera.height = 240;
  s.surfaces.push_back({surface->positions, surface->normals, surface->triangles});
  const auto segments = grid_lines(n, n);
  s.lines.push_back({grid, segments, Vec3f(0.25f, 0.25f, 0.3f), 1.0f});
  s.points.push_back({grid, Vec3f(0.15f, 0.35f, 0.9f), 3.0f});
  const auto st = render_png(s, file);
  ASSERT_TRUE(st.ok()) << st.error().message;
}

}  // namespace

TEST(DocImages, DISABLED_WriteSurfaceComparison) {
  PALPATE_NEEDS(OSMESA, "OSMesa");
  const std::filesystem::path dir = std::filesystem::path(PALPATE_SOURCE_DIR) / "docs" / "images";
  std::filesystem::create_directories(dir);
  write(SurfaceScheme::bezier, dir / "surface_bezier_dent.png");
  write(SurfaceScheme::bspline, dir / "surface_bspline_dent.png");
}
