// test_render_blade.cpp — a blade tool drawn headless (issue 37), checked by image content: the flat
// blade covers the side of its edge where its back is and nothing on the other side or past its tip,
// the cutting edge shows in its own colour along the projected edge, the handle lies behind the heel;
// and the shape the renderer, the viewer and the glTF export share (core/blade_shape.h).
#include <palpate/render.h>

#include "components.h"
#include "core/blade_shape.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

using palpate::CameraDef;
using palpate::Image;
using palpate::RenderScene;
using palpate::Vec3;
using palpate::Vec3f;

namespace {

// 5 px per mm at the blade, looking at its face (the faces face ±z for a horizontal edge).
CameraDef face_camera() {
  CameraDef c;
  c.position = Vec3(0, 0.01, 0.09);
  c.target = Vec3(0, 0.004, 0);
  c.fov = 30;
  c.width = 320;
  c.height = 240;
  return c;
}

bool is_background(const Image& img, const Eigen::Vector2d& p, const Vec3f& bg) {
  const uint8_t* q = img.pixel(int(p.x()), int(p.y()));
  for (int c = 0; c < 3; ++c)
    if (std::abs(int(q[c]) - int(std::lround(bg[c] * 255))) > 1) return false;
  return true;
}

// The edge's warm colour (1, 0.92, 0.55): the steel (0.72, 0.74, 0.78), lit, is bluer than red.
bool edge_coloured(const uint8_t* q) { return q[0] > 150 && q[1] > 0.85 * q[0] && q[2] < 0.65 * q[0]; }

// Some pixel within `r` of p has the edge's colour.
bool edge_near(const Image& img, const Eigen::Vector2d& p, int r) {
  for (int dy = -r; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx) {
      const int x = int(std::lround(p.x())) + dx, y = int(std::lround(p.y())) + dy;
      if (x >= 0 && y >= 0 && x < img.width && y < img.height && edge_coloured(img.pixel(x, y))) return true;
    }
  return false;
}

Eigen::Vector2d px(const CameraDef& c, const Vec3& p) {
  auto q = palpate::project_to_pixel(c, p);
  EXPECT_TRUE(q.has_value());
  return q.value_or(Eigen::Vector2d::Zero());
}

double luminance(const uint8_t* q) { return 0.3 * q[0] + 0.59 * q[1] + 0.11 * q[2]; }

}  // namespace

TEST(RenderBlade, TheBladeCoversItsBackSideOfTheEdgeTheEdgeShowsAndTheHandleIsBehindTheHeel) {
  PALPATE_NEEDS(OSMESA, "OSMesa");
  RenderScene s;
  s.camera = face_camera();
  palpate::RenderTool t;
  t.kind = "blade";
  t.tip = Vec3(0.01, 0.002, 0);
  t.axis = Vec3(2, 0, 0);  // not unit: drawn along its direction
  t.length = 0.02;
  t.radius = 0.0003;
  s.tool = t;
  auto img = palpate::render_rgba(s);
  ASSERT_TRUE(img.ok()) << img.error().message;
  const palpate::BladeShape b = palpate::blade_shape(t.tip, t.axis, t.length, t.radius);
  ASSERT_EQ(b.back, Vec3(0, 1, 0)) << "a horizontal edge: the blade's back up, its edge down";
  const Vec3 heel = b.heel();
  for (double f : {0.1, 0.3, 0.5, 0.7, 0.9}) {
    const Vec3 on = heel + f * t.length * b.axis;
    // The edge, in its colour, along its projection.
    EXPECT_TRUE(edge_near(*img, px(s.camera, on), 2)) << "edge at " << f;
    // The blade above the edge (a third of the way to its back, where the outline is deep enough).
    const double deep = f < 0.7 ? b.depth : b.depth * (1 - f) / 0.3;
    EXPECT_FALSE(is_background(*img, px(s.camera, on + 0.4 * deep * b.back), s.background)) << "blade at " << f;
    // Nothing on the cutting side: 2 mm below the edge is background.
    EXPECT_TRUE(is_background(*img, px(s.camera, on - 0.002 * b.back), s.background)) << "below the edge at " << f;
  }
  // Nothing past the tip along the edge, nor above the pointed end's back.
  EXPECT_TRUE(is_background(*img, px(s.camera, t.tip + 0.003 * b.axis), s.background));
  EXPECT_TRUE(is_background(*img, px(s.camera, t.tip + 0.9 * b.depth * b.back), s.background));
  // The handle behind the heel, darker than the blade.
  const uint8_t* handle = img->pixel(int(px(s.camera, heel - 0.02 * b.axis + 0.5 * b.depth * b.back).x()),
                                     int(px(s.camera, heel - 0.02 * b.axis + 0.5 * b.depth * b.back).y()));
  const uint8_t* blade = img->pixel(int(px(s.camera, heel + 0.3 * t.length * b.axis + 0.5 * b.depth * b.back).x()),
                                    int(px(s.camera, heel + 0.3 * t.length * b.axis + 0.5 * b.depth * b.back).y()));
  EXPECT_FALSE(is_background(*img, px(s.camera, heel - 0.02 * b.axis + 0.5 * b.depth * b.back), s.background));
  EXPECT_LT(luminance(handle), 0.8 * luminance(blade));
}

