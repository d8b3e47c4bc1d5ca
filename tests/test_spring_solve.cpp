// test_spring_solve.cpp — the sparse predictor's per-tick solve (supernodes, orderings), the
// all-pairs force kernel, and the error bound of the single-precision predictor.
#include "spring_fixtures.h"

#include "tissue/spring/forces.h"
#include "tissue/spring/ordering.h"
#include "tissue/spring/solve.h"

#include <Eigen/Dense>

#include <cmath>
#include <cstdint>
#include <random>
#include <set>

using namespace palpate;
using namespace spring_test;

namespace {

// The predictor's matrix A = M + h(γI + C_L) + h²K_L with anchored rows and columns the identity,
// dense (the equation of docs/models/mass-spring.md, written out independently of model.cpp).
Eigen::MatrixXd predictor_matrix(const SpringNetwork& net, const SpringModelOptions& o) {
  const Eigen::Index n = static_cast<Eigen::Index>(net.size());
  const double h = o.dt;
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n, n);
  for (Eigen::Index i = 0; i < n; ++i) A(i, i) = net.mass[static_cast<size_t>(i)] + h * o.point_damping;
  for (size_t e = 0; e < net.springs.size(); ++e) {
    const int a = net.springs[e][0], b = net.springs[e][1];
    const double w = h * net.damping[e] + h * h * net.stiffness[e];
    A(a, a) += w; A(b, b) += w; A(a, b) -= w; A(b, a) -= w;
  }
  for (int a : net.anchors) {
    A.row(a).setZero();
    A.col(a).setZero();
    A(a, a) = 1;
  }
  return A;
}

RowMat3d random_rhs(Eigen::Index n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  RowMat3d b(n, 3);
  for (Eigen::Index i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) b(i, c) = u(rng);
  return b;
}

double relative(const RowMat3d& a, const RowMat3d& b) { return (a - b).cwiseAbs().maxCoeff() / b.cwiseAbs().maxCoeff(); }

SpringModelOptions sparse_options() {
  SpringModelOptions o;
  o.solver = SpringSolver::sparse;
  return o;
}

}  // namespace

TEST(SpringSolve, SupernodalSolveSolvesThePredictorSystem) {
  // A 9³ block with its bottom anchored and springs of different stiffness: the supernodal solve
  // (exact supernodes and two paddings) equals the column-by-column reference to 1e-13 and leaves
  // a residual |A x − b| below 1e-12 of |b|.
  SpringNetwork net = block_network(9, 9, 9, 0.005, 100.0, 0.1, true, 0.05);
  for (size_t e = 0; e < net.stiffness.size(); ++e) net.stiffness[e] *= 1.0 + 0.5 * std::sin(static_cast<double>(e));
  const SpringModelOptions o = sparse_options();
  const auto p = build_predictor(net, o);
  ASSERT_TRUE(p.ok()) << p.error().message;
  const Eigen::MatrixXd A = predictor_matrix(net, o);
  const RowMat3d b = random_rhs(p->n, 7);
  RowMat3d reference(p->n, 3), work(p->n, 3);
  spring::solve_columns(*p, b, reference, work);
  EXPECT_LT((A * reference - b).cwiseAbs().maxCoeff(), 1e-12 * b.cwiseAbs().maxCoeff());
  std::set<int> widths;
  for (double padding : {0.0, 0.5, 1.0}) {
    const spring::SpringSupernodes sn = spring::make_supernodes(*p, false, padding);
    for (size_t k = 0; k + 1 < sn.first_column.size(); ++k) widths.insert(sn.first_column[k + 1] - sn.first_column[k]);
    std::vector<double> scratch(spring::supernodal_scratch(*p, sn));
    RowMat3d x(p->n, 3);
    // Every build of the sweeps this CPU runs (the best of them is the step's).
    for (spring::SolveIsa isa : {spring::SolveIsa::x86_64, spring::SolveIsa::x86_64_v3, spring::SolveIsa::x86_64_v4}) {
      spring::solve_supernodal(*p, sn, b, x, scratch.data(), isa);
      const int level = static_cast<int>(isa);
      EXPECT_LT(relative(x, reference), 1e-13) << "padding " << padding << ", x86-64 level " << level;
      EXPECT_LT((A * x - b).cwiseAbs().maxCoeff(), 1e-12 * b.cwiseAbs().maxCoeff())
          << "padding " << padding << ", x86-64 level " << level;
    }
  }
  // The cases ran every kind of block: narrow ones solved in place (1 to 3 columns), and wide ones
  // of one group of columns narrower than eight, of several with a narrower last one, and of
  // eight-wide groups only.
  const auto some = [&](auto pred) { return std::any_of(widths.begin(), widths.end(), pred); };
  EXPECT_TRUE(some([](int w) { return w < 4; }));
  EXPECT_TRUE(some([](int w) { return w >= 4 && w < 8; }));
  EXPECT_TRUE(some([](int w) { return w > 8 && w % 8 != 0; }));
  EXPECT_TRUE(some([](int w) { return w >= 8 && w % 8 == 0; }));
}

