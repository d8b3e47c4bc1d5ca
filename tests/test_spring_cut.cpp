// test_spring_cut.cpp — cutting a mass-spring organ (src/tissue/spring/cut.cpp): removed springs and
// tetrahedra lose their force at once, and once the cutter's correction (or new factor) is installed
// every step equals the step of a predictor built from scratch for the cut network (issue 37 item 4).
#include <palpate/spring.h>

#include "spring_fixtures.h"
#include "tissue/spring/forces.h"
#include "tissue/spring/layouts.h"
#include "tissue/spring/stages.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <set>
#include <chrono>
#include <thread>
#include <vector>

namespace {

using namespace palpate;
using namespace spring_test;

struct CutCase {
  const char* name;
  SpringSolver solver;
  bool single;
  bool volume;  // ν = 0.4: the volume term's share in the predictor's weights
  double tolerance;
};

// A 6 x 5 x 4 tissue block, 2 mm spacing, held at its base, with spring damping and (when asked)
// the volume term.
SpringNetwork tissue_block(bool volume) {
  return tissue_network(spring::make_block(6, 5, 4, 0.002), volume ? 0.4 : 0.0, 1000, 0.02, Held::bottom);
}

SpringModelOptions options_for(const CutCase& c) {
  SpringModelOptions o;
  o.solver = c.solver;
  o.single_precision = c.single;
  o.gravity = true;
  return o;
}

// The springs whose rest segment crosses the plane x = at (a straight cut through the block).
std::vector<int> crossing(const SpringNetwork& net, double at) {
  std::vector<int> out;
  for (size_t e = 0; e < net.springs.size(); ++e) {
    const double a = net.rest(net.springs[e][0], 0) - at, b = net.rest(net.springs[e][1], 0) - at;
    if (a * b < 0) out.push_back(static_cast<int>(e));
  }
  return out;
}

// The network cut from scratch: the removed springs' stiffness and damping zero (the predictor is
// the same as without them), the removed tetrahedra gone.
SpringNetwork cut_from_scratch(const SpringNetwork& original, const std::vector<std::uint8_t>& springs,
                               const std::vector<std::uint8_t>& tets) {
  SpringNetwork net = original;
  for (size_t e = 0; e < springs.size(); ++e)
    if (springs[e]) net.stiffness[e] = net.damping[e] = 0;
  net.tets.clear();
  net.rest_volume.clear();
  for (size_t t = 0; t < tets.size(); ++t)
    if (!tets[t]) {
      net.tets.push_back(original.tets[t]);
      net.rest_volume.push_back(original.rest_volume[t]);
    }
  return net;
}

// A moving, deformed state: every free vertex displaced and moving (fixed seed).
void stir(const SpringModel& model, SpringState& s) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  for (Eigen::Index i = 0; i < s.x.rows(); ++i) {
    if (model.anchored[static_cast<size_t>(i)]) continue;
    for (int c = 0; c < 3; ++c) {
      s.x(i, c) += 2e-4 * u(rng);
      s.v(i, c) = 0.05 * u(rng);
    }
  }
}

// max |Δv_cut − Δv_ref| / max |Δv_ref| after one step from the same state.
double step_residual(SpringModel& cut, const SpringModel& ref, const SpringState& from) {
  SpringState a = make_state(cut), b = make_state(ref);
  a.x = b.x = from.x;
  a.v = b.v = from.v;
  EXPECT_TRUE(step(cut, a, nullptr));
  EXPECT_TRUE(step(ref, b, nullptr));
  const RowMat3d da = a.v - from.v, db = b.v - from.v;
  return (da - db).cwiseAbs().maxCoeff() / db.cwiseAbs().maxCoeff();
}

class SpringCut : public ::testing::TestWithParam<CutCase> {};

