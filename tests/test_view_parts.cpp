// test_view_parts.cpp — the viewer's GUI-free parts: the orbit camera's geometry, ray picking, the
// needle tilted by a mouse drag, and SnapshotTissue's hand-over of positions from a stepping
// thread to a reading thread; the player of a scene's scripted tools.
#include <gtest/gtest.h>

// The viewer lives in the app (it links GUI libraries the test binary must not); these two
// sources of it use only palpate's public headers, so they are compiled in here.
#include "../apps/palpate/view/camera.cpp"
#include "../apps/palpate/view/tool_tilt.cpp"
#include "../apps/palpate/view/script_player.cpp"
#include <palpate/scene.h>
#include <palpate/device.h>
#include <palpate/snapshot_tissue.h>

#include <atomic>
#include <cmath>
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

}  // namespace
