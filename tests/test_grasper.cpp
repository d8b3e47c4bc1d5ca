// test_grasper.cpp — a grasper in the other hand (the scene's `grasper`, LoopTool::tissue_tool): a
// second tool on the tissues with its own device and safety filter. A scripted waypoint's `grasp`
// closes its jaws; on a mass-spring organ it presses as a probe and grasps and pulls as the scene's
// tool does, and its force is its own (tool 0 feels nothing of it); the loop refuses what it cannot
// do (two such tools, a tissue on its own thread). And the generated gallbladder on the liver's
// underside it is made for (data/scenes/gallbladder.yaml).
#include <palpate/device.h>
#include <palpate/haptics.h>
#include <palpate/scene.h>
#include <palpate/spring.h>
#include <palpate/tissue.h>
#include <palpate/tissue_files.h>

#include "tissue/spring/shapes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <queue>
#include <string>
#include <vector>

namespace {

using namespace palpate;

Waypoint at(double t, const Vec3& p, bool grasp = false) {
  Waypoint w;
  w.t = t;
  w.position = p;
  w.grasp = grasp;
  return w;
}

}  // namespace

// A waypoint's grasp holds from it until the next waypoint: the jaws close at the first waypoint
// that says so and open at the first that does not; before the first and from the last on, theirs.
TEST(ScriptedGrasp, AWaypointsGraspHoldsUntilTheNextWaypoint) {
  ScriptedDevice d({at(0.0, Vec3::Zero()), at(0.5, Vec3(0, 0.01, 0), true), at(1.0, Vec3(0, 0.02, 0), true),
                    at(1.5, Vec3(0, 0.03, 0))},
                   DeviceLimits{}, Vec3(0, -1, 0));
  DeviceState s;
  const auto buttons = [&](double t) {
    EXPECT_TRUE(d.read(t, s));
    return s.buttons;
  };
  EXPECT_EQ(buttons(0.0), 0u);
  EXPECT_EQ(buttons(0.49), 0u);
  EXPECT_EQ(buttons(0.5), 0u);    // (a waypoint's own tick belongs to the segment that ends there)
  EXPECT_EQ(buttons(0.501), 1u);  // closed from the waypoint that says so
  EXPECT_EQ(buttons(1.2), 1u);
  EXPECT_EQ(buttons(1.49), 1u);
  EXPECT_EQ(buttons(1.5), 0u);    // at and after the last waypoint: its own (open), as its position
  EXPECT_EQ(buttons(2.0), 0u);
  // Read in the scene file: `grasp` is a waypoint key, a boolean.
  auto scene = parse_scene(R"(
tool: {kind: sphere, radius: 0.002}
device:
  waypoints:
    - {t: 0, position: [0, 0, 0]}
    - {t: 1, position: [0, 0, 0], grasp: true}
tissues:
  - {name: t, patch: {shape: flat}}
)",
                           "grasp.yaml", ".");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  EXPECT_FALSE(scene->device.waypoints[0].grasp);
  EXPECT_TRUE(scene->device.waypoints[1].grasp);
  auto bad = parse_scene(R"(
tool: {kind: sphere, radius: 0.002}
device:
  waypoints:
    - {t: 0, position: [0, 0, 0], grasp: sometimes}
tissues:
  - {name: t, patch: {shape: flat}}
)",
                         "grasp.yaml", ".");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("grasp.yaml:5"), std::string::npos) << bad.error().message;
  EXPECT_NE(bad.error().message.find("grasp"), std::string::npos) << bad.error().message;
}

namespace {

// A 20 mm ball of soft tissue resting on its base (a sphere probe as the scene's tool, far away).
const char* kBall = R"(
dt: 0.001
duration: 3.0
tool: {kind: sphere, radius: 0.002}
tissues:
  - name: ball
    model: mass_spring
    patch: {shape: sphere, radius: 0.01, spacing: 0.002, center: [0, 0, 0]}
    material:
      topology: tet_edges
      solver: sparse
      youngs_modulus: 20000
      poisson_ratio: 0.4
      density: 1000
      spring_damping: 0.02
      point_damping: 0.01
      contact: vertices
      contact_stiffness: 400
      grasp_radius: 0.002
      grasp_stiffness: 200
      grasp_release_time: 0.05
)";