TEST_P(SpringCut, EveryStepAfterACutEqualsTheStepOfAPredictorBuiltForTheCutNetwork) {
  const CutCase& c = GetParam();
  const SpringNetwork original = tissue_block(c.volume);
  SpringModel model = must_build(original, options_for(c));
  SpringCutOptions co;
  co.fixed_latency = 1;
  co.refactor_rank = 1000;  // corrections only (the next test swaps factors)
  co.max_rank = 1000;
  auto cutter = SpringCutter::create(model, co);
  ASSERT_TRUE(cutter.ok()) << cutter.error().message;
  SpringState s = make_state(model);
  stir(model, s);

  // First cut: the plane x = 5 mm.
  const std::vector<int> first = crossing(original, 0.005);
  ASSERT_GT(first.size(), 20u);
  EXPECT_EQ((*cutter)->remove_springs(first), static_cast<int>(first.size()));
  EXPECT_EQ((*cutter)->remove_springs(first), 0);  // already removed
  (*cutter)->settle();
  EXPECT_EQ((*cutter)->status().pending, 0);
  EXPECT_GT((*cutter)->status().correction_rank, 20);
  if (c.volume) {
    EXPECT_GT((*cutter)->status().removed_tets, 0);
  }
  {
    const SpringModel ref = must_build(cut_from_scratch(original, (*cutter)->removed_springs(), (*cutter)->removed_tets()),
                                       options_for(c));
    EXPECT_LE(step_residual(model, ref, s), c.tolerance);
  }
  // A second cut crossing the first: x = 7 mm (a piece nearly cut off between them).
  const std::vector<int> second = crossing(original, 0.007);
  EXPECT_GT((*cutter)->remove_springs(second), 0);
  (*cutter)->settle();
  {
    const SpringModel ref = must_build(cut_from_scratch(original, (*cutter)->removed_springs(), (*cutter)->removed_tets()),
                                       options_for(c));
    EXPECT_LE(step_residual(model, ref, s), c.tolerance);
  }
}

TEST_P(SpringCut, ANewFactorSwappedInIsExactAndCorrectionsAfterItAreToo) {
  const CutCase& c = GetParam();
  const SpringNetwork original = tissue_block(c.volume);
  SpringModel model = must_build(original, options_for(c));
  SpringCutOptions co;
  co.fixed_latency = 1;
  co.refactor_rank = 8;  // the first cut passes it: a new factor
  co.max_rank = 256;
  auto cutter = SpringCutter::create(model, co);
  ASSERT_TRUE(cutter.ok()) << cutter.error().message;
  SpringState s = make_state(model);
  stir(model, s);
  (*cutter)->remove_springs(crossing(original, 0.005));
  (*cutter)->settle();
  EXPECT_EQ((*cutter)->status().factors, 1);
  EXPECT_EQ((*cutter)->status().correction_rank, 0);  // the factor holds the whole cut
  {
    const SpringModel ref = must_build(cut_from_scratch(original, (*cutter)->removed_springs(), (*cutter)->removed_tets()),
                                       options_for(c));
    EXPECT_LE(step_residual(model, ref, s), c.tolerance);
  }
  // A few more springs: a correction relative to the new factor (with the volume term a spring's
  // tetrahedra change more than refactor_rank edges' weights: then a second factor).
  const std::vector<int> more = crossing(original, 0.007);
  (*cutter)->remove_springs(std::span(more).first(c.volume ? 1 : 4));
  (*cutter)->settle();
  const SpringCutStatus st = (*cutter)->status();
  if (c.volume) {
    EXPECT_TRUE((st.factors == 1 && st.correction_rank > 0) || st.factors == 2) << st.factors;
  } else {
    EXPECT_EQ(st.factors, 1);
    EXPECT_GT(st.correction_rank, 0);
  }
  {
    const SpringModel ref = must_build(cut_from_scratch(original, (*cutter)->removed_springs(), (*cutter)->removed_tets()),
                                       options_for(c));
    EXPECT_LE(step_residual(model, ref, s), c.tolerance);
  }
}

INSTANTIATE_TEST_SUITE_P(Predictors, SpringCut,
                         ::testing::Values(CutCase{"sparse_double", SpringSolver::sparse, false, false, 1e-10},
                                           CutCase{"sparse_double_volume", SpringSolver::sparse, false, true, 1e-10},
                                           CutCase{"sparse_single_volume", SpringSolver::sparse, true, true, 1e-5},
                                           CutCase{"dense_double", SpringSolver::desbrun, false, false, 1e-10},
                                           CutCase{"dense_double_volume", SpringSolver::desbrun, false, true, 1e-10},
                                           CutCase{"dense_single", SpringSolver::desbrun, true, false, 1e-5}),
                         [](const auto& param_info) { return std::string(param_info.param.name); });

