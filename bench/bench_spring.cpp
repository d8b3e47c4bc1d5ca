// bench_spring.cpp — cost of one mass-spring tick (DS99 predictor, dense and sparse), of
// precomputing and loading a predictor, and of a baseline that re-factorises every tick.
#include <palpate/mesh.h>
#include <palpate/spring.h>
#include <palpate/mesh_load.h>
#include <palpate/meshing.h>
#include <palpate/tissue_files.h>

#include "tissue/spring/forces.h"
#include "tissue/spring/shapes.h"
#include "tissue/spring/solve.h"

#include <Eigen/SparseCholesky>
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>

namespace {

using namespace palpate;

SpringNetwork block(int n) {
  SpringNetworkOptions o;
  o.topology = SpringTopology::tet_edges;
  o.stiffness = 100.0;
  o.mass = 0.1;
  for (int k = 0; k < n; ++k)
    for (int i = 0; i < n; ++i) o.anchors.push_back(i + n * n * k);  // the y = 0 layer
  return *make_spring_network(spring::make_block(n, n, n, 0.005), o, "block");
}

// Anchors the bottom cap: the vertices in the lowest 5% of the height.
SpringNetwork anchor_bottom(SpringNetwork net) {
  const double lo = net.rest.col(1).minCoeff(), hi = net.rest.col(1).maxCoeff();
  for (Eigen::Index i = 0; i < net.rest.rows(); ++i)
    if (net.rest(i, 1) < lo + 0.05 * (hi - lo)) net.anchors.push_back(static_cast<int>(i));
  return net;
}

SpringNetwork organ(double radius_in_spacings) {
  SpringNetworkOptions o;
  o.topology = SpringTopology::tet_edges;
  o.stiffness = 100.0;
  o.mass = 0.5;
  return anchor_bottom(*make_spring_network(spring::make_tet_ball(radius_in_spacings * 0.002, 0.002), o, "organ"));
}

// A real organ's shape at about 10,000 vertices: SOFA's liver (data/meshes/liver_tet_boundary.obj,
// the boundary of liver.msh) scaled to 23 cm and filled with tetrahedra by Gmsh (edges ≤ 4.7 mm:
// 10,3xx vertices), springs on the tet edges, the lowest 5% of its height anchored.
SpringNetwork liver() {
  const auto surface =
      load_surface(std::filesystem::path(PALPATE_DATA_DIR) / "meshes" / "liver_tet_boundary.obj", 0.035);
  auto tets = tetrahedralize(*surface, 0.0047);
  SpringNetworkOptions o;
  o.topology = SpringTopology::tet_edges;
  o.stiffness = 100.0;
  o.mass = 0.5;
  return anchor_bottom(*make_spring_network(*tets, o, "liver"));
}

// Issue 21's comparison: the same tet meshes as tissue (E = 5 kPa, 1060 kg/m³), as today (springs,
// per-vertex contact) and with the new terms (poisson_ratio 0.48: the volume term; surface contact).
SpringNetwork tissue(const TetMesh& mesh, bool volume, const std::string& where) {
  SpringNetworkOptions o;
  o.topology = SpringTopology::tet_edges;
  o.youngs_modulus = 5000;
  o.poisson_ratio = volume ? 0.48 : 0.0;
  o.density = 1060;
  return anchor_bottom(*make_spring_network(mesh, o, where));
}

SpringNetwork paper_organ() {
  SpringNetworkOptions o;
  o.topology = SpringTopology::all_pairs;
  o.stiffness = 5.0;
  o.mass = 0.2;
  return *make_spring_network(spring::make_ball_surface(500, 0.04), o, "paper organ");
}

SpringModelOptions options(SpringSolver solver) {
  SpringModelOptions o;
  o.dt = 0.001;
  o.solver = solver;
  return o;
}

// Models are built once per process and shared by the benchmarks that tick them.
const SpringModel& cached(const std::string& key) {
  static std::map<std::string, std::unique_ptr<SpringModel>> models;
  auto& m = models[key];
  if (!m) {
    // A key is a case, then optional variants: "/single" (float predictor), "/amd_columns" (the
    // first kernel's solve: AMD ordering, column-by-column substitution; the baseline).
    const std::string name = key.substr(0, key.find('/'));
    const bool single = key.find("/single") != std::string::npos;
    const bool amd_columns = key.find("/amd_columns") != std::string::npos;
    SpringNetwork net;
    SpringSolver solver = SpringSolver::sparse;
    if (name == "paper") { net = paper_organ(); solver = SpringSolver::desbrun; }
    else if (name == "block10_dense") { net = block(10); solver = SpringSolver::desbrun; }
    else if (name == "block10") net = block(10);
    else if (name == "block20") net = block(20);
    else if (name == "organ10k") net = organ(13.4);
    else if (name == "liver10k") net = liver();
    else if (name == "organ50k") net = organ(22.9);
    const bool today = key.find("/today") != std::string::npos, volume = key.find("/volume") != std::string::npos;
    if (today || volume) {
      if (name == "block10") net = tissue(spring::make_block(10, 10, 10, 0.005), volume, "block");
      else if (name == "block20") net = tissue(spring::make_block(20, 20, 20, 0.005), volume, "block");
      else if (name == "organ10k") net = tissue(spring::make_tet_ball(13.4 * 0.002, 0.002), volume, "organ");
    }
    SpringModelOptions o = options(solver);
    if (today || key.find("/vertex_contact") != std::string::npos) o.contact = SpringContact::vertices;
    if (key.find("/exact1") != std::string::npos) o.exact_iterations = 1;
    if (key.find("/directional") != std::string::npos) o.directional_correction = true;
    o.single_precision = single;
    auto predictor = *spring::build_predictor(net, o, amd_columns ? spring::SparseOrdering::amd
                                                                  : spring::SparseOrdering::fewest_nonzeros);
    m = std::make_unique<SpringModel>(*build_spring_model(std::move(net), o, std::move(predictor)));
    if (amd_columns) m->solver->supernodes = spring::SpringSupernodes{};  // step() then takes the column solve
  }
  return *m;
}

// Where the probe starts: over the middle of the model's top.
Vec3 probe_top(const SpringModel& model) {
  return {model.network.rest.col(0).mean(), model.network.rest.col(1).maxCoeff(), model.network.rest.col(2).mean()};
}
// The probe of tick i: a 4 mm sphere from `top`, pressing in and out every 2 s.
ToolState probe(const Vec3& top, int i) {
  ToolState tool;
  tool.radius = 0.004;
  tool.tip = top + Vec3(0, 0.004 - 0.002 * ((i % 2000) / 2000.0), 0);
  return tool;
}

void tick(benchmark::State& state, const std::string& key) {
  const SpringModel& model = cached(key);
  SpringState s = make_state(model);
  const Vec3 top = probe_top(model);
  int i = 0;
  for (auto _ : state) {
    const ToolState tool = probe(top, i++);
    benchmark::DoNotOptimize(step(model, s, &tool));
  }
  const auto& p = model.predictor;
  state.counters["vertices"] = static_cast<double>(model.network.size());
  state.counters["springs"] = static_cast<double>(model.network.springs.size());
  state.counters["predictor_MiB"] =
      static_cast<double>(p.inverse.size() * 8 + p.value.size() * 12 + p.perm.size() * 16 + p.col_start.size() * 4) /
      (1024.0 * 1024.0);
  // What the tick actually streams: the dense inverse, or the supernodal values and block rows.
  const auto& sn = model.solver->supernodes;
  state.counters["solve_MiB"] =
      static_cast<double>(model.solver->inverse_single.empty() ? p.inverse.size() * 8 : model.solver->inverse_single.size() * 4) /
          (1024.0 * 1024.0) +
      static_cast<double>(sn.empty() ? p.value.size() * 12
                                     : sn.values.size() * 8 + sn.values_single.size() * 4 + sn.rows.size() * 4) /
          (1024.0 * 1024.0);
  state.counters["nnz_L"] = static_cast<double>(p.value.size());
  state.counters["tets"] = static_cast<double>(model.network.tets.size());
  state.counters["contacts"] = static_cast<double>(s.contacts);
}

// Issue 21: today's tick (springs, per-vertex contact) against the one with the volume term and the
// surface contact, on the same meshes as tissue, in one run (the probe presses 2 mm, as above).
void BM_SpringTick_Block10_Today(benchmark::State& s) { tick(s, "block10/today"); }
void BM_SpringTick_Block10_Volume(benchmark::State& s) { tick(s, "block10/volume"); }
void BM_SpringTick_Block20_Today(benchmark::State& s) { tick(s, "block20/today"); }
void BM_SpringTick_Block20_Volume(benchmark::State& s) { tick(s, "block20/volume"); }
void BM_SpringTick_Organ10k_Today(benchmark::State& s) { tick(s, "organ10k/today"); }
void BM_SpringTick_Organ10k_Volume(benchmark::State& s) { tick(s, "organ10k/volume"); }
// The two terms apart on the 1k block: the volume term with the first contact model.
void BM_SpringTick_Block10_VolumeVertexContact(benchmark::State& s) { tick(s, "block10/volume/vertex_contact"); }
BENCHMARK(BM_SpringTick_Block10_VolumeVertexContact)->Unit(benchmark::kMicrosecond);
// Backward Euler's damping on request: one conjugate-gradient step toward the exact system per tick.
void BM_SpringTick_Block10_VolumeExact1(benchmark::State& s) { tick(s, "block10/volume/exact1"); }
void BM_SpringTick_Block20_VolumeExact1(benchmark::State& s) { tick(s, "block20/volume/exact1"); }
void BM_SpringTick_Organ10k_VolumeExact1(benchmark::State& s) { tick(s, "organ10k/volume/exact1"); }
BENCHMARK(BM_SpringTick_Block10_VolumeExact1)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringTick_Block20_VolumeExact1)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringTick_Organ10k_VolumeExact1)->Unit(benchmark::kMicrosecond);
// directional_correction: the right-hand side with each spring's exact stiffness, in the spring pass.
void BM_SpringTick_Block10_VolumeDirectional(benchmark::State& s) { tick(s, "block10/volume/directional"); }
void BM_SpringTick_Block20_VolumeDirectional(benchmark::State& s) { tick(s, "block20/volume/directional"); }
void BM_SpringTick_Organ10k_VolumeDirectional(benchmark::State& s) { tick(s, "organ10k/volume/directional"); }
BENCHMARK(BM_SpringTick_Block10_VolumeDirectional)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringTick_Block20_VolumeDirectional)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringTick_Organ10k_VolumeDirectional)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringTick_Block10_Today)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringTick_Block10_Volume)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringTick_Block20_Today)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringTick_Block20_Volume)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringTick_Organ10k_Today)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringTick_Organ10k_Volume)->Unit(benchmark::kMicrosecond);