TEST(RenderBlade, ABladeOfNoLengthOrAxisIsRefusedNamingIt) {
  RenderScene s;
  s.camera = face_camera();
  palpate::RenderTool t;
  t.kind = "blade";
  t.length = 0;
  s.tool = t;
  auto a = palpate::render_rgba(s);
  ASSERT_FALSE(a.ok());
  EXPECT_EQ(a.error().message, "render: blade length 0.000000 m along a non-zero axis; expected > 0");
  t.length = 0.02;
  t.axis = Vec3::Zero();
  s.tool = t;
  EXPECT_FALSE(palpate::render_rgba(s).ok());
  t.kind = "scalpel";
  s.tool = t;
  auto c = palpate::render_rgba(s);
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.error().message, "render: tool kind 'scalpel'; expected sphere, needle or blade");
}

// The shape every front end draws: a closed, flat blade on its edge and a handle behind the heel.
TEST(BladeShape, TheBladeLiesOnItsEdgeWithinItsThicknessAndTheHandleBehindTheHeel) {
  for (const Vec3& axis : {Vec3(1, 0, 0), Vec3(0, -1, 0), Vec3(0.3, -0.8, 0.5), Vec3(0, 0, 1)}) {
    const palpate::BladeShape s = palpate::blade_shape(Vec3(0.01, 0.02, 0.03), axis, 0.025, 0.0002);
    EXPECT_NEAR(s.axis.norm(), 1.0, 1e-12);
    EXPECT_NEAR(s.back.norm(), 1.0, 1e-12);
    EXPECT_NEAR(s.back.dot(s.axis), 0.0, 1e-12) << axis.transpose();
    if (std::abs(s.axis.y()) < 0.99) {
      EXPECT_GT(s.back.y(), 0) << "edge down, back up";
    }
    palpate::BladeMesh blade, handle;
    palpate::append_blade(blade, s);
    palpate::append_blade_handle(handle, s);
    ASSERT_FALSE(blade.triangles.empty());
    ASSERT_EQ(blade.positions.size(), blade.normals.size());
    const Vec3 side = s.axis.cross(s.back);
    for (size_t i = 0; i < blade.positions.size(); i += 3) {
      const Vec3 p = Vec3(blade.positions[i], blade.positions[i + 1], blade.positions[i + 2]) - s.heel();
      const double along = p.dot(s.axis), up = p.dot(s.back), across = p.dot(side);
      ASSERT_GE(along, -1e-6);                       // not behind the heel
      ASSERT_LE(along, s.length + 1e-6);             // not past the tip
      ASSERT_GE(up, -1e-6);                          // nothing below the edge
      ASSERT_LE(up, s.depth + 1e-6);
      ASSERT_LE(std::abs(across), 0.5 * s.thickness + 1e-6);  // flat: within its thickness
    }
    for (size_t i = 0; i < handle.positions.size(); i += 3) {
      const Vec3 p = Vec3(handle.positions[i], handle.positions[i + 1], handle.positions[i + 2]) - s.heel();
      ASSERT_LE(p.dot(s.axis), 1e-6);  // behind the heel
      ASSERT_GE(p.dot(s.axis), -s.handle_length - 1e-6);
    }
    for (std::uint32_t v : blade.triangles) ASSERT_LT(v, blade.positions.size() / 3);
  }
}