TEST(SpringCutAllPairs, TheSeedsAllPairsOrganCutStaysExact) {
  // The seed paper's organ: every vertex tied to every other, the dense predictor.
  TetMesh mesh = spring::make_block(4, 3, 3, 0.003);
  SpringNetworkOptions o;
  o.topology = SpringTopology::all_pairs;
  o.stiffness = 20;
  o.spring_damping = 0.01;
  o.mass = 0.05;
  for (int k = 0; k < 3; ++k)
    for (int i = 0; i < 4; ++i) o.anchors.push_back(i + 4 * 3 * k);
  auto net = make_spring_network(mesh, o, "all pairs");
  ASSERT_TRUE(net.ok()) << net.error().message;
  SpringModelOptions so;
  so.solver = SpringSolver::desbrun;
  SpringModel model = must_build(*net, so);
  ASSERT_TRUE(model.all_pairs);
  SpringCutOptions co;
  co.fixed_latency = 1;
  co.refactor_rank = 256;
  auto cutter = SpringCutter::create(model, co);
  ASSERT_TRUE(cutter.ok());
  SpringState s = make_state(model);
  stir(model, s);
  const std::vector<int> cut = crossing(*net, 0.0045);
  ASSERT_GT(cut.size(), 50u);
  (*cutter)->remove_springs(cut);
  (*cutter)->settle();
  const SpringModel ref = must_build(cut_from_scratch(*net, (*cutter)->removed_springs(), (*cutter)->removed_tets()), so);
  EXPECT_LE(step_residual(model, ref, s), 1e-10);
}

TEST(SpringCutForces, ARemovedElementsForceIsGoneFromTheNextStepBeforeAnyCorrection) {
  // The force pass of the cut model (vectorised, with the volume term's lanes) against the scalar
  // reference on the network cut from scratch, before the worker has corrected anything.
  const SpringNetwork original = tissue_block(true);
  SpringModelOptions o;
  o.solver = SpringSolver::sparse;
  SpringModel model = must_build(original, o);
  SpringCutOptions co;
  co.fixed_latency = 1;
  auto cutter = SpringCutter::create(model, co);
  ASSERT_TRUE(cutter.ok());
  SpringState s = make_state(model);
  stir(model, s);
  (*cutter)->remove_springs(crossing(original, 0.005));
  EXPECT_GT((*cutter)->status().pending, -1);
  const SpringNetwork ref = cut_from_scratch(original, (*cutter)->removed_springs(), (*cutter)->removed_tets());
  RowMat3d f_cut = RowMat3d::Zero(s.x.rows(), 3), r_cut = f_cut, f_ref = f_cut;
  std::vector<double> scratch(spring::spring_pass_scratch(model) + 64);
  spring::add_spring_forces_and_stiffness_term(model, s.x, s.v, f_cut, r_cut, scratch.data(), true);
  spring::add_spring_forces(ref, s.x, s.v, f_ref);
  RowMat3d f_scalar = RowMat3d::Zero(s.x.rows(), 3);
  spring::add_spring_forces(model.network, s.x, s.v, f_scalar);
  EXPECT_LE((f_scalar - f_ref).cwiseAbs().maxCoeff(), 1e-9 * f_ref.cwiseAbs().maxCoeff());
  EXPECT_LE((f_cut - f_ref).cwiseAbs().maxCoeff(), 1e-9 * f_ref.cwiseAbs().maxCoeff());
  // And the energy stored in what was removed is gone: the cut block's elastic energy is the
  // reference network's.
  SpringModel ref_model = must_build(ref, o);
  EXPECT_NEAR(elastic_energy(model, s), elastic_energy(ref_model, s), 1e-12 * elastic_energy(ref_model, s) + 1e-15);
}

