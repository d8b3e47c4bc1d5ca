// test_render_offscreen.cpp — off-screen images checked by content: coverage, dents, arrow, tool.
#include <palpate/render.h>
#include <palpate/surface.h>

#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_STATIC
#include <stb/stb_image.h>

#include "components.h"
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <vector>

using palpate::CameraDef;
using palpate::Image;
using palpate::RenderScene;
using palpate::Vec3;
using palpate::Vec3f;

namespace {

CameraDef test_camera() {
  CameraDef c;
  c.position = Vec3(0.03, 0.05, 0.06);
  c.target = Vec3::Zero();
  c.fov = 40;
  c.width = 160;
  c.height = 120;
  return c;
}

bool is_background(const Image& img, int x, int y, const Vec3f& bg) {
  const uint8_t* p = img.pixel(x, y);
  for (int c = 0; c < 3; ++c)
    if (std::abs(int(p[c]) - int(std::lround(bg[c] * 255))) > 1) return false;
  return true;
}

bool differ(const Image& a, const Image& b, int x, int y) {
  const uint8_t *p = a.pixel(x, y), *q = b.pixel(x, y);
  return std::abs(p[0] - q[0]) + std::abs(p[1] - q[1]) + std::abs(p[2] - q[2]) > 6;
}

Eigen::Vector2d project(const CameraDef& c, const Vec3& p) {
  auto px = palpate::project_to_pixel(c, p);
  EXPECT_TRUE(px.has_value());
  return px.value_or(Eigen::Vector2d::Zero());
}

// Signed distance (pixels) from q to a convex polygon given counter- or clockwise: > 0 inside.
double inside_distance(const std::vector<Eigen::Vector2d>& poly, const Eigen::Vector2d& q) {
  double area = 0;
  for (size_t i = 0; i < poly.size(); ++i) {
    const auto& a = poly[i];
    const auto& b = poly[(i + 1) % poly.size()];
    area += a.x() * b.y() - b.x() * a.y();
  }
  const double sign = area > 0 ? 1 : -1;
  double d = 1e30;
  for (size_t i = 0; i < poly.size(); ++i) {
    const Eigen::Vector2d a = poly[i], e = poly[(i + 1) % poly.size()] - a;
    const double cross = e.x() * (q - a).y() - e.y() * (q - a).x();
    d = std::min(d, sign * cross / e.norm());
  }
  return d;
}

// Distance from q to segment ab.
double segment_distance(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& q) {
  const Eigen::Vector2d e = b - a;
  const double t = std::clamp((q - a).dot(e) / e.squaredNorm(), 0.0, 1.0);
  return (a + t * e - q).norm();
}

// A flat rows x cols control grid in y = 0 centred on the origin, spacing h, rows along −z.
std::vector<Vec3f> flat_grid(int rows, int cols, float h) {
  std::vector<Vec3f> g(size_t(rows) * cols);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      g[size_t(r) * cols + c] = Vec3f(h * (c - (cols - 1) / 2.0f), 0.0f, -h * (r - (rows - 1) / 2.0f));
  return g;
}

Image render(const RenderScene& s) {
  auto img = palpate::render_rgba(s);
  EXPECT_TRUE(img.ok()) << (img.ok() ? "" : img.error().message);
  return img.ok() ? std::move(img).value() : Image{};
}

}  // namespace

TEST(RenderOffscreen, ProjectionPutsTheTargetAtTheCentre) {
  const CameraDef c = test_camera();
  const auto centre = project(c, c.target);
  EXPECT_NEAR(centre.x(), 80.0, 1e-9);
  EXPECT_NEAR(centre.y(), 60.0, 1e-9);
  // The camera looks from +x+z: +x−z goes right on screen, +y goes up (smaller y).
  EXPECT_GT(project(c, Vec3(0.01, 0, -0.01)).x(), 80.0);
  EXPECT_LT(project(c, Vec3(0, 0.01, 0)).y(), 60.0);
  EXPECT_FALSE(palpate::project_to_pixel(c, c.position + (c.position - c.target)).has_value());
}

