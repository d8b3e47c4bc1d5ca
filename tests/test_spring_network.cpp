// test_spring_network.cpp — networks from meshes: spring counts per topology, lumped masses,
// stiffness from Young's modulus, the tissue wired into a scene, and errors on bad input.
#include <palpate/meshing.h>
#include <palpate/tissue_files.h>
#include "spring_fixtures.h"

#include "tissue/factory.h"

#include <cmath>
#include <filesystem>
#include <numeric>

using namespace palpate;
using namespace spring_test;

TEST(SpringNetwork, BlockHasTheExpectedEdgesAndPositiveTets) {
  const TetMesh b10 = spring::make_block(10, 10, 10, 0.01);
  SpringNetworkOptions o;
  o.topology = SpringTopology::tet_edges;
  auto net = make_spring_network(b10, o, "b10");
  ASSERT_TRUE(net.ok()) << net.error().message;
  EXPECT_EQ(net->size(), 1000u);
  EXPECT_EQ(net->springs.size(), 5130u);  // 2,700 axis edges + 2,430 face diagonals
  EXPECT_EQ(b10.T.rows(), 9 * 9 * 9 * 5);
  // Its boundary: 6 faces of 9·9 squares, two triangles each.
  EXPECT_EQ(net->triangles.size(), 6u * 81 * 2);
  auto net20 = make_spring_network(spring::make_block(20, 20, 20, 0.01), o, "b20");
  ASSERT_TRUE(net20.ok());
  EXPECT_EQ(net20->springs.size(), 44460u);
}

TEST(SpringNetwork, DensityLumpsMassFromVolume) {
  SpringNetworkOptions o;
  o.topology = SpringTopology::tet_edges;
  o.density = 1000.0;
  auto net = make_spring_network(spring::make_block(4, 3, 5, 0.01), o, "block");
  ASSERT_TRUE(net.ok());
  const double total = std::accumulate(net->mass.begin(), net->mass.end(), 0.0);
  EXPECT_NEAR(total, 1000.0 * 0.03 * 0.02 * 0.04, 1e-12);
  // A corner vertex carries less than an interior one.
  EXPECT_LT(net->mass[0], net->mass[1 + 4 * (1 + 3 * 1)]);
  // Uniform mass: the total shared equally.
  o.density = 0;
  o.mass = 0.6;
  net = make_spring_network(spring::make_block(4, 3, 5, 0.01), o, "block");
  EXPECT_DOUBLE_EQ(net->mass[17], 0.6 / 60);
  // A closed surface lumps from the volume it encloses (a ball: close to 4/3 π r³).
  auto ball = make_spring_network(spring::make_ball_surface(500, 0.05), SpringNetworkOptions{SpringTopology::edges, 100, 0, 0, 0, 1000.0, 0.0, {}, {}}, "ball");
  ASSERT_TRUE(ball.ok()) << ball.error().message;
  const double ball_mass = std::accumulate(ball->mass.begin(), ball->mass.end(), 0.0);
  EXPECT_NEAR(ball_mass, 1000.0 * 4.0 / 3.0 * M_PI * std::pow(0.05, 3), 0.03 * ball_mass);
}

TEST(SpringNetwork, YoungsModulusGivesVanGelderStiffness) {
  // One right tetrahedron: each edge is in the single tet, k_e = E V / |e|².
  TetMesh t;
  t.V.resize(4, 3);
  t.V << 0, 0, 0, 0.01, 0, 0, 0, 0.01, 0, 0, 0, 0.01;
  t.T.resize(1, 4);
  t.T << 0, 1, 2, 3;
  SpringNetworkOptions o;
  o.topology = SpringTopology::tet_edges;
  o.youngs_modulus = 3000.0;
  auto net = make_spring_network(t, o, "tet");
  ASSERT_TRUE(net.ok()) << net.error().message;
  const double vol = 1e-6 / 6;
  for (size_t e = 0; e < net->springs.size(); ++e)
    EXPECT_NEAR(net->stiffness[e], 3000.0 * vol / (net->rest_length[e] * net->rest_length[e]), 1e-12);
  // All pairs on the same tet = its edges: the uniform rule keeps Σ k |e|² = 6 E V.
  o.topology = SpringTopology::all_pairs;
  net = make_spring_network(t, o, "tet");
  ASSERT_TRUE(net.ok());
  double sum = 0;
  for (size_t e = 0; e < net->springs.size(); ++e) sum += net->stiffness[e] * net->rest_length[e] * net->rest_length[e];
  EXPECT_NEAR(sum, 6 * 3000.0 * vol, 1e-12);
}