void BM_SpringTick_PaperAllPairs500(benchmark::State& s) { tick(s, "paper"); }
void BM_SpringTick_Block10_Dense(benchmark::State& s) { tick(s, "block10_dense"); }
void BM_SpringTick_Block10_Sparse(benchmark::State& s) { tick(s, "block10"); }
void BM_SpringTick_Block20_Sparse(benchmark::State& s) { tick(s, "block20"); }
void BM_SpringTick_Organ10k_Sparse(benchmark::State& s) { tick(s, "organ10k"); }
void BM_SpringTick_Organ50k_Sparse(benchmark::State& s) { tick(s, "organ50k"); }
void BM_SpringTick_Liver10k_Sparse(benchmark::State& s) { tick(s, "liver10k"); }
BENCHMARK(BM_SpringTick_PaperAllPairs500)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringTick_Block10_Dense)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringTick_Block10_Sparse)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringTick_Block20_Sparse)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringTick_Organ10k_Sparse)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringTick_Organ50k_Sparse)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringTick_Liver10k_Sparse)->Unit(benchmark::kMicrosecond);

// The same cases with the predictor in float (SpringModelOptions::single_precision).
void BM_SpringTick_PaperAllPairs500_Single(benchmark::State& s) { tick(s, "paper/single"); }
void BM_SpringTick_Block10_Sparse_Single(benchmark::State& s) { tick(s, "block10/single"); }
void BM_SpringTick_Block20_Sparse_Single(benchmark::State& s) { tick(s, "block20/single"); }
void BM_SpringTick_Organ10k_Sparse_Single(benchmark::State& s) { tick(s, "organ10k/single"); }
void BM_SpringTick_Liver10k_Sparse_Single(benchmark::State& s) { tick(s, "liver10k/single"); }
BENCHMARK(BM_SpringTick_PaperAllPairs500_Single)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringTick_Block10_Sparse_Single)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringTick_Block20_Sparse_Single)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringTick_Organ10k_Sparse_Single)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringTick_Liver10k_Sparse_Single)->Unit(benchmark::kMicrosecond);