TEST(RenderOffscreen, SurfaceCoversExactlyWhereItProjects) {
  PALPATE_NEEDS(OSMESA, "OSMesa");
  const auto grid = flat_grid(4, 4, 0.01f);  // 3 cm square
  auto surface = palpate::tessellate_grid(grid, 4, 4, {palpate::SurfaceScheme::bezier, 4});
  ASSERT_TRUE(surface.ok());
  for (int ss : {1, 2}) {
    RenderScene s;
    s.camera = test_camera();
    s.supersample = ss;
    s.surfaces.push_back({surface->positions, surface->normals, surface->triangles});
    const Image img = render(s);
    ASSERT_EQ(img.width, 160);
    ASSERT_EQ(img.height, 120);
    const std::vector<Eigen::Vector2d> quad = {project(s.camera, grid[0].cast<double>()),
                                               project(s.camera, grid[3].cast<double>()),
                                               project(s.camera, grid[15].cast<double>()),
                                               project(s.camera, grid[12].cast<double>())};
    int inside = 0, outside = 0;
    for (int y = 0; y < img.height; ++y)
      for (int x = 0; x < img.width; ++x) {
        const double d = inside_distance(quad, Eigen::Vector2d(x + 0.5, y + 0.5));
        if (d > 1.5) {
          ++inside;
          EXPECT_FALSE(is_background(img, x, y, s.background)) << "ss " << ss << " pixel " << x << "," << y;
        } else if (d < -1.5) {
          ++outside;
          EXPECT_TRUE(is_background(img, x, y, s.background)) << "ss " << ss << " pixel " << x << "," << y;
        }
      }
    EXPECT_GT(inside, 1000);
    EXPECT_GT(outside, 5000);
  }
}

TEST(RenderOffscreen, ADentShowsAsAPixelDifferenceAroundIt) {
  PALPATE_NEEDS(OSMESA, "OSMesa");
  const int rows = 10, cols = 10;
  auto grid = flat_grid(rows, cols, 0.004f);
  auto tess = palpate::SurfaceTessellator::build(rows, cols, {palpate::SurfaceScheme::bezier, 8});
  ASSERT_TRUE(tess.ok());
  palpate::SurfaceBuffers flat, dented;
  ASSERT_TRUE(tess->tessellate(grid, flat));
  grid[size_t(4) * cols + 4].y() -= 0.008f;  // control point (4,4): only patch (1,1) moves
  ASSERT_TRUE(tess->tessellate(grid, dented));

  RenderScene s;
  s.camera = test_camera();
  s.surfaces.push_back({flat.positions, flat.normals, flat.triangles});
  const Image a = render(s);
  s.surfaces[0] = {dented.positions, dented.normals, dented.triangles};
  const Image b = render(s);

  // Where the dent's patch can project: its 16 control points' (dented) projections, bounded.
  double x0 = 1e9, x1 = -1e9, y0 = 1e9, y1 = -1e9;
  for (int r = 3; r <= 6; ++r)
    for (int c = 3; c <= 6; ++c) {
      const auto p = project(s.camera, grid[size_t(r) * cols + c].cast<double>());
      x0 = std::min(x0, p.x()), x1 = std::max(x1, p.x()), y0 = std::min(y0, p.y()), y1 = std::max(y1, p.y());
    }
  const auto dent = project(s.camera, tess->evaluate(grid, 1, 1, 1.0f / 3, 1.0f / 3).position.cast<double>());
  int changed = 0, near_dent = 0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      if (!differ(a, b, x, y)) continue;
      ++changed;
      EXPECT_TRUE(x + 0.5 > x0 - 2 && x + 0.5 < x1 + 2 && y + 0.5 > y0 - 2 && y + 0.5 < y1 + 2)
          << "pixel " << x << "," << y << " changed outside the dented patch";
      if ((Eigen::Vector2d(x + 0.5, y + 0.5) - dent).norm() < 4) ++near_dent;
    }
  EXPECT_GT(changed, 30);
  EXPECT_GT(near_dent, 0);
}