TEST(SpringSolve, SupernodesPartitionTheColumnsAndHoldEveryEntryOfL) {
  SpringNetwork net = block_network(8, 8, 8, 0.005, 100.0, 0.1, true);
  const auto p = build_predictor(net, sparse_options());
  ASSERT_TRUE(p.ok());
  for (double padding : {0.0, 0.5}) {
    const spring::SpringSupernodes sn = spring::make_supernodes(*p, false, padding, 64);
    ASSERT_FALSE(sn.empty());
    EXPECT_EQ(sn.first_column.front(), 0);
    EXPECT_EQ(sn.first_column.back(), p->n);
    for (size_t k = 0; k + 1 < sn.first_column.size(); ++k) {
      const int w = sn.first_column[k + 1] - sn.first_column[k];
      EXPECT_GT(w, 0);
      EXPECT_LE(w, 64);
      // Rows below a block are ascending and below its last column.
      for (int q = sn.row_start[k]; q < sn.row_start[k + 1]; ++q) {
        EXPECT_GE(sn.rows[static_cast<size_t>(q)], sn.first_column[k + 1]);
        if (q > sn.row_start[k]) {
          EXPECT_GT(sn.rows[static_cast<size_t>(q)], sn.rows[static_cast<size_t>(q) - 1]);
        }
      }
    }
    // Every entry of L is stored once; the rest are padding zeros, within the allowed share.
    const auto nonzero = [](const auto& v) {
      return std::count_if(v.begin(), v.end(), [](double x) { return x != 0.0; });
    };
    // (the wide blocks' values and the narrow ones' chunks together).
    EXPECT_EQ(nonzero(sn.values) + nonzero(sn.chunk_values), nonzero(p->value)) << "padding " << padding;
    // The dense blocks (w(w − 1)/2 + r w entries each) hold at most (1 + padding) times the
    // entries of L, exactly as many without padding. The wide ones' storage adds only their
    // padding: a start on a multiple of eight values, and within the block's own rows and its rows
    // below, each rounded up to a multiple of eight, the zeros of the tiles on the diagonal.
    size_t dense = 0, dense_wide = 0, rounding = 0;
    const int S = static_cast<int>(sn.first_column.size()) - 1;
    ASSERT_EQ(sn.chunk_start.size(), static_cast<size_t>(S) + 1);
    int narrow_columns = 0;
    for (int k = 0; k < S; ++k) {
      const size_t w = static_cast<size_t>(sn.first_column[k + 1] - sn.first_column[k]);
      const size_t r = static_cast<size_t>(sn.row_start[k + 1] - sn.row_start[k]);
      dense += w * (w - 1) / 2 + r * w;
      if (w >= 4) {
        dense_wide += w * (w - 1) / 2 + r * w;
        EXPECT_EQ(sn.value_start[k] % 8, 0U) << "block " << k;
        rounding += 7 + ((w + 7) / 8 * 8 + (r + 7) / 8 * 8) * w - (w * (w - 1) / 2 + r * w);
        EXPECT_EQ(sn.chunk_start[k + 1], sn.chunk_start[k]) << "wide block " << k << " has no chunks";
        EXPECT_EQ(sn.run_end[k], k + 1);
        EXPECT_EQ(sn.run_begin[k], k);
        continue;
      }
      // A narrow block's chunks: each of its columns' entries of L in ceil(entries / 4) chunks, in
      // column order, rows below the pivot; the last chunk's padding is the pivot's row with 0.
      // Its run reaches back to the last wide block and on to the next.
      EXPECT_TRUE(sn.run_begin[k] == 0 || sn.first_column[sn.run_begin[k]] - sn.first_column[sn.run_begin[k] - 1] >= 4);
      EXPECT_TRUE(sn.run_end[k] == S || sn.first_column[sn.run_end[k] + 1] - sn.first_column[sn.run_end[k]] >= 4);
      EXPECT_LE(sn.run_begin[k], k);
      EXPECT_GT(sn.run_end[k], k);
      int q = sn.chunk_start[k];
      for (int c = sn.first_column[k]; c < sn.first_column[k + 1]; ++c, ++narrow_columns) {
        const int entries = p->col_start[c + 1] - p->col_start[c];
        for (int e = 0; e < entries; e += 4, ++q) {
          ASSERT_LT(q, sn.chunk_start[k + 1]);
          EXPECT_EQ(sn.pivot[q], c);
          for (int l = 0; l < 4; ++l) {
            const size_t slot = 4 * static_cast<size_t>(q) + static_cast<size_t>(l);
            if (e + l < entries) {
              EXPECT_GT(sn.chunk_rows[slot], c);
              EXPECT_EQ(sn.chunk_values[slot], p->value[static_cast<size_t>(p->col_start[c] + e + l)]);
            } else {
              EXPECT_EQ(sn.chunk_rows[slot], c);
              EXPECT_EQ(sn.chunk_values[slot], 0.0);
            }
          }
        }
      }
      EXPECT_EQ(q, sn.chunk_start[k + 1]) << "narrow block " << k;
    }
    EXPECT_GT(narrow_columns, 0);
    EXPECT_EQ(sn.chunk_rows.size(), 4 * sn.pivot.size());
    EXPECT_EQ(sn.chunk_values.size(), 4 * sn.pivot.size());
    EXPECT_LE(static_cast<double>(dense), (1.0 + padding) * static_cast<double>(p->value.size()) + 1e-9);
    if (padding == 0.0) {
      EXPECT_EQ(dense, p->value.size());
    }
    EXPECT_GE(sn.values.size(), dense_wide);
    EXPECT_LE(sn.values.size(), dense_wide + rounding);
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(sn.values.data()) % 64, 0U);
  }
}