// The paper case's all-pairs force kernel alone, per instruction set (one this processor lacks
// falls back to the next narrower), in one process so the ratios are fair on a shared machine.
void all_pairs_kernel(benchmark::State& state, spring::SpringKernel kernel) {
  const SpringModel& model = cached("paper");
  const size_t n = model.network.size(), N = spring::all_pairs_stride(n);
  std::vector<double> scratch(spring::all_pairs_scratch(n));
  double* p = spring::align64(scratch.data());
  for (size_t i = 0; i < n; ++i)
    for (size_t c = 0; c < 3; ++c) {
      p[c * N + i] = model.network.rest(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(c)) *
                     (1.0 + 0.01 * std::sin(static_cast<double>(3 * i + c)));
      p[(3 + c) * N + i] = 0.01 * std::cos(static_cast<double>(3 * i + c));
    }
  for (auto _ : state) {
    std::fill(p + 6 * N, p + 9 * N, 0.0);
    spring::add_all_pair_forces_soa(model.network, true, p, N, kernel);
    benchmark::DoNotOptimize(p);
  }
}
void BM_SpringAllPairsKernel_Scalar(benchmark::State& s) { all_pairs_kernel(s, spring::SpringKernel::scalar); }
void BM_SpringAllPairsKernel_Avx2(benchmark::State& s) { all_pairs_kernel(s, spring::SpringKernel::avx2); }
void BM_SpringAllPairsKernel_Avx512(benchmark::State& s) { all_pairs_kernel(s, spring::SpringKernel::avx512); }
BENCHMARK(BM_SpringAllPairsKernel_Scalar)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringAllPairsKernel_Avx2)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringAllPairsKernel_Avx512)->Unit(benchmark::kMicrosecond);

