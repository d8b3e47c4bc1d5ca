// test_view_parts.cpp — the viewer's GUI-free parts: the orbit camera's geometry, ray picking, the
// needle tilted by a mouse drag, and SnapshotTissue's hand-over of positions from a stepping
// thread to a reading thread; the player of a scene's scripted tools; a tissue's drawn surface,
// a blade's wound in it included.
#include <gtest/gtest.h>

// The viewer lives in the app (it links GUI libraries the test binary must not); these two
// sources of it use only palpate's public headers, so they are compiled in here.
#include "../apps/palpate/view/camera.cpp"
#include "../apps/palpate/view/tool_tilt.cpp"
#include "../apps/palpate/view/script_player.cpp"
#include "../apps/palpate/view/tissue_view.cpp"
#include <palpate/render.h>
#include <palpate/tissue_files.h>
#include <palpate/scene.h>
#include <palpate/device.h>
#include <palpate/snapshot_tissue.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <set>
#include <thread>

namespace {

using palpate::CameraDef;
using palpate::Vec3;
using palpate::Vec3f;
using palpate::view::OrbitCamera;

CameraDef camera_def() {
  CameraDef c;
  c.position = Vec3(0.05, 0.03, 0.06);
  c.target = Vec3(0.0, -0.006, 0.0);
  c.fov = 40;
  return c;
}

TEST(ViewCamera, StartsWhereTheSceneCameraIs) {
  const OrbitCamera cam = OrbitCamera::from(camera_def());
  EXPECT_LT((cam.eye() - camera_def().position).norm(), 1e-12);
  EXPECT_LT((cam.forward() - (camera_def().target - camera_def().position).normalized()).norm(), 1e-12);
  EXPECT_NEAR(cam.up().dot(cam.forward()), 0.0, 1e-12);
  EXPECT_GT(cam.up().y(), 0.0);  // y is up on screen
}

TEST(ViewCamera, CentrePixelRayPointsAtTheTargetAndProjectionInvertsRays) {
  const OrbitCamera cam = OrbitCamera::from(camera_def());
  EXPECT_LT((cam.ray_direction(400, 300, 800, 600) - cam.forward()).norm(), 1e-12);
  for (const auto& px : {Eigen::Vector2d(10, 20), Eigen::Vector2d(700, 590), Eigen::Vector2d(400, 77)}) {
    const Vec3 p = cam.eye() + 0.08 * cam.ray_direction(px.x(), px.y(), 800, 600);
    const auto back = cam.project(p, 800, 600);
    ASSERT_TRUE(back.has_value());
    EXPECT_LT((*back - px).norm(), 1e-9);
  }
  EXPECT_FALSE(cam.project(cam.eye() - cam.forward(), 800, 600).has_value());  // behind the eye
}

TEST(ViewCamera, MatricesAgreeWithTheRayProjection) {
  const OrbitCamera cam = OrbitCamera::from(camera_def());
  const Eigen::Matrix4f pv = cam.projection_matrix(800.0 / 600.0) * cam.view_matrix();
  const Vec3 p(0.01, -0.004, 0.007);
  const Eigen::Vector4f clip = pv * Eigen::Vector4f(0.01f, -0.004f, 0.007f, 1.0f);
  const double x = (clip.x() / clip.w() + 1) * 400, y = (1 - clip.y() / clip.w()) * 300;
  const auto px = cam.project(p, 800, 600);
  ASSERT_TRUE(px.has_value());
  EXPECT_NEAR(x, px->x(), 1e-3);
  EXPECT_NEAR(y, px->y(), 1e-3);
  EXPECT_GT(clip.z() / clip.w(), -1.0f);  // inside the depth range
  EXPECT_LT(clip.z() / clip.w(), 1.0f);
}

TEST(ViewCamera, OrbitKeepsDistancePanMovesEyeAndTargetTogetherZoomApproaches) {
  OrbitCamera cam = OrbitCamera::from(camera_def());
  const double d = (cam.eye() - cam.target).norm();
  cam.orbit(120, -45);
  EXPECT_NEAR((cam.eye() - cam.target).norm(), d, 1e-12);
  cam.orbit(0, 1e6);  // never flips over the pole
  EXPECT_LT(cam.pitch, std::numbers::pi / 2);
  EXPECT_TRUE(cam.eye().allFinite());
  const Vec3 eye = cam.eye(), target = cam.target;
  cam.pan(30, -10, 600);
  EXPECT_LT(((cam.eye() - eye) - (cam.target - target)).norm(), 1e-12);
  EXPECT_GT((cam.target - target).norm(), 0.0);
  cam.zoom(2);
  EXPECT_NEAR(cam.distance, d * 0.81, 1e-12);
}

TEST(ViewTilt, TheHandleFollowsTheDragAndTheNeedleStaysUnit) {
  const OrbitCamera cam = OrbitCamera::from(camera_def());
  const Vec3 tool_axis(0, -1, 0);
  const double k = 0.5 * M_PI / 180;  // rad per pixel
  palpate::Quat q = palpate::Quat::Identity();
  // A drag to the right and up, in small steps, from a needle pointing down: the handle (above the
  // tip) moves right and up in the image, by the drag's length times k in angle, as far as the
  // drag is across the handle.
  for (int i = 0; i < 40; ++i) {
    const Vec3 handle = -palpate::needle_axis(tool_axis, q);
    const palpate::Quat next = palpate::view::tilt_by_drag(q, handle, 3.0, -1.0, cam.right(), cam.up(), k);
    const Vec3 moved = -palpate::needle_axis(tool_axis, next) - handle;
    const Vec3 drag = 3.0 * cam.right() + 1.0 * cam.up();
    const Vec3 across = drag - drag.dot(handle) * handle;  // the part of the drag across the handle
    ASSERT_NEAR(next.norm(), 1.0, 1e-15);
    ASSERT_NEAR(palpate::needle_axis(tool_axis, next).norm(), 1.0, 1e-15);
    ASSERT_NEAR(next.angularDistance(q), k * across.norm(), 1e-12) << i;
    ASSERT_GT(moved.dot(cam.right()), 0.0) << i;
    ASSERT_GT(moved.dot(across), 0.99 * moved.norm() * across.norm()) << i;
    q = next;
  }
  // No drag, or a drag straight along the handle (a handle pointing at the eye): no turn.
  const Vec3 handle = -palpate::needle_axis(tool_axis, q);
  EXPECT_EQ(palpate::view::tilt_by_drag(q, handle, 0, 0, cam.right(), cam.up(), k).coeffs(), q.coeffs());
  EXPECT_LT(palpate::view::tilt_by_drag(q, cam.right(), 5, 0, cam.right(), cam.up(), k).angularDistance(q), 1e-12);
}

TEST(ViewTilt, TurnTowardsStepsAtMostTheGivenAngleAlongTheShortestArc) {
  const palpate::Quat from = palpate::Quat::Identity();
  const palpate::Quat to(Eigen::AngleAxisd(1.0, Vec3(1, 2, 3).normalized()));
  palpate::Quat q = from;
  int steps = 0;
  while (q.coeffs() != to.coeffs() && steps < 10000) {
    const palpate::Quat next = palpate::view::turn_towards(q, to, 0.002);
    ASSERT_LE(next.angularDistance(q), 0.002 + 1e-12);
    ASSERT_NEAR(next.angularDistance(from) + next.angularDistance(to), 1.0, 1e-9);  // on the arc
    q = next;
    ++steps;
  }
  EXPECT_NEAR(steps, 500, 1);  // 1 rad at 2 mrad a step, the last one landing on `to` exactly
}

TEST(ViewPick, HitsTheNearestTriangleAndMissesOutside) {
  // Two unit right triangles facing +y, at y = 0 and y = -1.
  const std::vector<float> positions = {0, 0, 0, 1, 0, 0, 0, 0, 1, 0, -1, 0, 1, -1, 0, 0, -1, 1};
  const std::vector<std::uint32_t> triangles = {3, 4, 5, 0, 1, 2};
  const auto hit = palpate::view::pick(Vec3(0.2, 2, 0.2), Vec3(0, -1, 0), positions, triangles);
  ASSERT_TRUE(hit.has_value());
  EXPECT_NEAR(*hit, 2.0, 1e-12);
  EXPECT_FALSE(palpate::view::pick(Vec3(0.8, 2, 0.8), Vec3(0, -1, 0), positions, triangles));  // u + v > 1
  EXPECT_FALSE(palpate::view::pick(Vec3(0.2, 2, 0.2), Vec3(0, 1, 0), positions, triangles));   // pointing away
  const std::vector<std::uint32_t> bad = {0, 1, 99};  // an index out of range is skipped, not read
  EXPECT_FALSE(palpate::view::pick(Vec3(0.2, 2, 0.2), Vec3(0, -1, 0), positions, bad));
}

// A tissue whose every point holds the number of steps taken: a torn copy (points from two
// different steps) shows as unequal values.
class CountingTissue final : public palpate::Tissue {
 public:
  explicit CountingTissue(size_t n) : points_(n, 0.0f) {}
  const std::string& name() const override { return name_; }
  palpate::Vec3 step(const palpate::ToolState&, double) noexcept override {
    ++steps_;
    for (float& p : points_) p = static_cast<float>(steps_);
    return palpate::Vec3(0, 1, 0);
  }
  std::span<const std::string> figure_names() const override { return {}; }
  void figures(std::span<double>) const noexcept override {}
  size_t drain_events(std::span<palpate::TissueEvent>) noexcept override { return 0; }
  void snapshot(palpate::TissueSnapshot& snap) const override {
    snap.points.resize(points_.size());
    for (size_t i = 0; i < points_.size(); ++i) snap.points[i] = Vec3f(points_[i], points_[i], points_[i]);
    snap.rows_cols = {static_cast<int>(points_.size()), 1};
    snap.links.clear();
    for (int i = 0; i + 1 < static_cast<int>(points_.size()); ++i) snap.links.push_back({i, i + 1});
  }
  void reset() noexcept override {
    steps_ = 0;
    for (float& p : points_) p = 0;
  }