TEST(SpringSolve, NestedDissectionFillsLessThanMinimumDegreeOnA3DBlock) {
  // 16³ = 4,096 vertices: the grid's plane separators beat AMD's greedy choice (measured on 20³:
  // 530k against 725k entries). The default build keeps whichever is sparser.
  SpringNetwork net = block_network(16, 16, 16, 0.005, 100.0, 0.1, true);
  const SpringModelOptions o = sparse_options();
  const auto amd = spring::build_predictor(net, o, spring::SparseOrdering::amd);
  const auto nd = spring::build_predictor(net, o, spring::SparseOrdering::nested_dissection);
  const auto best = build_predictor(net, o);
  ASSERT_TRUE(amd.ok() && nd.ok() && best.ok());
  std::printf("nnz(L): AMD %zu, nested dissection %zu\n", amd->value.size(), nd->value.size());
  EXPECT_LT(nd->value.size(), amd->value.size());
  EXPECT_EQ(best->value.size(), std::min(amd->value.size(), nd->value.size()));
  // perm is a permutation.
  std::vector<int> seen(static_cast<size_t>(nd->n), 0);
  for (int q : nd->perm) ++seen[static_cast<size_t>(q)];
  EXPECT_TRUE(std::all_of(seen.begin(), seen.end(), [](int c) { return c == 1; }));
  // Both METIS settings the build tries give permutations, and they differ (else trying both
  // would be pointless).
  const std::vector<int> one = spring::nested_dissection(nd->n, net.springs);
  const std::vector<int> ten = spring::nested_dissection(nd->n, net.springs, 10, 300);
  for (const std::vector<int>* q : {&one, &ten}) {
    ASSERT_EQ(q->size(), static_cast<size_t>(nd->n));
    std::vector<int> count(q->size(), 0);
    for (int i : *q) ++count[static_cast<size_t>(i)];
    EXPECT_TRUE(std::all_of(count.begin(), count.end(), [](int c) { return c == 1; }));
  }
  EXPECT_NE(one, ten);
  EXPECT_TRUE(nd->perm == one || nd->perm == ten);
}