TEST(SpringCutOptionsCheck, BadOptionsAndTheExactSolverAreRefused) {
  SpringModelOptions o;
  o.solver = SpringSolver::exact;
  SpringModel exact = must_build(tissue_block(false), o);
  auto a = SpringCutter::create(exact);
  ASSERT_FALSE(a.ok());
  EXPECT_NE(a.error().message.find("exact solver"), std::string::npos);
  o.solver = SpringSolver::sparse;
  SpringModel sparse = must_build(tissue_block(false), o);
  SpringCutOptions bad;
  bad.refactor_rank = 300;
  bad.max_rank = 100;
  auto b = SpringCutter::create(sparse, bad);
  ASSERT_FALSE(b.ok());
  EXPECT_NE(b.error().message.find("refactor_rank <= max_rank"), std::string::npos);
  // Out-of-range and repeated indices remove nothing.
  auto c = SpringCutter::create(sparse);
  ASSERT_TRUE(c.ok());
  const int wrong[] = {-1, 1 << 30};
  EXPECT_EQ((*c)->remove_springs(wrong), 0);
  EXPECT_EQ((*c)->remove_tets(wrong), 0);
  // A second cutter on the same model is refused once the first has installed a correction.
  const int one[] = {crossing(sparse.network, 0.005).back()};  // a free spring, high in the block
  (*c)->remove_springs(one);
  (*c)->settle();
  auto d = SpringCutter::create(sparse);
  EXPECT_FALSE(d.ok());
}

}  // namespace

namespace {

// Every undirected edge of the triangles is used by exactly two of them, once each way (closed and
// consistently oriented).
void expect_closed(const std::vector<std::array<int, 3>>& tris) {
  std::map<std::pair<int, int>, int> directed;
  for (const auto& t : tris)
    for (int k = 0; k < 3; ++k) ++directed[{t[static_cast<size_t>(k)], t[static_cast<size_t>((k + 1) % 3)]}];
  int bad = 0;
  for (const auto& [e, count] : directed) {
    const auto back = directed.find({e.second, e.first});
    if (count != 1 || back == directed.end() || back->second != 1) ++bad;
  }
  EXPECT_EQ(bad, 0) << "of " << directed.size() << " directed edges";
}

TEST(SpringCutSurface, TheDrawnSurfaceShowsTheCutsFacesAndStaysClosed) {
  const SpringNetwork original = tissue_block(true);
  SpringModelOptions o;
  o.solver = SpringSolver::sparse;
  SpringModel model = must_build(original, o);
  ASSERT_TRUE(model.closed_surface);
  const size_t before = model.network.triangles.size();
  expect_closed(model.network.triangles);
  auto cutter = SpringCutter::create(model);
  ASSERT_TRUE(cutter.ok());
  // Half-way through the block: a slit that ends inside it (only springs above y = 4 mm).
  std::vector<int> slit;
  for (int e : crossing(original, 0.005))
    if (original.rest(original.springs[static_cast<size_t>(e)][0], 1) > 0.0039 &&
        original.rest(original.springs[static_cast<size_t>(e)][1], 1) > 0.0039)
      slit.push_back(e);
  ASSERT_FALSE(slit.empty());
  (*cutter)->remove_springs(slit);
  EXPECT_GT(model.network.triangles.size(), before);  // the wound's walls are drawn
  expect_closed(model.network.triangles);
  // Every vertex of the drawn triangles is among the surface vertices the contact culls with.
  std::set<int> listed(model.surface_vertices.begin(), model.surface_vertices.end());
  for (const auto& t : model.network.triangles)
    for (int v : t) EXPECT_TRUE(listed.count(v)) << "vertex " << v;
  // Right through (the crossing cut): a piece comes off, both parts closed.
  (*cutter)->remove_springs(crossing(original, 0.005));
  (*cutter)->remove_springs(crossing(original, 0.007));
  expect_closed(model.network.triangles);
  // No drawn triangle is a face of a removed tetrahedron only: each lies on a live one.
  const auto& gone = (*cutter)->removed_tets();
  std::set<std::array<int, 3>> live_faces;
  for (size_t t = 0; t < original.tets.size(); ++t) {
    if (gone[t]) continue;
    const auto [a, b, c, d] = original.tets[t];
    for (std::array<int, 3> f : {std::array<int, 3>{a, b, c}, {a, b, d}, {a, c, d}, {b, c, d}}) {
      std::sort(f.begin(), f.end());
      live_faces.insert(f);
    }
  }
  for (auto t : model.network.triangles) {
    std::sort(t.begin(), t.end());
    EXPECT_TRUE(live_faces.count(t));
  }
}

TEST(SpringCutSurface, ACutSurfaceNetworkLosesTheTrianglesOnItsCutSprings) {
  // A network over a surface only (no tetrahedra): the triangles on a removed spring are gone
  // (the wound is an open slit: nothing to close it with).
  TetMesh block = spring::make_block(5, 2, 5, 0.002);
  SpringNetworkOptions no;
  no.topology = SpringTopology::tet_edges;
  auto tet_net = make_spring_network(block, no, "block");
  ASSERT_TRUE(tet_net.ok());
  SurfaceMesh surface;
  surface.V = tet_net->rest;
  surface.F.resize(static_cast<Eigen::Index>(tet_net->triangles.size()), 3);
  for (size_t i = 0; i < tet_net->triangles.size(); ++i)
    for (int k = 0; k < 3; ++k) surface.F(static_cast<Eigen::Index>(i), k) = tet_net->triangles[i][static_cast<size_t>(k)];
  no.topology = SpringTopology::edges;
  auto net = make_spring_network(surface, no, "surface");
  ASSERT_TRUE(net.ok()) << net.error().message;
  SpringModelOptions o;
  o.solver = SpringSolver::sparse;
  SpringModel model = must_build(*net, o);
  auto cutter = SpringCutter::create(model);
  ASSERT_TRUE(cutter.ok());
  const std::vector<int> cut = crossing(*net, 0.005);
  (*cutter)->remove_springs(cut);
  const auto& removed = (*cutter)->removed_springs();
  for (const auto& t : model.network.triangles)
    for (int k = 0; k < 3; ++k) {
      const int a = std::min(t[static_cast<size_t>(k)], t[static_cast<size_t>((k + 1) % 3)]);
      const int b = std::max(t[static_cast<size_t>(k)], t[static_cast<size_t>((k + 1) % 3)]);
      for (size_t e = 0; e < net->springs.size(); ++e) {
        if (net->springs[e][0] == a && net->springs[e][1] == b) {
          EXPECT_FALSE(removed[e]);
        }
      }
    }
  EXPECT_LT(model.network.triangles.size(), net->triangles.size());
}

}  // namespace