TEST(RenderOffscreen, TheForceArrowShowsWhereItPoints) {
  PALPATE_NEEDS(OSMESA, "OSMesa");
  const auto grid = flat_grid(4, 4, 0.01f);
  auto surface = palpate::tessellate_grid(grid, 4, 4, {palpate::SurfaceScheme::bezier, 4});
  ASSERT_TRUE(surface.ok());
  RenderScene s;
  s.camera = test_camera();
  s.surfaces.push_back({surface->positions, surface->normals, surface->triangles});
  const Image without = render(s);
  palpate::RenderArrow arrow;
  arrow.origin = Vec3(-0.005, 0.0, 0.005);
  arrow.force = Vec3(0.0, 1.5, 0.0);  // N
  arrow.length_per_newton = 0.01;     // 1.5 cm
  s.force = arrow;
  const Image with = render(s);

  const auto from = project(s.camera, arrow.origin);
  const auto to = project(s.camera, arrow.origin + 0.015 * Vec3::UnitY());
  const double depth = (arrow.origin - s.camera.position).norm();
  const double px_per_m = 0.5 * s.camera.height / std::tan(0.5 * s.camera.fov * std::numbers::pi / 180) / depth;
  const double head_radius_px = 0.1 * 0.015 * px_per_m * 1.3;  // a little perspective slack
  int changed = 0;
  for (int y = 0; y < with.height; ++y)
    for (int x = 0; x < with.width; ++x) {
      if (!differ(with, without, x, y)) continue;
      ++changed;
      EXPECT_LT(segment_distance(from, to, Eigen::Vector2d(x + 0.5, y + 0.5)), head_radius_px + 2)
          << "pixel " << x << "," << y;
    }
  EXPECT_GT(changed, 20);
  // Along its length, the arrow is there: the shaft's middle and next to the tip.
  for (double t : {0.3, 0.5, 0.9}) {
    const Eigen::Vector2d q = from + t * (to - from);
    EXPECT_TRUE(differ(with, without, int(q.x()), int(q.y()))) << "t " << t;
  }
  // It is yellow where it covers the surface: red and green well above blue.
  const Eigen::Vector2d mid = from + 0.5 * (to - from);
  const uint8_t* p = with.pixel(int(mid.x()), int(mid.y()));
  EXPECT_GT(int(p[1]) - int(p[2]), 60);
}

TEST(RenderOffscreen, ToolPointsAndLinesAppearInTheirColours) {
  PALPATE_NEEDS(OSMESA, "OSMesa");
  RenderScene s;
  s.camera = test_camera();
  s.supersample = 1;
  palpate::RenderTool tool;
  tool.tip = Vec3(0.0, 0.004, 0.0);
  tool.radius = 0.003;
  s.tool = tool;
  const std::vector<Vec3f> dots = {Vec3f(0.015f, 0.0f, -0.015f)};
  s.points.push_back({dots, Vec3f(0.1f, 0.2f, 0.95f), 6.0f});
  const std::vector<Vec3f> ends = {Vec3f(-0.02f, 0.0f, 0.02f), Vec3f(-0.02f, 0.0f, -0.02f)};
  const std::vector<std::array<int, 2>> seg = {{0, 1}};
  s.lines.push_back({ends, seg, Vec3f(0.9f, 0.1f, 0.1f), 3.0f});
  const Image img = render(s);

  const auto c = project(s.camera, tool.tip);
  const uint8_t* grey = img.pixel(int(c.x()), int(c.y()));
  EXPECT_LT(std::abs(int(grey[0]) - int(grey[1])), 20);  // steel: grey
  EXPECT_LT(std::abs(int(grey[1]) - int(grey[2])), 25);
  EXPECT_GT(int(grey[0]), 60);
  const auto d = project(s.camera, dots[0].cast<double>());
  const uint8_t* blue = img.pixel(int(d.x()), int(d.y()));
  EXPECT_GT(int(blue[2]), 200);
  EXPECT_LT(int(blue[0]), 60);
  const auto m = project(s.camera, Vec3(-0.02, 0.0, 0.0));
  const uint8_t* red = img.pixel(int(m.x()), int(m.y()));
  EXPECT_GT(int(red[0]), 200);
  EXPECT_LT(int(red[1]), 60);
  // A needle instead of the sphere shows along its shaft.
  tool.kind = "needle";
  tool.radius = 0.0008;
  tool.length = 0.02;
  tool.axis = Vec3(0, -1, 0);
  s.tool = tool;
  s.points.clear();
  s.lines.clear();
  const Image needle = render(s);
  const auto shaft = project(s.camera, tool.tip + Vec3(0, 0.01, 0));
  EXPECT_FALSE(is_background(needle, int(shaft.x()), int(shaft.y()), s.background));
  const auto beside = project(s.camera, tool.tip + Vec3(0.008, 0.01, -0.008));
  EXPECT_TRUE(is_background(needle, int(beside.x()), int(beside.y()), s.background));
}