TEST(SpringNetwork, AllPairsConnectsEveryVertexOnce) {
  SpringNetworkOptions o;
  o.topology = SpringTopology::all_pairs;
  auto net = make_spring_network(spring::make_ball_surface(60, 0.02), o, "ball");
  ASSERT_TRUE(net.ok());
  const size_t n = net->size();
  EXPECT_EQ(net->springs.size(), n * (n - 1) / 2);
  SpringModelOptions mo;
  auto model = build_spring_model(std::move(*net), mo);
  ASSERT_TRUE(model.ok());
  EXPECT_TRUE(model->all_pairs);  // the vectorised O(n²) kernel is used
}

TEST(SpringNetwork, AllPairsKernelMatchesTheGenericOne) {
  // The same all-pairs network with one spring's order swapped runs the generic kernel.
  SpringNetworkOptions o;
  o.topology = SpringTopology::all_pairs;
  o.spring_damping = 0.3;
  auto net = make_spring_network(spring::make_ball_surface(40, 0.02), o, "ball");
  ASSERT_TRUE(net.ok());
  SpringNetwork shuffled = *net;
  std::swap(shuffled.springs[0], shuffled.springs[1]);
  std::swap(shuffled.rest_length[0], shuffled.rest_length[1]);
  SpringModelOptions mo;
  mo.solver = SpringSolver::sparse;
  SpringModel fast = must_build(*net, mo), generic = must_build(shuffled, mo);
  ASSERT_TRUE(fast.all_pairs);
  ASSERT_FALSE(generic.all_pairs);
  SpringState a = make_state(fast), b = make_state(generic);
  ToolState tool;
  tool.tip = Vec3(0, 0.02, 0);
  tool.radius = 0.004;
  for (int i = 0; i < 100; ++i) {
    ASSERT_TRUE(step(fast, a, &tool));
    ASSERT_TRUE(step(generic, b, &tool));
  }
  EXPECT_GT(max_displacement(fast, a), 1e-4);
  EXPECT_LT((a.x - b.x).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(SpringNetwork, BadInputIsAnErrorNamingWhere) {
  SpringNetworkOptions o;
  o.topology = SpringTopology::tet_edges;
  auto r = make_spring_network(spring::make_ball_surface(60, 0.02), o, "organ.obj");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message,
            "organ.obj: topology tet_edges needs a tetrahedral mesh; fill the surface with tetrahedralize() first, or "
            "use edges or all_pairs");
  TetMesh t = spring::make_block(2, 2, 2, 0.01);
  t.T(3, 2) = 99;
  r = make_spring_network(t, o, "cube.msh");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, "cube.msh: tetrahedron 3 has vertex index 99, expected 0..7");
  t = spring::make_block(2, 2, 2, 0.01);
  std::swap(t.T(1, 0), t.T(1, 1));
  r = make_spring_network(t, o, "cube.msh");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message.rfind("cube.msh: tetrahedron 1 has volume -", 0), 0u) << r.error().message;
  o.anchors = {8};
  r = make_spring_network(spring::make_block(2, 2, 2, 0.01), o, "cube.msh");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, "cube.msh: anchor 8 is not a vertex (expected 0..7)");
  SpringMaterialDef m;
  m.topology = "springs";
  auto opt = network_options(m, {}, "scene.yaml:4: tissue 'liver'");
  ASSERT_FALSE(opt.ok());
  EXPECT_EQ(opt.error().message, "scene.yaml:4: tissue 'liver': topology 'springs' is not one of all_pairs|edges|tet_edges");
  SpringModelOptions mo;
  mo.dense_limit = 10;
  auto model = build_spring_model(block_network(3, 3, 3, 0.01, 100, 0.1, true), mo);
  ASSERT_FALSE(model.ok());
  EXPECT_EQ(model.error().message,
            "material.solver 'desbrun' keeps a dense n x n inverse: 27 vertices, 5.83 kB kept and about 23.3 kB to "
            "build, past its limit of 10 vertices (use solver: sparse)");
}