// The generic spring pass alone (springs' forces and −h K_L v, with the copies in and out of the
// padded layout) on the 20³ block, per kernel, in one process so the ratios are fair.
void spring_pass(benchmark::State& state, spring::SpringKernel kernel) {
  const SpringModel& model = cached("block20");
  const Eigen::Index n = static_cast<Eigen::Index>(model.network.size());
  RowMat3d x = model.network.rest, v(n, 3), f = RowMat3d::Zero(n, 3), r = RowMat3d::Zero(n, 3);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index c = 0; c < 3; ++c) {
      x(i, c) *= 1.0 + 0.01 * std::sin(static_cast<double>(3 * i + c));
      v(i, c) = 0.01 * std::cos(static_cast<double>(3 * i + c));
    }
  std::vector<double> scratch(spring::spring_pass_scratch(model));
  for (auto _ : state) {
    spring::add_spring_forces_and_stiffness_term(model, x, v, f, r, scratch.data(), true, kernel);
    benchmark::DoNotOptimize(f.data());
  }
  state.counters["springs"] = static_cast<double>(model.network.springs.size());
}
void BM_SpringPass_Block20_Scalar(benchmark::State& s) { spring_pass(s, spring::SpringKernel::scalar); }
void BM_SpringPass_Block20_Avx2(benchmark::State& s) { spring_pass(s, spring::SpringKernel::avx2); }
void BM_SpringPass_Block20_Avx512(benchmark::State& s) { spring_pass(s, spring::SpringKernel::avx512); }
BENCHMARK(BM_SpringPass_Block20_Scalar)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringPass_Block20_Avx2)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringPass_Block20_Avx512)->Unit(benchmark::kMicrosecond);

