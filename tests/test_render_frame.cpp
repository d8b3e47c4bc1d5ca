// test_render_frame.cpp — frames of a scene from tissue snapshots: the tissue fills the view, the
// tool's dent shows as a pixel difference where it presses, and the PNG is written.
#include <palpate/render.h>
#include <palpate/scene.h>
#include <palpate/tissue.h>
#include <palpate/tissue_files.h>

#include "components.h"
#include <gtest/gtest.h>

#include <filesystem>

using namespace palpate;

namespace {

struct Frame {
  Image image;
  std::optional<Eigen::Vector2d> tip_px;
};

Frame render(const SceneDef& scene, std::vector<std::unique_ptr<Tissue>>& tissues, const Vec3& tip,
             const Vec3& force) {
  std::vector<TissueSnapshot> snaps(tissues.size());
  for (size_t i = 0; i < tissues.size(); ++i) tissues[i]->snapshot(snaps[i]);
  std::vector<std::vector<float>> storage;
  std::vector<std::vector<uint32_t>> idx;
  auto rs = frame_scene(scene, snaps, tip, force, {}, storage, idx);
  EXPECT_TRUE(rs.ok()) << rs.error().message;
  rs->supersample = 1;
  auto img = render_rgba(*rs);
  EXPECT_TRUE(img.ok()) << img.error().message;
  return {std::move(*img), project_to_pixel(rs->camera, tip)};
}

}  // namespace

TEST(RenderFrame, ProbeDentShowsWhereItPresses) {
  PALPATE_NEEDS(OSMESA, "OSMesa");
  auto scene = load_scene(PALPATE_SOURCE_DIR "/data/scenes/probe.yaml");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  scene->camera = CameraDef{};
  scene->camera->position = Vec3(0.0, 0.06, 0.04);
  scene->camera->target = Vec3::Zero();
  scene->camera->width = 200, scene->camera->height = 150;
  std::vector<std::unique_ptr<Tissue>> tissues;
  for (int i = 0; i < int(scene->tissues.size()); ++i) {
    auto t = make_tissue(*scene, i);
    ASSERT_TRUE(t.ok()) << t.error().message;
    tissues.push_back(std::move(*t));
  }
  const Vec3 far(0, 0.05, 0);
  Frame rest = render(*scene, tissues, far, Vec3::Zero());
  // The tissue fills the middle of the view; the background shows at a top corner.
  const uint8_t* bg = rest.image.pixel(2, 2);
  const uint8_t* mid = rest.image.pixel(100, 80);
  EXPECT_GT(std::abs(int(mid[0]) - int(bg[0])) + std::abs(int(mid[1]) - int(bg[1])), 60);

  // Press the probe 4 mm in and draw again: pixels change around the tool, not in the far corners.
  ToolState tool;
  tool.radius = scene->tool.radius;
  Vec3 f = Vec3::Zero();
  for (int k = 0; k <= 400; ++k) {
    tool.time = k * 0.001;
    tool.tip = Vec3(0, 0.004 - k * 2e-5, 0);
    f = Vec3::Zero();
    for (auto& t : tissues) f += t->step(tool, 0.001);
  }
  Frame pressed = render(*scene, tissues, tool.tip, f);
  ASSERT_TRUE(pressed.tip_px.has_value());
  const int cx = int(pressed.tip_px->x()), cy = int(pressed.tip_px->y());
  int near_changed = 0, far_changed = 0;
  for (int y = 0; y < 150; ++y)
    for (int x = 0; x < 200; ++x) {
      const uint8_t* a = rest.image.pixel(x, y);
      const uint8_t* b = pressed.image.pixel(x, y);
      const bool changed = std::abs(int(a[0]) - int(b[0])) + std::abs(int(a[1]) - int(b[1])) +
                               std::abs(int(a[2]) - int(b[2])) > 24;
      const bool near = std::hypot(x - cx, y - cy) < 40;
      (near ? near_changed : far_changed) += changed ? 1 : 0;
    }
  EXPECT_GT(near_changed, 200);
  EXPECT_LT(far_changed, near_changed / 4);

  const auto file = std::filesystem::temp_directory_path() / "palpate_frame.png";
  std::vector<TissueSnapshot> snaps(tissues.size());
  for (size_t i = 0; i < tissues.size(); ++i) tissues[i]->snapshot(snaps[i]);
  ASSERT_TRUE(render_frame_png(*scene, snaps, tool.tip, f, file).ok());
  EXPECT_GT(std::filesystem::file_size(file), 1000u);
}

TEST(RenderFrame, TheNeedleIsDrawnAlongTheAxisOfItsTick) {
  SceneDef scene;
  scene.tool.kind = "needle";
  scene.tool.axis = Vec3(0, -2, 0);  // as loaded it would be unit; the frame normalises it anyway
  scene.camera = CameraDef{};
  const std::vector<TissueSnapshot> none;
  std::vector<std::vector<float>> storage;
  std::vector<std::vector<uint32_t>> idx;
  auto fixed = frame_scene(scene, none, Vec3::Zero(), Vec3::Zero(), {}, storage, idx);
  ASSERT_TRUE(fixed.ok()) << fixed.error().message;
  ASSERT_TRUE(fixed->tool.has_value());
  EXPECT_EQ(fixed->tool->axis, Vec3(0, -1, 0));
  const Vec3 tilted = Vec3(0.5, -1, 0.25).normalized();
  auto turned = frame_scene(scene, none, Vec3::Zero(), Vec3::Zero(), {}, storage, idx, tilted);
  ASSERT_TRUE(turned.ok()) << turned.error().message;
  EXPECT_EQ(turned->tool->axis, tilted);
}