TEST(RenderOffscreen, RenderingIsDeterministic) {
  PALPATE_NEEDS(OSMESA, "OSMesa");
  const auto grid = flat_grid(7, 7, 0.005f);
  auto surface = palpate::tessellate_grid(grid, 7, 7, {palpate::SurfaceScheme::bspline, 4});
  ASSERT_TRUE(surface.ok());
  RenderScene s;
  s.camera = test_camera();
  s.surfaces.push_back({surface->positions, surface->normals, surface->triangles});
  EXPECT_EQ(render(s).rgba, render(s).rgba);
}

TEST(RenderOffscreen, PngIsWrittenAtomicallyAndReadsBack) {
  PALPATE_NEEDS(OSMESA, "OSMesa");
  const auto dir = std::filesystem::temp_directory_path() / ("palpate_render_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const auto grid = flat_grid(4, 4, 0.01f);
  auto surface = palpate::tessellate_grid(grid, 4, 4, {});
  ASSERT_TRUE(surface.ok());
  RenderScene s;
  s.camera = test_camera();
  s.surfaces.push_back({surface->positions, surface->normals, surface->triangles});
  const auto file = dir / "frame.png";
  const auto st = palpate::render_png(s, file);
  ASSERT_TRUE(st.ok()) << st.error().message;
  int w = 0, h = 0, n = 0;
  uint8_t* data = stbi_load(file.c_str(), &w, &h, &n, 4);
  ASSERT_NE(data, nullptr);
  EXPECT_EQ(w, 160);
  EXPECT_EQ(h, 120);
  const Image img = render(s);
  EXPECT_TRUE(std::equal(img.rgba.begin(), img.rgba.end(), data));
  stbi_image_free(data);
  // Only the PNG is left: no temporary file.
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), std::filesystem::directory_iterator{}), 1);
  const auto missing = dir / "no_such_dir" / "x.png";
  const auto bad = palpate::write_png(img, missing);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().message,
            missing.string() + ": cannot write (No such file or directory); expected a writable directory");
  std::filesystem::remove_all(dir);
}

TEST(RenderOffscreen, RejectsBadScenesWithClearErrors) {
  RenderScene s;
  s.camera = test_camera();
  s.camera.width = 0;
  auto a = palpate::render_rgba(s);
  ASSERT_FALSE(a.ok());
  EXPECT_EQ(a.error().message, "render: camera size 0 x 120 pixels; expected 1 to 4096 each");
  s.camera = test_camera();
  s.camera.target = s.camera.position;
  auto b = palpate::render_rgba(s);
  ASSERT_FALSE(b.ok());
  EXPECT_EQ(b.error().message, "render: camera position equals its target; expected them apart");
  s.camera = test_camera();
  const std::vector<float> p = {0, 0, 0, 1, 0, 0, 0, 0, 1};
  const std::vector<uint32_t> t = {0, 1, 2, 0, 2, 3};
  s.surfaces.push_back({p, {}, t});
  auto c = palpate::render_rgba(s);
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.error().message, "render: surface 0: triangle 1 refers to point 3; expected an index below 3 (the point count)");
  s.surfaces.clear();
  palpate::RenderTool tool;
  tool.kind = "scalpel";
  s.tool = tool;
  auto d = palpate::render_rgba(s);
  ASSERT_FALSE(d.ok());
  EXPECT_EQ(d.error().message, "render: tool kind 'scalpel'; expected sphere, needle or blade");
}