TEST(SpringSolve, EveryOrderingAndSolveGivesTheSameSteps) {
  // The first kernel (AMD, column-by-column, as in predictor files written before) and the current
  // one (nested dissection, supernodes) step a probed block identically to 1e-12 m.
  SpringNetwork net = block_network(6, 6, 6, 0.01, 300.0, 0.1, true, 0.05);
  const SpringModelOptions o = sparse_options();
  auto old_p = spring::build_predictor(net, o, spring::SparseOrdering::amd);
  auto new_p = spring::build_predictor(net, o, spring::SparseOrdering::nested_dissection);
  ASSERT_TRUE(old_p.ok() && new_p.ok());
  auto old_model = build_spring_model(net, o, std::move(*old_p));
  auto new_model = build_spring_model(net, o, std::move(*new_p));
  ASSERT_TRUE(old_model.ok() && new_model.ok());
  old_model->solver->supernodes = spring::SpringSupernodes{};  // the column solve
  ASSERT_FALSE(new_model->solver->supernodes.empty());
  SpringState a = make_state(*old_model), b = make_state(*new_model);
  ToolState tool;
  tool.tip = Vec3(0.025, 0.0505, 0.025);
  tool.radius = 0.004;
  for (int i = 0; i < 100; ++i) {
    ASSERT_TRUE(step(*old_model, a, &tool));
    ASSERT_TRUE(step(*new_model, b, &tool));
  }
  EXPECT_GT(max_displacement(*new_model, b), 1e-4);
  EXPECT_LT((a.x - b.x).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_GT(a.anchor_force.norm(), 0.0);
  EXPECT_LT((a.anchor_force - b.anchor_force).norm(), 1e-9 * a.anchor_force.norm());
}

TEST(SpringSolve, FusedSparseStepIsTheGeneralStepExactly) {
  // The step's fused sparse path (right-hand side built straight into the solve's permuted layout,
  // v and x taken from it) does the general path's arithmetic operation for operation: a state whose
  // scratch is too small for the fused path takes the general one, and the two agree bit for bit over
  // probed steps, anchored and free, in double and in float.
  for (bool anchored : {true, false})
    for (bool single : {false, true}) {
      SpringNetwork net = block_network(7, 7, 7, 0.005, 200.0, 0.1, anchored, 0.05);
      SpringModelOptions o = sparse_options();
      o.single_precision = single;
      SpringModel model = must_build(net, o);
      ASSERT_FALSE(model.solver->supernodes.empty());
      SpringState fused = make_state(model), general = make_state(model);
      general.soa.resize(std::max(spring::spring_pass_scratch(model),
                                  spring::supernodal_scratch(model.predictor, model.solver->supernodes)));
      ASSERT_LT(general.soa.size(), fused.soa.size());
      ToolState tool;
      tool.tip = Vec3(0.015, 0.0335, 0.015);
      tool.radius = 0.004;
      for (int i = 0; i < 60; ++i) {
        tool.tip.y() -= 2e-5;
        ASSERT_TRUE(step(model, fused, &tool));
        ASSERT_TRUE(step(model, general, &tool));
      }
      EXPECT_GT(max_displacement(model, fused), 1e-5) << "anchored " << anchored << " single " << single;
      EXPECT_EQ((fused.x - general.x).cwiseAbs().maxCoeff(), 0.0) << "anchored " << anchored << " single " << single;
      EXPECT_EQ((fused.v - general.v).cwiseAbs().maxCoeff(), 0.0);
      EXPECT_EQ(fused.anchor_force, general.anchor_force);
      EXPECT_EQ(fused.tool_force, general.tool_force);
      EXPECT_GT(fused.contacts, 0);
    }
}

TEST(SpringSolve, SinglePrecisionErrorIsBounded) {
  // Stated bound: the float predictor's Δv is within 1e-6 (relative, max norm) of the double one,
  // for the sparse factor and the dense inverse (measured: 6e-9 and 3e-8); over 200 probed steps
  // positions stay within 1e-5 of the largest displacement.
  SpringNetwork net = block_network(8, 8, 8, 0.005, 100.0, 0.1, true, 0.05);
  for (SpringSolver solver : {SpringSolver::sparse, SpringSolver::desbrun}) {
    SpringModelOptions o;
    o.solver = solver;
    SpringModel dbl = must_build(net, o);
    o.single_precision = true;
    SpringModel flt = must_build(net, o);
    if (solver == SpringSolver::sparse) {
      EXPECT_FALSE(flt.solver->supernodes.values_single.empty());
      EXPECT_TRUE(flt.solver->supernodes.values.empty());
    } else {
      EXPECT_EQ(flt.solver->inverse_single.size(), flt.predictor.inverse.size());
    }
    const RowMat3d b = random_rhs(dbl.predictor.n, 11);
    RowMat3d x(b.rows(), 3), y(b.rows(), 3);
    std::vector<double> scratch(std::max(spring::supernodal_scratch(dbl.predictor, dbl.solver->supernodes),
                                         spring::dense_scratch(dbl.predictor.n)));
    if (solver == SpringSolver::sparse) {
      spring::solve_supernodal(dbl.predictor, dbl.solver->supernodes, b, x, scratch.data());
      // The float sweeps of the builds below the best (checked here; y is the best's, below).
      for (spring::SolveIsa isa : {spring::SolveIsa::x86_64, spring::SolveIsa::x86_64_v3}) {
        spring::solve_supernodal(flt.predictor, flt.solver->supernodes, b, y, scratch.data(), isa);
        EXPECT_LT(relative(y, x), 1e-6) << "x86-64 level " << static_cast<int>(isa);
      }
      spring::solve_supernodal(flt.predictor, flt.solver->supernodes, b, y, scratch.data());
    } else {
      spring::solve_dense(dbl.predictor, dbl.solver->inverse_single, b, x, scratch.data());
      spring::solve_dense(flt.predictor, flt.solver->inverse_single, b, y, scratch.data());
    }
    const double err = relative(y, x);
    std::printf("single precision solve error %.3g\n", err);
    EXPECT_LT(err, 1e-6);
    EXPECT_GT(err, 0.0);  // it really is float
    SpringState a = make_state(dbl), c = make_state(flt);
    ToolState tool;
    tool.tip = Vec3(0.0175, 0.0375, 0.0175);
    tool.radius = 0.004;
    for (int i = 0; i < 200; ++i) {
      ASSERT_TRUE(step(dbl, a, &tool));
      ASSERT_TRUE(step(flt, c, &tool));
    }
    const double peak = max_displacement(dbl, a);
    EXPECT_GT(peak, 1e-4);
    EXPECT_LT((a.x - c.x).cwiseAbs().maxCoeff(), 1e-5 * peak);
  }
}

TEST(SpringSolve, AllPairsKernelWithPerSpringStiffnessMatchesTheGenericOne) {
  // Non-uniform stiffness and damping take the per-spring branch of the all-pairs kernel and the
  // per-spring K_L v loop; the generic kernel (one spring order swapped) must agree to 1e-12 m.
  SpringNetworkOptions o;
  o.topology = SpringTopology::all_pairs;
  o.spring_damping = 0.3;
  auto net = make_spring_network(spring::make_ball_surface(41, 0.02), o, "ball");
  ASSERT_TRUE(net.ok());
  for (size_t e = 0; e < net->springs.size(); ++e) {
    net->stiffness[e] *= 1.0 + 0.5 * std::cos(static_cast<double>(e));
    net->damping[e] *= 1.0 + 0.5 * std::sin(static_cast<double>(e));
  }
  SpringNetwork shuffled = *net;
  std::swap(shuffled.springs[0], shuffled.springs[1]);
  std::swap(shuffled.rest_length[0], shuffled.rest_length[1]);
  std::swap(shuffled.stiffness[0], shuffled.stiffness[1]);
  std::swap(shuffled.damping[0], shuffled.damping[1]);
  SpringModelOptions mo;
  mo.solver = SpringSolver::desbrun;
  SpringModel fast = must_build(*net, mo), generic = must_build(shuffled, mo);
  ASSERT_TRUE(fast.all_pairs);
  ASSERT_FALSE(generic.all_pairs);
  EXPECT_EQ(fast.uniform_stiffness, 0.0);
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

TEST(SpringSolve, SinglePrecisionAllPairsForcesStayWithinTheirBound) {
  // The seed paper's topology on a 120-vertex ball, sagging under gravity and probed: with
  // single_precision (float predictor and, on AVX2 machines, float all-pairs forces) the force on
  // the tool stays within 1e-4 of the double one's peak and positions within 1e-4 of the largest
  // displacement over 200 steps.
  SpringNetworkOptions o;
  o.topology = SpringTopology::all_pairs;
  o.stiffness = 5.0;
  o.mass = 0.05;
  auto net = make_spring_network(spring::make_ball_surface(120, 0.02), o, "ball");
  ASSERT_TRUE(net.ok());
  SpringModelOptions mo;
  mo.solver = SpringSolver::desbrun;
  SpringModel dbl = must_build(*net, mo);
  mo.single_precision = true;
  SpringModel flt = must_build(*net, mo);
  EXPECT_EQ(flt.solver->rest_length_single.size(), flt.network.springs.size());
  SpringState a = make_state(dbl), b = make_state(flt);
  ToolState tool;
  tool.radius = 0.006;
  double peak_force = 0, force_gap = 0;
  for (int i = 0; i < 200; ++i) {
    tool.tip = Vec3(0, 0.024 - 0.00004 * i, 0);
    ASSERT_TRUE(step(dbl, a, &tool));
    ASSERT_TRUE(step(flt, b, &tool));
    peak_force = std::max(peak_force, a.tool_force.norm());
    force_gap = std::max(force_gap, (a.tool_force - b.tool_force).norm());
  }
  const double peak = max_displacement(dbl, a);
  std::printf("all pairs, single precision: position gap %.3g of %.3g m, force gap %.3g of %.3g N\n",
              (a.x - b.x).cwiseAbs().maxCoeff(), peak, force_gap, peak_force);
  EXPECT_GT(peak, 1e-4);
  EXPECT_GT(peak_force, 0.0);
  EXPECT_LT((a.x - b.x).cwiseAbs().maxCoeff(), 1e-4 * peak);
  EXPECT_LT(force_gap, 1e-4 * peak_force);
}

TEST(SpringSolve, VectorisedSpringPassMatchesTheScalarOne) {
  // The AVX2 and AVX-512 spring passes (four springs at a time on padded copies) against the scalar
  // loop, on a jittered, moving 5 x 4 x 3 block with per-spring rest lengths, one spring of zero
  // length (no force, but its −h K_L v term) and a spring count that is not a multiple of 4; first
  // with one stiffness and damping for all (the AVX-512 pass then reads no per-spring K and C),
  // then with each spring its own: forces and right-hand side agree to 1e-13 of their largest entry.
  SpringNetwork net = block_network(5, 4, 3, 0.01, 300.0, 0.1, false, 0.05);
  for (const std::array<int, 2> extra : {std::array<int, 2>{0, 59}, std::array<int, 2>{1, 58}}) {
    if (net.springs.size() % 4 != 0) break;  // the last group of four is then partial
    net.springs.push_back(extra);
    net.rest_length.push_back(0.02);
    net.stiffness.push_back(300.0);
    net.damping.push_back(0.1);
  }
  ASSERT_NE(net.springs.size() % 4, 0u);
  for (size_t e = 0; e < net.springs.size(); ++e) net.rest_length[e] *= 1.0 + 0.1 * std::sin(3.0 * static_cast<double>(e));
  if (!spring::has_avx2_fma()) std::printf("no AVX2 + FMA here: all ran the scalar pass\n");
  if (!spring::has_avx512()) std::printf("no AVX-512 here: its pass fell back to AVX2\n");
  // Then (directional) the directional_correction's right-hand side, AVX2 against scalar.
  for (const int pass : {0, 1, 2}) {
    const bool uniform = pass == 0, directional = pass == 2;
    if (pass == 1)
      for (size_t e = 0; e < net.springs.size(); ++e) {
        net.stiffness[e] *= 1.0 + 0.5 * std::sin(static_cast<double>(e));
        net.damping[e] *= 1.0 + 0.5 * std::cos(static_cast<double>(e));
      }
    SpringModelOptions o;
    o.solver = SpringSolver::sparse;
    o.directional_correction = directional;
    const SpringModel model = must_build(net, o);
    ASSERT_EQ(model.uniform_stiffness > 0 && model.uniform_damping, uniform);
    const Eigen::Index n = static_cast<Eigen::Index>(net.size());
    RowMat3d x = net.rest + 0.002 * random_rhs(n, 3), v = random_rhs(n, 5);
    const int a = net.springs[7][0], b = net.springs[7][1];
    x.row(b) = x.row(a);  // spring 7 has zero length
    RowMat3d f0 = random_rhs(n, 9), r0 = random_rhs(n, 13);  // both passes add to what is there
    const RowMat3d f_in = f0, r_in = r0;
    std::vector<double> scratch(spring::spring_pass_scratch(model) + 1);
    spring::add_spring_forces_and_stiffness_term(model, x, v, f0, r0, nullptr, false);
    // The AVX2 pass and the AVX-512 one (rsqrt14 + Newton instead of the divider).
    for (const spring::SpringKernel k : {spring::SpringKernel::avx2, spring::SpringKernel::avx512}) {
      RowMat3d f1 = f_in, r1 = r_in;
      // Start one double in, so the pass has to find its own 64-byte boundary.
      spring::add_spring_forces_and_stiffness_term(model, x, v, f1, r1, scratch.data() + 1, true, k);
      EXPECT_LT((f1 - f0).cwiseAbs().maxCoeff(), 1e-13 * f0.cwiseAbs().maxCoeff()) << "pass " << pass;
      EXPECT_LT((r1 - r0).cwiseAbs().maxCoeff(), 1e-13 * r0.cwiseAbs().maxCoeff()) << "pass " << pass;
      EXPECT_TRUE(f1.allFinite() && r1.allFinite());
    }
    if (directional) {
      // The correction changes the right-hand side (the springs are stretched, moving, not parallel
      // to their velocities' differences) and not the forces: r − r_in is h K_exact v per spring.
      SpringModelOptions plain = o;
      plain.directional_correction = false;
      const SpringModel reference = must_build(net, plain);
      RowMat3d f2 = f_in, r2 = r_in;
      spring::add_spring_forces_and_stiffness_term(reference, x, v, f2, r2, nullptr, false);
      EXPECT_EQ(f2, f0);
      EXPECT_GT((r2 - r0).cwiseAbs().maxCoeff(), 1e-3 * (r2 - r_in).cwiseAbs().maxCoeff());
      // Against the exact Jacobian written out: h Σ_e k[uuᵀ + max(0, 1 − L/l)(I − uuᵀ)](v_j − v_i).
      RowMat3d expect = r_in;
      const double h = o.dt;
      for (size_t e = 0; e < net.springs.size(); ++e) {
        const int i = net.springs[e][0], j = net.springs[e][1];
        const Vec3 d = (x.row(j) - x.row(i)).transpose(), w = (v.row(j) - v.row(i)).transpose();
        const double l = d.norm();
        Vec3 t = h * net.stiffness[e] * w;
        if (l > 0) {
          const Vec3 u = d / l;
          t = h * net.stiffness[e] * (u.dot(w) * u + std::max(0.0, 1.0 - net.rest_length[e] / l) * (w - u.dot(w) * u));
        }
        expect.row(i) += t.transpose();
        expect.row(j) -= t.transpose();
      }
      EXPECT_LT((r0 - expect).cwiseAbs().maxCoeff(), 1e-12 * r0.cwiseAbs().maxCoeff());
    }
  }
}

TEST(SpringSolve, SymmetricDenseProductMatchesTheFullOne) {
  // The desbrun product from A⁻¹'s upper triangle (AVX-512) against the full row-by-row product,
  // for blocks of 8 to 125 vertices (8, 12, 16, 27, 36, 45, …: full and partial blocks of eight,
  // rows that start in every lane): the same sums in
  // another order, so 1e-13 of the largest entry. The stored inverse is exactly symmetric.
  for (const int side : {2, 3, 4, 5}) {
    for (const int extra : {0, 1, 2}) {
      const int nx = side, ny = side, nz = side + extra;
      if (nx * ny * nz > 130) continue;
      SpringNetwork net = block_network(nx, ny, nz, 0.005, 100.0, 0.1, false, 0.05);
      SpringModelOptions o;
      o.solver = SpringSolver::desbrun;
      const SpringModel model = must_build(net, o);
      const int n = model.predictor.n;
      const auto& W = model.predictor.inverse;
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j)
          ASSERT_EQ(W[static_cast<size_t>(i * n + j)], W[static_cast<size_t>(j * n + i)]);
      const RowMat3d b = random_rhs(n, 17);
      RowMat3d full(n, 3), sym(n, 3);
      // One double in, so the product has to find its own 64-byte boundary.
      std::vector<double> scratch(spring::dense_scratch(n) + 1);
      spring::solve_dense(model.predictor, model.solver->inverse_single, b, full, scratch.data() + 1, false);
      spring::solve_dense(model.predictor, model.solver->inverse_single, b, sym, scratch.data() + 1, true);
      EXPECT_LT((sym - full).cwiseAbs().maxCoeff(), 1e-13 * full.cwiseAbs().maxCoeff()) << n << " vertices";
      EXPECT_TRUE(sym.allFinite());
    }
  }
}

TEST(SpringSolve, AllPairsKernelsMatchTheScalarOne) {
  // The AVX2 and AVX-512 all-pairs kernels against the scalar loop on jittered, moving balls (rows
  // of every length mod 8), uniform and per-spring stiffness, damping and rest length, two
  // coincident vertices (no force between them): forces agree to 1e-13 of the largest (the
  // vector kernels' 1/l is Newton-refined to round-off, the scalar one's is a square root).
  // Balls of 34, 38, 37 and 42 vertices: the AVX-512 kernel takes rows two at a time, and with an
  // even count a last row alone.
  for (const int count : {37, 38, 41, 45}) {
  SpringNetworkOptions o;
  o.topology = SpringTopology::all_pairs;
  o.spring_damping = 0.3;
  auto net = make_spring_network(spring::make_ball_surface(count, 0.02), o, "ball");
  ASSERT_TRUE(net.ok());
  const size_t n = net->size(), N = spring::all_pairs_stride(n);
  std::printf("%zu vertices\n", n);
  ASSERT_EQ(N % 8, 0u);
  const RowMat3d x = net->rest + 0.002 * random_rhs(static_cast<Eigen::Index>(n), 3);
  const RowMat3d v = random_rhs(static_cast<Eigen::Index>(n), 5);
  for (const bool uniform : {true, false}) {
    SpringNetwork m = *net;
    if (!uniform)
      for (size_t e = 0; e < m.springs.size(); ++e) {
        m.stiffness[e] *= 1.0 + 0.5 * std::sin(static_cast<double>(e));
        m.damping[e] *= 1.0 + 0.5 * std::cos(static_cast<double>(e));
        m.rest_length[e] *= 1.0 + 0.1 * std::sin(3.0 * static_cast<double>(e));
      }
    std::vector<std::vector<double>> out;
    for (const spring::SpringKernel k :
         {spring::SpringKernel::scalar, spring::SpringKernel::avx2, spring::SpringKernel::avx512}) {
      std::vector<double> scratch(spring::all_pairs_scratch(n) + 1);
      double* p = spring::align64(scratch.data() + 1);
      for (size_t i = 0; i < n; ++i)
        for (size_t c = 0; c < 3; ++c) {
          p[c * N + i] = x(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(c));
          p[(3 + c) * N + i] = v(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(c));
        }
      for (size_t c = 0; c < 3; ++c) p[c * N + 20] = p[c * N + 9];  // vertices 9 and 20 coincide
      spring::add_all_pair_forces_soa(m, uniform, p, N, k);
      out.emplace_back(p + 6 * N, p + 9 * N);
    }
    if (!spring::has_avx512()) std::printf("no AVX-512 here: its kernel fell back\n");
    double top = 0;
    for (double f : out[0]) top = std::max(top, std::abs(f));
    ASSERT_GT(top, 0.0);
    for (size_t k = 1; k < out.size(); ++k)
      for (size_t q = 0; q < out[0].size(); ++q) {
        ASSERT_TRUE(std::isfinite(out[k][q]));
        ASSERT_LT(std::abs(out[k][q] - out[0][q]), 1e-13 * top) << "kernel " << k << " entry " << q;
      }
  }
  }
}