// The supernodal solve alone (x = A⁻¹ b: permute, both sweeps, permute back) on a fixed right-hand
// side, per case and value type, so the sweeps can be compared without the rest of the tick.
void solve_only(benchmark::State& state, const std::string& key) {
  const SpringModel& model = cached(key);
  const Eigen::Index n = static_cast<Eigen::Index>(model.network.size());
  RowMat3d b(n, 3), x(n, 3);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index c = 0; c < 3; ++c) b(i, c) = 1e-6 * std::sin(static_cast<double>(3 * i + c));
  std::vector<double> scratch(spring::supernodal_scratch(model.predictor, model.solver->supernodes));
  for (auto _ : state) {
    spring::solve_supernodal(model.predictor, model.solver->supernodes, b, x, scratch.data());
    benchmark::DoNotOptimize(x.data());
  }
  const auto& sn = model.solver->supernodes;
  state.counters["values_MiB"] =
      static_cast<double>(sn.values.size() * 8 + sn.values_single.size() * 4) / (1024.0 * 1024.0);
}
void BM_SpringSolve_Block20(benchmark::State& s) { solve_only(s, "block20"); }
void BM_SpringSolve_Block20_Single(benchmark::State& s) { solve_only(s, "block20/single"); }
void BM_SpringSolve_Organ10k(benchmark::State& s) { solve_only(s, "organ10k"); }
void BM_SpringSolve_Organ10k_Single(benchmark::State& s) { solve_only(s, "organ10k/single"); }
void BM_SpringSolve_Liver10k(benchmark::State& s) { solve_only(s, "liver10k"); }
void BM_SpringSolve_Liver10k_Single(benchmark::State& s) { solve_only(s, "liver10k/single"); }
BENCHMARK(BM_SpringSolve_Block20)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringSolve_Block20_Single)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringSolve_Organ10k)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringSolve_Organ10k_Single)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringSolve_Liver10k)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringSolve_Liver10k_Single)->Unit(benchmark::kMicrosecond);

// Baseline solve in the same process: AMD ordering and the column-by-column substitution of the
// first version (the rest of the tick is the current code).
void BM_SpringTick_Block10_Sparse_AmdColumns(benchmark::State& s) { tick(s, "block10/amd_columns"); }
void BM_SpringTick_Block20_Sparse_AmdColumns(benchmark::State& s) { tick(s, "block20/amd_columns"); }
void BM_SpringTick_Organ10k_Sparse_AmdColumns(benchmark::State& s) { tick(s, "organ10k/amd_columns"); }
BENCHMARK(BM_SpringTick_Block10_Sparse_AmdColumns)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringTick_Block20_Sparse_AmdColumns)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringTick_Organ10k_Sparse_AmdColumns)->Unit(benchmark::kMicrosecond);

// Median time of one predictor tick (as in tick(), the probe pressing in and out), in µs.
double predictor_tick_median_us(const SpringModel& model, int ticks) {
  SpringState s = make_state(model);
  const Vec3 top = probe_top(model);
  std::vector<double> us(static_cast<size_t>(ticks));
  for (int i = 0; i < ticks; ++i) {
    const ToolState tool = probe(top, i);
    const auto t0 = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(step(model, s, &tool));
    us[static_cast<size_t>(i)] = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
  }
  std::nth_element(us.begin(), us.begin() + ticks / 2, us.end());
  return us[static_cast<size_t>(ticks / 2)];
}