 private:
  std::string name_ = "counting";
  std::vector<float> points_;
  int steps_ = 0;
};

TEST(ViewSnapshot, StartsAtRestAndForwardsTheStep) {
  palpate::SnapshotTissue t(std::make_unique<CountingTissue>(10));
  bool fresh = true;
  const palpate::TissueSnapshot& s = t.latest(&fresh);
  EXPECT_FALSE(fresh);
  ASSERT_EQ(s.points.size(), 10u);
  EXPECT_EQ(s.points[3].x(), 0.0f);
  EXPECT_EQ(t.name(), "counting");
  EXPECT_EQ(t.step({}, 0.001), palpate::Vec3(0, 1, 0));
  // The first step answers the request made at construction.
  EXPECT_EQ(t.latest(&fresh).points[9].x(), 1.0f);
  EXPECT_TRUE(fresh);
  // No new request: further steps publish nothing, the reader keeps its copy.
  t.step({}, 0.001);
  EXPECT_EQ(t.latest(&fresh).points[9].x(), 1.0f);
  EXPECT_FALSE(fresh);
  t.request();
  t.step({}, 0.001);
  EXPECT_EQ(t.latest().points[0].x(), 3.0f);
  EXPECT_EQ(t.published(), 2u);
}

TEST(ViewSnapshot, ReaderNeverSeesATornCopyAndSteadyStateNeverGrowsArrays) {
  palpate::SnapshotTissue t(std::make_unique<CountingTissue>(2000));
  std::atomic<bool> stop{false};
  std::thread stepper([&] {
    while (!stop) t.step({}, 0.001);
  });
  // Read 200 fresh copies while the other thread steps as fast as it can.
  int torn = 0, seen = 0;
  float last = 0;
  bool backwards = false;
  while (seen < 200) {
    t.request();
    bool fresh = false;
    const palpate::TissueSnapshot& s = t.latest(&fresh);
    if (!fresh) continue;
    ++seen;
    const float v = s.points.front().x();
    for (const Vec3f& p : s.points) torn += p.x() != v;
    backwards = backwards || v < last;
    last = v;
  }
  stop = true;
  stepper.join();
  EXPECT_EQ(torn, 0);
  EXPECT_FALSE(backwards);  // copies arrive in step order
  EXPECT_EQ(t.capacity_growths(), 0u);
}

// The viewer's script player: its clock plays, pauses, steps and stops where told, and the poses it
// gives are the scene's scripted devices' at that clock, the needle's and the probe's.
TEST(ViewScript, PlaysPausesAndStepsTheScenesScriptedTools) {
  auto scene = palpate::parse_scene(
      "duration: 2\n"
      "tool: {kind: needle, axis: [0, -1, 0]}\n"
      "device: {kind: scripted, waypoints: [{t: 0, position: [0, 0.01, 0]}, {t: 1, position: [0, -0.01, 0], direction: [0, -1, 1]}]}\n"
      "anatomy: {kind: neck}\n"
      "probe: {device: {kind: scripted, waypoints: [{t: 0, position: [0, 0, 0]}, {t: 2, position: [0, -0.004, 0]}]}}\n",
      "s.yaml");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  palpate::view::ScriptPlayer p(*scene);
  ASSERT_TRUE(p.has_tool());
  ASSERT_TRUE(p.has_probe());
  EXPECT_EQ(p.error(), "");
  EXPECT_DOUBLE_EQ(p.duration(), 2.0);
  EXPECT_FALSE(p.playing());
  EXPECT_TRUE(p.moved()) << "the first poses are to be taken";
  EXPECT_FALSE(p.moved());
  p.advance(0.5);  // paused: the clock stays
  EXPECT_EQ(p.time(), 0.0);
  EXPECT_FALSE(p.moved());
  p.play();
  p.advance(0.25);
  EXPECT_DOUBLE_EQ(p.time(), 0.25);
  EXPECT_TRUE(p.moved());
  palpate::DeviceState s;
  ASSERT_TRUE(p.tool_pose(s));
  EXPECT_TRUE(s.position.isApprox(Vec3(0, 0.005, 0), 1e-12));
  ASSERT_TRUE(p.probe_pose(s));
  EXPECT_TRUE(s.position.isApprox(Vec3(0, -0.0005, 0), 1e-12));
  p.toggle();  // pause
  p.advance(1.0);
  EXPECT_DOUBLE_EQ(p.time(), 0.25);
  p.step(palpate::view::ScriptPlayer::kStep);
  EXPECT_NEAR(p.time(), 0.35, 1e-12);
  EXPECT_FALSE(p.playing()) << "a step pauses";
  // Played to 1.5 s it stops there, whatever the frames' lengths; at 1 s and after, the needle is
  // turned to the waypoint's direction.
  p.play_to(1.5);
  EXPECT_TRUE(p.playing());
  for (int i = 0; i < 10; ++i) p.advance(0.3);
  EXPECT_DOUBLE_EQ(p.time(), 1.5);
  EXPECT_FALSE(p.playing());
  ASSERT_TRUE(p.tool_pose(s));
  EXPECT_TRUE(palpate::needle_axis(Vec3(0, -1, 0), s.orientation).isApprox(Vec3(0, -1, 1).normalized(), 1e-9));
  // Steps stop at the ends; play at the end starts over.
  p.step(10);
  EXPECT_DOUBLE_EQ(p.time(), 2.0);
  p.step(-10);
  EXPECT_DOUBLE_EQ(p.time(), 0.0);
  p.step(10);
  p.play();
  EXPECT_DOUBLE_EQ(p.time(), 0.0);
  EXPECT_TRUE(p.playing());
  // A hand's device (openhaptics) is not played; a missing trajectory file is named.
  auto hand = palpate::parse_scene("anatomy: {kind: neck}\ndevice: {kind: openhaptics}\n", "h.yaml");
  ASSERT_TRUE(hand.ok()) << hand.error().message;
  EXPECT_FALSE(palpate::view::ScriptPlayer(*hand).has_script());
  auto missing = palpate::parse_scene("anatomy: {kind: neck}\ndevice: {kind: scripted, trajectory: /nonexistent/path.csv}\n", "m.yaml");
  if (missing.ok()) {
    palpate::view::ScriptPlayer m(*missing);
    EXPECT_FALSE(m.has_script());
    EXPECT_NE(m.error().find("/nonexistent/path.csv"), std::string::npos) << m.error();
  }
}

// Issue 37: the viewer draws a cut charged layer's wound as the run's frames do. The scripted
// stroke of tests/data/scenes/blade-patch.yaml (in 2 mm, drawn 20 mm along x, lifted out) steps the
// scene's tissue through SnapshotTissue, as the viewer's loop does, and the view is brought up to
// date every 20 ticks (a 50 Hz frame). The stroke runs 0.4 mm off the script's z = 0, where a row
// of the lattice lies in the blade's plane (the links from that row touch the swept surface at an
// end, and the cut takes links on both sides of it): here every cut link crosses one line. While
// uncut the view is the whole surface;
// once cut, no drawn surface triangle has corners on both sides of the cut line where the cut
// runs, the walls are there, the control net shows no cut link; the layout (the index buffer) is
// made again only on frames whose cut links changed, while the points follow the opening wound;
// and the view equals the frame the run would draw of the same snapshot.
TEST(ViewTissue, ABladesWoundInAChargedLayerIsDrawnWithNoTriangleAcrossItAndRelaidOnlyWhenTheCutChanges) {
  using namespace palpate;
  auto scene = load_scene(std::string(PALPATE_TEST_DATA_DIR) + "/scenes/blade-patch.yaml");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  auto made = make_tissue(*scene, 0);
  ASSERT_TRUE(made.ok()) << made.error().message;
  SnapshotTissue tissue(std::move(*made));
  const float depth = static_cast<float>(wound_wall_depth(*scene, 0));
  EXPECT_EQ(depth, static_cast<float>(scene->tissues[0].charged.thickness));
  const int resolution = 6;
  view::TissueView v;
  const TissueSnapshot& rest = tissue.latest();
  ASSERT_TRUE(view::update_view(v, rest, resolution, depth));
  ASSERT_TRUE(v.grid.has_value());
  EXPECT_EQ(v.triangles().size(), v.grid->tessellator().triangles().size()) << "uncut: the whole surface";
  EXPECT_EQ(v.grid_links.size(), size_t(v.rows * (v.cols - 1) + (v.rows - 1) * v.cols));
  const std::vector<Vec3f> rest_points = rest.points;

  ToolState tool;
  tool.blade = true, tool.radius = scene->tool.radius, tool.length = scene->tool.length;
  tool.axis = scene->tool.axis.normalized();
  const double z_path = 0.0004;
  const auto at = [&](double t) {  // the scene's waypoints, z off the row at 0
    const Vec3 a(-0.01, 0.005, z_path), b(-0.01, -0.002, z_path), c(0.01, -0.002, z_path), d(0.01, 0.005, z_path);
    if (t < 0.3) return Vec3(a + (b - a) * (t / 0.3));
    if (t < 1.3) return Vec3(b + (c - b) * (t - 0.3));
    if (t < 1.6) return Vec3(c + (d - c) * ((t - 1.3) / 0.3));
    return d;
  };
  size_t frames = 0, cut_changes = 0, relaid = 0;
  std::uint64_t revision = v.grid->layout_revision();
  std::vector<std::array<int, 2>> last_cut;
  const std::uint32_t* indices = nullptr;
  std::vector<float> last_positions;
  size_t moved_while_same_cut = 0;
  for (int k = 1; k <= 2000; ++k) {  // 2 s: the stroke, then 0.4 s for the wound to open
    tool.time = k * 0.001;
    tool.tip = at(tool.time);
    ASSERT_TRUE(tissue.step(tool, 0.001).allFinite());
    if (k % 20 != 0) continue;
    const TissueSnapshot& s = tissue.latest();
    ASSERT_TRUE(view::update_view(v, s, resolution, depth));
    ++frames;
    const bool changed = s.cut_links != last_cut;
    cut_changes += changed;
    relaid += v.grid->layout_revision() != revision;
    if (!changed && v.grid->layout_revision() == revision && !s.cut_links.empty()) {
      // The same cut: the same index buffer (not even reallocated); the points move with the wound.
      EXPECT_EQ(v.triangles().data(), indices);
      moved_while_same_cut += !std::equal(last_positions.begin(), last_positions.end(), v.positions().begin(),
                                          v.positions().end());
    }
    EXPECT_EQ(v.grid->layout_revision() != revision, changed) << "frame " << frames;
    revision = v.grid->layout_revision();
    last_cut = s.cut_links;
    indices = v.triangles().data();
    last_positions.assign(v.positions().begin(), v.positions().end());
    tissue.request();
  }
  EXPECT_GT(cut_changes, 2u) << "the cut grew over several frames";
  EXPECT_EQ(relaid, cut_changes);
  EXPECT_GT(moved_while_same_cut, 0u) << "after the stroke the wound still opens, and the drawing follows it";
  // The cut links were handed over as the stroke cut them without the haptic thread allocating.
  EXPECT_EQ(tissue.capacity_growths(), 0u);

  const TissueSnapshot& s = tissue.current();
  ASSERT_GT(s.cut_links.size(), 20u);
  // The cut line: the middle of the cut links' rest segments (the blade ran along z).
  double zc = 0;
  for (const auto& [i, j] : s.cut_links) zc += 0.5 * (rest_points[size_t(i)].z() + rest_points[size_t(j)].z());
  zc /= double(s.cut_links.size());
  EXPECT_LT(std::abs(zc - z_path), 0.0005);
  for (const auto& [i, j] : s.cut_links) {  // every cut link crosses it
    EXPECT_LT(std::min(rest_points[size_t(i)].z(), rest_points[size_t(j)].z()), zc);
    EXPECT_GT(std::max(rest_points[size_t(i)].z(), rest_points[size_t(j)].z()), zc);
  }
  // Where the blade ran through the layer (x from −8 to 6 mm: past its ends the wound tapers), no
  // surface triangle of the view has corners on both sides of the cut line.
  const auto pos = v.positions();
  const auto tris = v.triangles();
  const size_t n = v.grid->tessellator().point_count();
  size_t surface = 0, walls = 0, bridging = 0, near_cut = 0;
  for (size_t t = 0; t + 2 < tris.size(); t += 3) {
    if (tris[t] >= n) {  // a wall: its points after the surface's, at most the layer's depth below it
      ++walls;
      for (int c = 0; c < 3; ++c) EXPECT_GT(pos[3 * tris[t + c] + 1], -0.004f - depth);
      continue;
    }
    ++surface;
    float xmin = 1, xmax = -1, zmin = 1, zmax = -1;
    for (int c = 0; c < 3; ++c) {
      const float x = pos[3 * tris[t + c]], z = pos[3 * tris[t + c] + 2];
      xmin = std::min(xmin, x), xmax = std::max(xmax, x), zmin = std::min(zmin, z), zmax = std::max(zmax, z);
    }
    if (xmin < -0.008f || xmax > 0.006f) continue;
    near_cut += std::abs(0.5f * (zmin + zmax) - float(zc)) < 0.003f;
    bridging += zmin < float(zc) && zmax > float(zc);
  }
  EXPECT_EQ(bridging, 0u) << "triangles bridge the wound";
  EXPECT_GT(near_cut, 100u) << "the surface is drawn up to the wound's edges";
  EXPECT_GT(walls, 0u);
  EXPECT_LT(surface, v.grid->tessellator().triangle_count());
  // The control net shows no cut link (the snapshot's own links leave them out already).
  std::set<std::array<int, 2>> cut;
  for (const auto& [i, j] : s.cut_links) cut.insert({std::min(i, j), std::max(i, j)});
  size_t net_cut = 0;
  for (const auto& [i, j] : s.cut_links) net_cut += std::abs(i - j) == 1 || std::abs(i - j) == v.cols;
  EXPECT_GT(net_cut, 0u) << "some cut links are segments of the net";
  EXPECT_EQ(v.grid_links.size(), size_t(v.rows * (v.cols - 1) + (v.rows - 1) * v.cols) - net_cut);
  for (const auto& [i, j] : v.grid_links) EXPECT_FALSE(cut.count({std::min(i, j), std::max(i, j)}));
  // The viewer draws what the run's frame draws of the same snapshot.
  std::vector<std::vector<float>> storage;
  std::vector<std::vector<uint32_t>> index_storage;
  FrameOptions options;
  options.resolution = resolution;
  auto frame = frame_scene(*scene, std::span<const TissueSnapshot>(&s, 1), tool.tip, Vec3::Zero(), options, storage,
                           index_storage);
  ASSERT_TRUE(frame.ok()) << frame.error().message;
  const RenderSurface& drawn = frame->surfaces.at(0);
  EXPECT_TRUE(std::ranges::equal(drawn.positions, v.positions()));
  EXPECT_TRUE(std::ranges::equal(drawn.normals, v.normals()));
  EXPECT_TRUE(std::ranges::equal(drawn.triangles, v.triangles()));
  // Healed (the tissue back to rest): the whole surface and net again.
  tissue.reset();
  TissueSnapshot healed;
  tissue.snapshot(healed);
  ASSERT_TRUE(view::update_view(v, healed, resolution, depth));
  EXPECT_EQ(v.triangles().size(), v.grid->tessellator().triangles().size());
  EXPECT_EQ(v.grid_links.size(), size_t(v.rows * (v.cols - 1) + (v.rows - 1) * v.cols));
}

}  // namespace