std::unique_ptr<Tissue> ball() {
  auto scene = parse_scene(kBall, "ball.yaml", ".");
  EXPECT_TRUE(scene.ok()) << scene.error().message;
  auto t = make_tissue(*scene, 0);
  EXPECT_TRUE(t.ok()) << t.error().message;
  return std::move(*t);
}

ToolDef jaws(double radius) {
  ToolDef d;
  d.kind = "sphere";
  d.radius = radius;
  return d;
}

}  // namespace

// The grasper closes on the ball's top, pulls it up 4 mm and lets go: pressing, it is pushed back
// out; pulling, it is pulled back down; let go, its pull fades to nothing. The scene's tool, held
// away from the ball, feels none of it. Every force within the grasper's device's limits.
TEST(Grasper, ItPressesGraspsAndPullsAnOrganOnItsOwnDevice) {
  auto tissue = ball();
  DeviceLimits lim;
  lim.max_force = 3.3, lim.max_force_rate = 200;
  ScriptedDevice hand({at(0, Vec3(0.03, 0.03, 0))}, lim, Vec3(0, -1, 0));  // the scene's tool, away
  // Top of the ball at y ≈ 0.01: the jaws (2 mm) come down to press 1 mm in, close, pull up, let go.
  ScriptedDevice grasper({at(0.0, Vec3(0, 0.014, 0)), at(0.4, Vec3(0, 0.011, 0)), at(0.6, Vec3(0, 0.011, 0), true),
                          at(1.6, Vec3(0, 0.015, 0), true), at(2.0, Vec3(0, 0.015, 0))},
                         lim, Vec3(0, -1, 0));
  LoopSettings ls;
  ls.dt = 0.001;
  ls.ramp_in = 0;
  LoopTool g{"grasper", &grasper, nullptr, 0.0, std::nullopt, {}};
  g.tissue_tool = jaws(0.002);
  auto loop = HapticLoop::create(hand, {{tissue.get(), 0.0}}, ls, {g});
  ASSERT_TRUE(loop.ok()) << loop.error().message;
  Vec3 pressed = Vec3::Zero(), pulled = Vec3::Zero(), let_go = Vec3::Zero();
  double tool0 = 0;
  Vec3 prev = Vec3::Zero();
  for (int k = 1; k <= 2600; ++k) {
    (*loop)->run_headless(1);
    const ToolSample s = (*loop)->tool_sample(1);
    ASSERT_TRUE(s.force.allFinite());
    ASSERT_LE(s.force.norm(), lim.max_force + 1e-12);
    ASSERT_LE((s.force - prev).norm(), lim.max_force_rate * ls.dt + 1e-12) << k;
    prev = s.force;
    tool0 = std::max(tool0, (*loop)->tool_sample(0).force.norm());
    if (k == 550) pressed = s.force;
    if (k == 1600) pulled = s.force;
    if (k == 2600) let_go = s.force;
  }
  EXPECT_GT(pressed.y(), 0.003) << "pressed into the top, the jaws are pushed back up";
  EXPECT_LT(pulled.y(), -0.05) << "pulled up, grasped: the organ pulls the jaws back down";
  EXPECT_LT(std::abs(pulled.x()) + std::abs(pulled.z()), 0.3 * std::abs(pulled.y()));
  EXPECT_LT(let_go.norm(), 0.005) << "let go 0.6 s ago: nothing holds";
  EXPECT_EQ(tool0, 0.0) << "the scene's tool is away from the organ: it feels nothing of the grasper";
  EXPECT_EQ((*loop)->stats().tools.at(0).safety.rate_limited, 0u);
}