// Baseline: the same linear system assembled and solved with Eigen every tick
// (SimplicialLDLT factorize + solve of M + h(γI + C_L) + h²K_L), forces as in step(). Reports,
// besides its own time, the predictor's median tick on the same model measured in the same run
// right after (predictor_us) and the ratio of the two medians (baseline_over_predictor).
void baseline(benchmark::State& state, const std::string& key) {
  const SpringModel& model = cached(key);
  const SpringNetwork& net = model.network;
  const int n = static_cast<int>(net.size());
  const double h = model.options.dt, gamma = model.options.point_damping;
  SpringState s = make_state(model);
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
  std::vector<double> own_us;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    std::vector<Eigen::Triplet<double>> t;
    std::vector<double> diag(static_cast<size_t>(n));
    for (int i = 0; i < n; ++i) diag[static_cast<size_t>(i)] = net.mass[static_cast<size_t>(i)] + h * gamma;
    for (size_t e = 0; e < net.springs.size(); ++e) {
      const auto [a, b] = net.springs[e];
      const double w = h * net.damping[e] + h * h * net.stiffness[e];
      diag[static_cast<size_t>(a)] += w;
      diag[static_cast<size_t>(b)] += w;
      if (model.anchored[static_cast<size_t>(a)] || model.anchored[static_cast<size_t>(b)]) continue;
      t.emplace_back(a, b, -w);
      t.emplace_back(b, a, -w);
    }
    for (int i = 0; i < n; ++i) t.emplace_back(i, i, model.anchored[static_cast<size_t>(i)] ? 1.0 : diag[static_cast<size_t>(i)]);
    Eigen::SparseMatrix<double> A(n, n);
    A.setFromTriplets(t.begin(), t.end());
    ldlt.compute(A);
    // The right-hand side of step(): forces and the −h K_L v term.
    Eigen::MatrixXd b = Eigen::MatrixXd::Zero(n, 3);
    for (size_t e = 0; e < net.springs.size(); ++e) {
      const auto [i, j] = net.springs[e];
      const Eigen::RowVector3d d = s.x.row(j) - s.x.row(i);
      const double l = d.norm();
      const Eigen::RowVector3d f = net.stiffness[e] * (l - net.rest_length[e]) / l * d;
      b.row(i) += f;
      b.row(j) -= f;
    }
    b.col(1).array() -= 9.8 * Eigen::Map<const Eigen::ArrayXd>(net.mass.data(), n);
    b *= h;
    for (int a : net.anchors) b.row(a).setZero();
    const Eigen::MatrixXd dv = ldlt.solve(b);
    s.v += dv;
    s.x += h * s.v;
    benchmark::DoNotOptimize(s.x.data());
    own_us.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count());
  }
  if (own_us.empty()) return;
  std::nth_element(own_us.begin(), own_us.begin() + static_cast<std::ptrdiff_t>(own_us.size() / 2), own_us.end());
  const double predictor = predictor_tick_median_us(model, 500);
  state.counters["predictor_us"] = predictor;
  state.counters["baseline_over_predictor"] = own_us[own_us.size() / 2] / predictor;
}
void BM_SpringBaseline_Block10_RefactorEachTick(benchmark::State& s) { baseline(s, "block10"); }
void BM_SpringBaseline_Block20_RefactorEachTick(benchmark::State& s) { baseline(s, "block20"); }
void BM_SpringBaseline_Organ10k_RefactorEachTick(benchmark::State& s) { baseline(s, "organ10k"); }
void BM_SpringBaseline_Liver10k_RefactorEachTick(benchmark::State& s) { baseline(s, "liver10k"); }
BENCHMARK(BM_SpringBaseline_Block10_RefactorEachTick)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringBaseline_Block20_RefactorEachTick)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringBaseline_Organ10k_RefactorEachTick)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpringBaseline_Liver10k_RefactorEachTick)->Unit(benchmark::kMicrosecond);

// Pre-processing the 10,000-vertex organ, then loading its predictor file.
void BM_SpringPrecompute_Organ10k(benchmark::State& state) {
  const SpringNetwork net = organ(13.4);
  for (auto _ : state) {
    auto p = build_predictor(net, options(SpringSolver::sparse));
    benchmark::DoNotOptimize(p.ok());
  }
  state.counters["vertices"] = static_cast<double>(net.size());
}
BENCHMARK(BM_SpringPrecompute_Organ10k)->Unit(benchmark::kMillisecond)->Iterations(3);
void BM_SpringPrecompute_Liver10k(benchmark::State& state) {
  const SpringNetwork net = liver();
  for (auto _ : state) {
    auto p = build_predictor(net, options(SpringSolver::sparse));
    benchmark::DoNotOptimize(p.ok());
  }
  state.counters["vertices"] = static_cast<double>(net.size());
}
BENCHMARK(BM_SpringPrecompute_Liver10k)->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_SpringLoadPredictor_Organ10k(benchmark::State& state) {
  const SpringModel& model = cached("organ10k");
  const auto file = std::filesystem::temp_directory_path() / "palpate_bench_organ10k.predictor";
  if (!save_predictor(file, model).ok()) state.SkipWithError("cannot write the predictor");
  for (auto _ : state) {
    auto p = load_predictor(file, model.network, model.options);
    benchmark::DoNotOptimize(p.ok());
  }
  state.counters["file_MiB"] = static_cast<double>(std::filesystem::file_size(file)) / (1024.0 * 1024.0);
  std::filesystem::remove(file);
}
BENCHMARK(BM_SpringLoadPredictor_Organ10k)->Unit(benchmark::kMillisecond);

}  // namespace