namespace {

TEST(SpringCutRealTime, StepsGoOnWhileTheWorkerCorrectsAndTheCorrectionArrives) {
  // The real-time path: the stepping thread never waits; install() takes what is ready. The steps in
  // between are finite and lose energy (the organ is damped and nothing drives it), and once the
  // correction is in, the next step is the cut network's exactly.
  const SpringNetwork original = tissue_block(true);
  SpringModelOptions o;
  o.solver = SpringSolver::sparse;
  SpringModel model = must_build(original, o);
  SpringCutOptions co;  // fixed_latency < 0: as soon as ready
  co.refactor_rank = 1000;
  co.max_rank = 1000;
  auto cutter = SpringCutter::create(model, co);
  ASSERT_TRUE(cutter.ok());
  SpringState s = make_state(model);
  stir(model, s);
  (*cutter)->remove_springs(crossing(original, 0.005));
  EXPECT_GT((*cutter)->status().removed_springs, 0);
  int steps = 0;
  const double start = kinetic_energy(model, s) + elastic_energy(model, s);
  while (true) {
    (*cutter)->install();
    if ((*cutter)->status().pending == 0) break;
    ASSERT_TRUE(step(model, s, nullptr));
    ASSERT_TRUE(s.x.allFinite());
    ++steps;
    if (steps > 20000) break;  // (generous: the worker needs milliseconds)
    std::this_thread::sleep_for(std::chrono::microseconds(100));
  }
  EXPECT_EQ((*cutter)->status().pending, 0) << "after " << steps << " steps";
  EXPECT_LE(kinetic_energy(model, s) + elastic_energy(model, s), start * 1.0001 + 1e-12);
  EXPECT_GT((*cutter)->status().installs, 0u);
  const SpringModel ref = must_build(cut_from_scratch(original, (*cutter)->removed_springs(), (*cutter)->removed_tets()), o);
  EXPECT_LE(step_residual(model, ref, s), 1e-10);
}

}  // namespace