// One tool in the other hand acts on the tissues; and only on tissues stepped on the haptic thread.
TEST(Grasper, TheLoopRefusesTwoTissueToolsOrATissueOnItsOwnThread) {
  auto tissue = ball();
  DeviceLimits lim;
  ScriptedDevice hand({at(0, Vec3(0.03, 0.03, 0))}, lim, Vec3(0, -1, 0));
  ScriptedDevice a({at(0, Vec3::Zero())}, lim, Vec3(0, -1, 0)), b({at(0, Vec3::Zero())}, lim, Vec3(0, -1, 0));
  LoopSettings ls;
  ls.dt = 0.001;
  LoopTool ga{"grasper", &a, nullptr, 0.1, std::nullopt, {}}, gb{"other", &b, nullptr, 0.1, std::nullopt, {}};
  ga.tissue_tool = gb.tissue_tool = jaws(0.002);
  auto two = HapticLoop::create(hand, {{tissue.get(), 0.0}}, ls, {ga, gb});
  ASSERT_FALSE(two.ok());
  EXPECT_NE(two.error().message.find("tool 2 'other': a second tool already acts on the tissues"), std::string::npos)
      << two.error().message;
  auto threaded = HapticLoop::create(hand, {{tissue.get(), 0.01}}, ls, {ga});
  ASSERT_FALSE(threaded.ok());
  EXPECT_NE(threaded.error().message.find("tissue 'ball' is stepped on its own thread"), std::string::npos)
      << threaded.error().message;
  LoopTool none{"grasper", &a, nullptr, 0.1, std::nullopt, {}};
  none.tissue_tool = jaws(0.0);
  auto flat = HapticLoop::create(hand, {{tissue.get(), 0.0}}, ls, {none});
  ASSERT_FALSE(flat.ok());
  EXPECT_NE(flat.error().message.find("needs a radius > 0 m"), std::string::npos) << flat.error().message;
}

// The scene's `grasper` section: read with its device, refused beside a probe, its tool built.
TEST(Grasper, TheSceneSectionIsReadAndAGrasperBesideAProbeIsRefused) {
  auto scene = parse_scene(std::string(kBall) + R"(
grasper:
  radius: 0.004
  device:
    max_force: 2.5
    waypoints:
      - {t: 0, position: [0, 0.02, 0], grasp: true}
)",
                           "ball.yaml", ".");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  ASSERT_TRUE(scene->grasper.has_value());
  EXPECT_EQ(scene->grasper->radius, 0.004);
  EXPECT_EQ(scene->grasper->device.max_force, 2.5);
  ASSERT_EQ(scene->grasper->device.waypoints.size(), 1u);
  EXPECT_TRUE(scene->grasper->device.waypoints[0].grasp);
  auto far = parse_scene(std::string(kBall) + "grasper: {radius: 0.2}\n", "ball.yaml", ".");
  ASSERT_FALSE(far.ok());
  EXPECT_NE(far.error().message.find("grasper.radius"), std::string::npos) << far.error().message;
  auto both = parse_scene(R"(
anatomy: {kind: neck}
tool: {kind: needle, radius: 0.0006, length: 0.06}
probe: {device: {waypoints: [{t: 0, position: [0, 0, 0]}]}}
grasper: {radius: 0.003}
)",
                          "both.yaml", ".");
  ASSERT_FALSE(both.ok());
  EXPECT_NE(both.error().message.find("both.yaml:5"), std::string::npos) << both.error().message;
  EXPECT_NE(both.error().message.find("not both"), std::string::npos) << both.error().message;
}