TEST(RenderFrame, TheProbeIsABoxOnItsFaceAndItsImagePlaneAnOutlineUnderIt) {
  SceneDef scene;
  scene.camera = CameraDef{};
  const std::vector<TissueSnapshot> none;
  std::vector<std::vector<float>> storage;
  std::vector<std::vector<uint32_t>> idx;
  FrameProbe probe;  // 38 × 10 mm, facing −y, its array along x, 40 mm deep
  probe.position = Vec3(0.001, -0.002, 0.003);
  probe.orientation = Quat(Eigen::AngleAxisd(0.3, Vec3::UnitZ()));  // tilted across the array
  auto rs = frame_scene(scene, none, Vec3::Zero(), Vec3::Zero(), {}, storage, idx, std::nullopt, &probe);
  ASSERT_TRUE(rs.ok()) << rs.error().message;
  ASSERT_EQ(rs->surfaces.size(), 2u);  // the box, the plane
  ASSERT_EQ(rs->lines.size(), 1u);     // the plane's outline
  const Vec3 beam = probe.orientation * probe.def.axis, lateral = probe.orientation * probe.def.lateral;
  const Vec3 elevation = beam.cross(lateral);
  // Every box corner lies within the footprint, between the face and 30 mm above it.
  const RenderSurface& box = rs->surfaces[0];
  ASSERT_EQ(box.positions.size(), 24u * 3);
  for (size_t k = 0; k < 24; ++k) {
    const Vec3 d = Vec3(box.positions[3 * k], box.positions[3 * k + 1], box.positions[3 * k + 2]) - probe.position;
    EXPECT_NEAR(std::abs(d.dot(lateral)), 0.5 * probe.def.width, 1e-6);
    EXPECT_NEAR(std::abs(d.dot(elevation)), 0.5 * probe.def.thickness, 1e-6);
    EXPECT_TRUE(std::abs(d.dot(beam)) < 1e-6 || std::abs(d.dot(beam) + probe.height) < 1e-6) << k;
  }
  // The outline: the face's width along the array, the imaging depth along the beam, in the plane.
  const RenderLines& l = rs->lines[0];
  ASSERT_EQ(l.points.size(), 4u);
  for (const Vec3f& p : l.points) EXPECT_NEAR((p.cast<double>() - probe.position).dot(elevation), 0.0, 1e-6);
  EXPECT_NEAR((l.points[2] - l.points[1]).cast<double>().dot(beam), probe.def.depth, 1e-6);
  EXPECT_NEAR((l.points[1] - l.points[0]).norm(), probe.def.width, 1e-6);
  EXPECT_LT(box.opacity, 1.0f) << "see-through: the needle's tip ends under it";
}

TEST(RenderFrame, ACutLayersFrameHasNoTriangleAcrossItsWound) {
  // A 6 x 6 grid snapshot with the links across its middle column cut: the frame's surface loses
  // the triangles over the cut cells and gains the wound's walls (off the surface); uncut, the
  // same grid draws whole.
  SceneDef scene;
  TissueSnapshot snap;
  const int rows = 6, cols = 6;
  snap.rows_cols = {rows, cols};
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) snap.points.push_back(Vec3f(0.002f * c, 0.0f, 0.002f * r));
  // Triangles of the top surface (y = 0) over the cut column (4 mm < x < 6 mm), and wall triangles.
  const auto count = [](const RenderSurface& s, size_t& over_cut, size_t& walls) {
    over_cut = walls = 0;
    for (size_t t = 0; t + 2 < s.triangles.size(); t += 3) {
      float x = 0, y = 0;
      for (int k = 0; k < 3; ++k) {
        x += s.positions[3 * s.triangles[t + k]] / 3;
        y += s.positions[3 * s.triangles[t + k] + 1] / 3;
      }
      if (std::abs(y) < 1e-6f && x > 0.0041f && x < 0.0059f) ++over_cut;
      if (std::abs(y) > 1e-5f) ++walls;  // (off the surface: against its normals, whichever side that is)
    }
  };
  std::vector<std::vector<float>> storage;
  std::vector<std::vector<uint32_t>> idx;
  auto whole = frame_scene(scene, std::span<const TissueSnapshot>(&snap, 1), Vec3(0, 0.01, 0), Vec3::Zero(), {},
                           storage, idx);
  ASSERT_TRUE(whole.ok()) << whole.error().message;
  size_t over = 0, walls = 0;
  count(whole->surfaces.at(0), over, walls);
  EXPECT_GT(over, 0u);
  EXPECT_EQ(walls, 0u);
  for (int r = 0; r < rows; ++r) snap.cut_links.push_back({r * cols + 2, r * cols + 3});
  auto cut = frame_scene(scene, std::span<const TissueSnapshot>(&snap, 1), Vec3(0, 0.01, 0), Vec3::Zero(), {},
                         storage, idx);
  ASSERT_TRUE(cut.ok()) << cut.error().message;
  count(cut->surfaces.at(0), over, walls);
  EXPECT_EQ(over, 0u);
  EXPECT_GT(walls, 0u);
  // A link that is not between two corners of one cell (here past the grid) cuts no cell: drawn whole.
  snap.cut_links = {{0, 1000}};
  auto odd = frame_scene(scene, std::span<const TissueSnapshot>(&snap, 1), Vec3(0, 0.01, 0), Vec3::Zero(), {},
                         storage, idx);
  ASSERT_TRUE(odd.ok()) << odd.error().message;
  count(odd->surfaces.at(0), over, walls);
  EXPECT_GT(over, 0u);
}