TEST(SpringTissue, PatchTissueInAScenePushesBackAndResetsOnNaN) {
  SceneDef scene;
  scene.file = "in-memory.yaml";
  scene.dt = 0.001;
  TissueDef t;
  t.name = "sheet";
  t.model = "mass_spring";
  t.line = 7;
  PatchDef p;
  p.width = p.height = 0.02;
  p.spacing = 0.002;
  t.patch = p;
  t.spring.solver = "sparse";
  t.spring.gravity = false;
  const auto file = std::filesystem::temp_directory_path() / ("palpate_sheet_" + std::to_string(::getpid()) + ".predictor");
  std::filesystem::remove(file);
  t.spring.predictor = file.string();
  // Anchor the border of the 11 x 11 sheet.
  for (int j = 0; j < 11; ++j)
    for (int i = 0; i < 11; ++i)
      if (i == 0 || j == 0 || i == 10 || j == 10) t.anchors.push_back(i + 11 * j);
  scene.tissues.push_back(t);
  auto tissue = make_tissue(scene, 0);
  ASSERT_TRUE(tissue.ok()) << tissue.error().message;
  EXPECT_TRUE(std::filesystem::exists(file));  // computed and written for next time
  Tissue& tis = **tissue;
  const auto names = tis.figure_names();
  ASSERT_EQ(names.size(), 9u);
  EXPECT_EQ(names[0], "force_N");
  EXPECT_EQ(names[4], "max_displacement_m");
  EXPECT_EQ(names[5], "kinetic_energy_J");
  ToolState tool;
  tool.radius = 0.002;
  Vec3 force = Vec3::Zero();
  for (int i = 0; i < 500; ++i) {
    tool.time = i * 0.001;
    tool.tip = Vec3(0, 0.002 - 0.003 * std::min(1.0, i / 200.0), 0);  // press 1 mm below the sheet
    force = tis.step(tool, 0.001);
  }
  EXPECT_GT(force.y(), 0.0);
  std::vector<double> fig(names.size());
  tis.figures(fig);
  EXPECT_DOUBLE_EQ(fig[0], force.norm());
  EXPECT_GT(fig[4], 5e-4);
  TissueSnapshot snap;
  tis.snapshot(snap);
  EXPECT_EQ(snap.points.size(), 121u);
  EXPECT_EQ(snap.triangles.size(), 200u);
  EXPECT_EQ(snap.links.size(), 320u);  // 220 grid edges + 100 diagonals
  // A non-finite tool position is ignored: no force, no event.
  tool.tip = Vec3(std::nan(""), 0, 0);
  tool.time = 0.5;
  EXPECT_EQ(tis.step(tool, 0.001), Vec3::Zero());
  TissueEvent none[4];
  EXPECT_EQ(tis.drain_events(none), 0u);
  // A glitching device reporting 1e9 m/s into the sheet kicks vertices past max_speed: the
  // watchdog resets the state, the force is zero and a "reset" event is queued.
  tool.tip = Vec3(0, -0.002, 0);  // where it pressed the sheet
  tool.velocity = Vec3(0, -1e9, 0);
  force = tis.step(tool, 0.001);
  EXPECT_EQ(force, Vec3::Zero());
  TissueEvent ev[4];
  ASSERT_EQ(tis.drain_events(ev), 1u);
  EXPECT_STREQ(ev[0].kind, "reset");
  EXPECT_EQ(ev[0].tissue, 0);
  EXPECT_EQ(tis.drain_events(ev), 0u);
  tis.figures(fig);
  EXPECT_EQ(fig[4], 0.0);
  // The predictor file is loaded the second time, even when it is required.
  scene.tissues[0].spring.predictor_policy = "require_file";
  auto again = make_tissue(scene, 0);
  ASSERT_TRUE(again.ok()) << again.error().message;
  scene.tissues[0].spring.stiffness = 250;
  auto stale = make_tissue(scene, 0);
  ASSERT_FALSE(stale.ok());
  EXPECT_EQ(stale.error().message, "in-memory.yaml:7: tissue 'sheet': " + file.string() +
                                       ": made for other parameters: stiffness of spring 0 is 100 N/m in the file, "
                                       "250 N/m here (predictor_policy: require_file)");
}