// The generated gallbladder (docs/models/cutting.md, "The gallbladder scene"): its published size,
// sunk in a slab of liver held from above, every tetrahedron positive, one connected organ, and an
// attachment — the springs across its bed — only over its footprint.
TEST(GallbladderShape, PublishedSizeInItsFossaUnderALiverHeldFromAbove) {
  const double s = 0.004;
  const spring::GallbladderBed bed = spring::make_gallbladder_bed(s);
  const TetMesh& m = bed.mesh;
  ASSERT_GT(m.T.rows(), 1000);
  for (Eigen::Index t = 0; t < m.T.rows(); ++t) {
    const Vec3 a = m.V.row(m.T(t, 0)).transpose();
    const double v6 = (m.V.row(m.T(t, 1)).transpose() - a)
                          .dot((m.V.row(m.T(t, 2)).transpose() - a).cross(m.V.row(m.T(t, 3)).transpose() - a));
    ASSERT_GT(std::abs(v6), 1e-3 * s * s * s) << "tet " << t;
  }
  // Below the liver's underside (y < 0): the gallbladder alone. Its extent, as cut out of the grid,
  // within two cells of the published 80 x 30 mm (neck to fundus, across) and of its 27 mm depth,
  // of which a quarter is in the fossa.
  Vec3 lo = Vec3::Constant(1e9), hi = Vec3::Constant(-1e9);
  for (Eigen::Index i = 0; i < m.V.rows(); ++i)
    if (m.V(i, 1) < -1e-9) lo = lo.cwiseMin(m.V.row(i).transpose()), hi = hi.cwiseMax(m.V.row(i).transpose());
  EXPECT_NEAR(hi.x() - lo.x(), 0.080, 2 * s);
  EXPECT_NEAR(hi.z() - lo.z(), 0.030, 2 * s);
  EXPECT_NEAR(-lo.y(), 0.027 * 0.75, 1.5 * s);
  EXPECT_GT(hi.x(), 0.028) << "the fundus passes the liver's inferior border";
  // Held: the liver's top face, all of it and nothing else.
  const double top = m.V.col(1).maxCoeff();
  EXPECT_NEAR(top, 0.020, 1e-9);
  size_t on_top = 0;
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) on_top += m.V(i, 1) > top - 1e-9 ? 1 : 0;
  EXPECT_EQ(bed.held.size(), on_top);
  for (int i : bed.held) EXPECT_NEAR(m.V(i, 1), top, 1e-9);
  // One organ: every vertex reached from a held one through the tetrahedra's edges.
  std::vector<std::vector<int>> adj(static_cast<size_t>(m.V.rows()));
  for (Eigen::Index t = 0; t < m.T.rows(); ++t)
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b)
        if (a != b) adj[static_cast<size_t>(m.T(t, a))].push_back(m.T(t, b));
  std::vector<char> seen(adj.size(), 0);
  std::queue<int> q;
  q.push(bed.held.front());
  seen[static_cast<size_t>(bed.held.front())] = 1;
  size_t reached = 1;
  while (!q.empty()) {
    const int v = q.front();
    q.pop();
    for (int w : adj[static_cast<size_t>(v)])
      if (!seen[static_cast<size_t>(w)]) seen[static_cast<size_t>(w)] = 1, ++reached, q.push(w);
  }
  EXPECT_EQ(reached, adj.size());
  // The bed: the vertices on y = 0 with the gallbladder under them lie within its footprint, the
  // ellipse where its sunk quarter meets the liver (published: 80 x 30 mm, a quarter sunk: about
  // 69 x 26 mm at the fundus's breadth, narrower at the neck).
  int bed_vertices = 0;
  for (Eigen::Index t = 0; t < m.T.rows(); ++t) {
    bool below = false, on = false;
    for (int k = 0; k < 4; ++k) below |= m.V(m.T(t, k), 1) < -1e-9;
    if (!below) continue;
    for (int k = 0; k < 4; ++k) {
      const Vec3 p = m.V.row(m.T(t, k)).transpose();
      if (std::abs(p.y()) < 1e-9) {
        on = true;
        EXPECT_LT(std::abs(p.x()), 0.040 + 1e-9);
        EXPECT_LT(std::abs(p.z()), 0.015 + 1e-9);
      }
    }
    bed_vertices += on ? 1 : 0;
  }
  EXPECT_GT(bed_vertices, 20);
}
