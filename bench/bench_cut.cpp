// bench_cut.cpp — cutting a mass-spring organ (issue 37, "Speed"): the tick with a cut's Woodbury
// correction installed ÷ the uncut tick, the worker's time to build a correction and a new factor,
// and the peer a user would pick instead, SuiteSparse CHOLMOD (its supernodal prefactored solve and
// its rank-k downdate of a simplicial factor), side by side with palpate's in the same run.
// CHOLMOD is linked into the benchmark program only, and only this file includes it
// (PALPATE_BENCH_CHOLMOD, bench/CMakeLists.txt); the library never depends on it.
#include <palpate/spring.h>

#include "tissue/spring/cut.h"
#include "tissue/spring/forces.h"
#include "tissue/spring/layouts.h"
#include "tissue/spring/shapes.h"
#include "tissue/spring/solve.h"

#include <benchmark/benchmark.h>

#if PALPATE_BENCH_CHOLMOD
#include <cholmod.h>
#endif

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace {

using namespace palpate;
using Clock = std::chrono::steady_clock;

// The models of bench_spring.cpp: the tet block n³ (5 mm spacing, its y = 0 layer anchored) and the
// 11,488-vertex tet ball (2 mm spacing, the lowest 5% of its height anchored); springs on the tet
// edges, 100 N/m, no volume term; the sparse predictor in double, h = 1 ms.
SpringNetwork block(int n) {
  SpringNetworkOptions o;
  o.topology = SpringTopology::tet_edges;
  o.stiffness = 100.0;
  o.mass = 0.1;
  for (int k = 0; k < n; ++k)
    for (int i = 0; i < n; ++i) o.anchors.push_back(i + n * n * k);
  return *make_spring_network(spring::make_block(n, n, n, 0.005), o, "block");
}

SpringNetwork organ() {
  SpringNetworkOptions o;
  o.topology = SpringTopology::tet_edges;
  o.stiffness = 100.0;
  o.mass = 0.5;
  SpringNetwork net = *make_spring_network(spring::make_tet_ball(13.4 * 0.002, 0.002), o, "organ");
  const double lo = net.rest.col(1).minCoeff(), hi = net.rest.col(1).maxCoeff();
  for (Eigen::Index i = 0; i < net.rest.rows(); ++i)
    if (net.rest(i, 1) < lo + 0.05 * (hi - lo)) net.anchors.push_back(static_cast<int>(i));
  return net;
}

// The uncut models, built once per process ("block10", "block20", "organ11k"); each benchmark that
// cuts works on its own copy.
const SpringModel& uncut(const std::string& name) {
  static std::map<std::string, std::unique_ptr<SpringModel>> models;
  auto& m = models[name];
  if (!m) {
    SpringNetwork net = name == "block10" ? block(10) : name == "block20" ? block(20) : organ();
    SpringModelOptions o;
    o.dt = 0.001;
    o.solver = SpringSolver::sparse;
    m = std::make_unique<SpringModel>(build_spring_model(std::move(net), o).value());
  }
  return *m;
}

// The cut: springs whose rest segment crosses the plane x = (the model's mean x) with both ends free
// (an edge with an anchored end corrects fewer entries), the highest first, as a blade entering
// from the top would meet them; the first k.
std::vector<int> cut_springs(const SpringModel& model, int k) {
  const SpringNetwork& net = model.network;
  const double at = net.rest.col(0).mean();
  std::vector<std::pair<double, int>> crossing;
  for (size_t e = 0; e < net.springs.size(); ++e) {
    const auto [a, b] = net.springs[e];
    if (model.anchored[static_cast<size_t>(a)] || model.anchored[static_cast<size_t>(b)]) continue;
    if ((net.rest(a, 0) - at) * (net.rest(b, 0) - at) < 0)
      crossing.push_back({-(net.rest(a, 1) + net.rest(b, 1)), static_cast<int>(e)});
  }
  std::sort(crossing.begin(), crossing.end());
  std::vector<int> out;
  for (int i = 0; i < k && i < static_cast<int>(crossing.size()); ++i) out.push_back(crossing[static_cast<size_t>(i)].second);
  return out;
}

// The weight each removed spring takes out of the predictor's matrix A (cut.h): w = h c + h² k_p.
std::vector<spring::EdgeWeight> removed_weights(const SpringModel& model, const std::vector<int>& springs) {
  const double h = model.options.dt;
  std::vector<spring::EdgeWeight> out;
  for (int e : springs) {
    const size_t u = static_cast<size_t>(e);
    out.push_back({model.network.springs[u][0], model.network.springs[u][1],
                   h * model.network.damping[u] + h * h * model.predictor_stiffness[u]});
  }
  return out;
}

Vec3 probe_top(const SpringModel& model) {
  return {model.network.rest.col(0).mean(), model.network.rest.col(1).maxCoeff(), model.network.rest.col(2).mean()};
}
// The probe of bench_spring.cpp: a 4 mm sphere pressing in and out from the top every 2 s.
ToolState probe(const Vec3& top, int i) {
  ToolState tool;
  tool.radius = 0.004;
  tool.tip = top + Vec3(0, 0.004 - 0.002 * ((i % 2000) / 2000.0), 0);
  return tool;
}

SpringCutOptions correction_only() {
  SpringCutOptions o;
  o.refactor_rank = 1000;  // above 50: every cut here stays a correction
  o.max_rank = 1000;
  return o;
}

// 1. The tick (one step, the probe pressing) with a correction of `k` removed springs installed;
// k = 0: the uncut model, no cutter; k = −1: uncut, but the spring pass reading each spring's
// stiffness and damping as it does once anything is cut; k = −2: uncut, with an idle cutter (its
// worker thread polling every 200 µs beside the tick). The cut's cost apart from the correction.
void tick(benchmark::State& state, const std::string& name) {
  const int k = static_cast<int>(state.range(0));
  SpringModel model = uncut(name);
  std::unique_ptr<SpringCutter> cutter;
  if (k > 0 || k == -2) {
    cutter = SpringCutter::create(model, correction_only()).value();
    const std::vector<int> springs = cut_springs(model, k);
    cutter->remove_springs(springs);
    cutter->settle();
  } else if (k == -1) {
    model.uniform_stiffness = 0;
    model.uniform_damping = false;
  }
  SpringState s = make_state(model);
  const Vec3 top = probe_top(model);
  int i = 0;
  for (auto _ : state) {
    if (cutter) cutter->install();
    const ToolState tool = probe(top, i++);
    benchmark::DoNotOptimize(step(model, s, &tool));
  }
  state.counters["vertices"] = static_cast<double>(model.network.size());
  const spring::PredictorCorrection* c = model.solver->correction;
  state.counters["rank"] = c ? c->rank : 0;
  state.counters["nnz_V"] = c ? static_cast<double>(c->row.size()) : 0.0;
  state.counters["contacts"] = static_cast<double>(s.contacts);
}
void BM_CutTick_Block20(benchmark::State& s) { tick(s, "block20"); }
void BM_CutTick_Organ11k(benchmark::State& s) { tick(s, "organ11k"); }
BENCHMARK(BM_CutTick_Block20)->Arg(0)->Arg(-1)->Arg(-2)->Arg(10)->Arg(25)->Arg(50)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CutTick_Organ11k)->Arg(0)->Arg(-1)->Arg(-2)->Arg(10)->Arg(25)->Arg(50)->Unit(benchmark::kMicrosecond);

// 2. and 3. The worker: wall time from remove_springs to the moment settle() has installed what it
// built (manual time), and the worker's own time for it (worker_ms: status().last_correction_ms,
// or last_factor_ms when refactor_rank < k makes it a new factor). Each iteration cuts a fresh copy
// of the uncut model (the copy and the cutter's set-up are not timed).
void worker(benchmark::State& state, const std::string& name, bool refactor) {
  const int k = static_cast<int>(state.range(0));
  const SpringModel& base = uncut(name);
  const std::vector<int> springs = cut_springs(base, k);
  double worker_ms = 0, installs = 0;
  int rank = 0, factors = 0;
  for (auto _ : state) {
    SpringModel model = base;
    SpringCutOptions o = correction_only();
    if (refactor) o.refactor_rank = 4;  // a cut of more than 4 edges makes a new factor
    auto cutter = SpringCutter::create(model, o).value();
    const auto t0 = Clock::now();
    cutter->remove_springs(springs);
    cutter->settle();
    state.SetIterationTime(std::chrono::duration<double>(Clock::now() - t0).count());
    const SpringCutStatus st = cutter->status();
    worker_ms += refactor ? st.last_factor_ms : st.last_correction_ms;
    rank = st.correction_rank;
    factors = st.factors;
    ++installs;
  }
  state.counters["worker_ms"] = worker_ms / std::max(installs, 1.0);
  state.counters["rank"] = rank;
  state.counters["factors"] = factors;
}
void BM_CutCorrection_Block20(benchmark::State& s) { worker(s, "block20", false); }
void BM_CutCorrection_Organ11k(benchmark::State& s) { worker(s, "organ11k", false); }
void BM_CutRefactor_Block20(benchmark::State& s) { worker(s, "block20", true); }
void BM_CutRefactor_Organ11k(benchmark::State& s) { worker(s, "organ11k", true); }
BENCHMARK(BM_CutCorrection_Block20)->Arg(10)->Arg(25)->Arg(50)->Iterations(10)->UseManualTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_CutCorrection_Organ11k)->Arg(10)->Arg(25)->Arg(50)->Iterations(10)->UseManualTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_CutRefactor_Block20)->Arg(25)->Iterations(3)->UseManualTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_CutRefactor_Organ11k)->Arg(25)->Iterations(3)->UseManualTime()->Unit(benchmark::kMillisecond);

// The correction's share of a tick alone: apply_middle (cut.h) on the solve's middle vector, for a
// correction of k removed springs (what the step adds between its sweeps once a cut is installed).
void apply_middle(benchmark::State& state, const std::string& name) {
  const int k = static_cast<int>(state.range(0));
  const SpringModel& model = uncut(name);
  const spring::PredictorCorrection c =
      spring::build_correction(model.predictor, model.anchored, removed_weights(model, cut_springs(model, k)));
  std::vector<double> z4(4 * model.network.size());
  for (size_t i = 0; i < z4.size(); ++i) z4[i] = i % 4 == 3 ? 0.0 : 1e-3 * std::sin(static_cast<double>(i));
  for (auto _ : state) {
    spring::apply_middle(c, z4.data());
    benchmark::DoNotOptimize(z4.data());
  }
  state.counters["nnz_V"] = static_cast<double>(c.row.size());
  std::vector<int> rows = c.row;  // the rows V touches at all
  std::sort(rows.begin(), rows.end());
  state.counters["rows_V"] = static_cast<double>(std::unique(rows.begin(), rows.end()) - rows.begin());
}
void BM_CutApplyMiddle_Block20(benchmark::State& s) { apply_middle(s, "block20"); }
void BM_CutApplyMiddle_Organ11k(benchmark::State& s) { apply_middle(s, "organ11k"); }
BENCHMARK(BM_CutApplyMiddle_Block20)->Arg(10)->Arg(25)->Arg(50)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CutApplyMiddle_Organ11k)->Arg(10)->Arg(25)->Arg(50)->Unit(benchmark::kMicrosecond);

// The right-hand sides of the solves below: three columns of values in [-1, 1] (free rows only;
// an anchored row's right-hand side is zero in the step).
RowMat3d rhs(const SpringModel& model) {
  const Eigen::Index n = static_cast<Eigen::Index>(model.network.size());
  RowMat3d b(n, 3);
  for (Eigen::Index i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c)
      b(i, c) = model.anchored[static_cast<size_t>(i)] ? 0.0 : std::sin(0.7 * static_cast<double>(3 * i + c) + 0.3);
  return b;
}

// palpate's prefactored solve, the step's own (spring::solve_supernodal, the best instruction set).
void palpate_solve(benchmark::State& state, const std::string& name) {
  const SpringModel& model = uncut(name);
  const RowMat3d b = rhs(model);
  RowMat3d x(b.rows(), 3);
  std::vector<double> scratch(spring::supernodal_scratch(model.predictor, model.solver->supernodes) + 8);
  double* aligned = spring::align64(scratch.data());
  for (auto _ : state) {
    spring::solve_supernodal(model.predictor, model.solver->supernodes, b, x, aligned);
    benchmark::DoNotOptimize(x.data());
  }
  state.counters["vertices"] = static_cast<double>(model.network.size());
  state.counters["nnz_L"] = static_cast<double>(model.predictor.value.size() + model.network.size());
}
void BM_CutPeerSolve_Palpate_Block10(benchmark::State& s) { palpate_solve(s, "block10"); }
void BM_CutPeerSolve_Palpate_Block20(benchmark::State& s) { palpate_solve(s, "block20"); }
void BM_CutPeerSolve_Palpate_Organ11k(benchmark::State& s) { palpate_solve(s, "organ11k"); }
BENCHMARK(BM_CutPeerSolve_Palpate_Block10)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CutPeerSolve_Palpate_Block20)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CutPeerSolve_Palpate_Organ11k)->Unit(benchmark::kMicrosecond);

// palpate's correction for the same cut as CHOLMOD's downdate below: build_correction alone (what
// the worker times as last_correction_ms), on the uncut factor.
void palpate_update(benchmark::State& state, const std::string& name) {
  const int k = static_cast<int>(state.range(0));
  const SpringModel& model = uncut(name);
  const std::vector<spring::EdgeWeight> removed = removed_weights(model, cut_springs(model, k));
  size_t nnz_v = 0;
  for (auto _ : state) {
    const auto t0 = Clock::now();
    spring::PredictorCorrection c = spring::build_correction(model.predictor, model.anchored, removed);
    state.SetIterationTime(std::chrono::duration<double>(Clock::now() - t0).count());
    nnz_v = c.row.size();
    benchmark::DoNotOptimize(c.m.data());
  }
  state.counters["nnz_V"] = static_cast<double>(nnz_v);
}
void BM_CutPeerUpdate_Palpate_Block20(benchmark::State& s) { palpate_update(s, "block20"); }
void BM_CutPeerUpdate_Palpate_Organ11k(benchmark::State& s) { palpate_update(s, "organ11k"); }
BENCHMARK(BM_CutPeerUpdate_Palpate_Block20)->Arg(10)->Arg(25)->Arg(50)->UseManualTime()->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CutPeerUpdate_Palpate_Organ11k)->Arg(10)->Arg(25)->Arg(50)->UseManualTime()->Unit(benchmark::kMicrosecond);

#if PALPATE_BENCH_CHOLMOD

// CHOLMOD on the predictor's matrix A = M + h(γI + C_L) + h² K_L (anchored rows and columns the
// identity; model.cpp predictor_triplets), assembled from the same network: its supernodal factor
// (its default ordering: AMD, METIS where AMD fills much) and its simplicial LDLᵀ factor (the form
// cholmod_updown works on; it converts an LLᵀ one to it first).
struct Cholmod {
  cholmod_common c{};
  cholmod_sparse* A = nullptr;
  cholmod_factor* super = nullptr;
  cholmod_factor* simplicial = nullptr;
  double factor_ms = 0;
  Cholmod() { cholmod_start(&c); }
  ~Cholmod() {
    cholmod_free_factor(&super, &c);
    cholmod_free_factor(&simplicial, &c);
    cholmod_free_sparse(&A, &c);
    cholmod_finish(&c);
  }
  Cholmod(const Cholmod&) = delete;
  Cholmod& operator=(const Cholmod&) = delete;
};

Cholmod& cholmod_of(const std::string& name) {
  static std::map<std::string, std::unique_ptr<Cholmod>> cache;
  auto& ch = cache[name];
  if (ch) return *ch;
  ch = std::make_unique<Cholmod>();
  const SpringModel& model = uncut(name);
  const SpringNetwork& net = model.network;
  const size_t n = net.size();
  const double h = model.options.dt;
  std::vector<double> diag(n);
  for (size_t i = 0; i < n; ++i) diag[i] = net.mass[i] + h * model.options.point_damping;
  cholmod_triplet* T = cholmod_allocate_triplet(n, n, n + net.springs.size(), -1, CHOLMOD_REAL, &ch->c);  // lower
  auto* ti = static_cast<int*>(T->i);
  auto* tj = static_cast<int*>(T->j);
  auto* tx = static_cast<double*>(T->x);
  size_t nz = 0;
  for (size_t e = 0; e < net.springs.size(); ++e) {
    const auto [a, b] = net.springs[e];
    const double w = h * net.damping[e] + h * h * model.predictor_stiffness[e];
    diag[static_cast<size_t>(a)] += w;
    diag[static_cast<size_t>(b)] += w;
    if (model.anchored[static_cast<size_t>(a)] || model.anchored[static_cast<size_t>(b)]) continue;
    ti[nz] = std::max(a, b);
    tj[nz] = std::min(a, b);
    tx[nz++] = -w;
  }
  for (size_t i = 0; i < n; ++i) {
    ti[nz] = tj[nz] = static_cast<int>(i);
    tx[nz++] = model.anchored[i] ? 1.0 : diag[i];
  }
  T->nnz = nz;
  ch->A = cholmod_triplet_to_sparse(T, nz, &ch->c);
  cholmod_free_triplet(&T, &ch->c);
  ch->c.supernodal = CHOLMOD_SUPERNODAL;
  const auto t0 = Clock::now();
  ch->super = cholmod_analyze(ch->A, &ch->c);
  cholmod_factorize(ch->A, ch->super, &ch->c);
  ch->factor_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  ch->c.supernodal = CHOLMOD_SIMPLICIAL;
  ch->c.final_ll = false;
  ch->simplicial = cholmod_analyze(ch->A, &ch->c);
  cholmod_factorize(ch->A, ch->simplicial, &ch->c);
  if (ch->c.status != CHOLMOD_OK) std::fprintf(stderr, "bench_cut: CHOLMOD status %d\n", ch->c.status);
  return *ch;
}

cholmod_dense* to_dense(const RowMat3d& b, cholmod_common* c) {
  cholmod_dense* B = cholmod_allocate_dense(static_cast<size_t>(b.rows()), 3, static_cast<size_t>(b.rows()), CHOLMOD_REAL, c);
  auto* x = static_cast<double*>(B->x);
  for (Eigen::Index i = 0; i < b.rows(); ++i)
    for (int k = 0; k < 3; ++k) x[static_cast<size_t>(k * b.rows() + i)] = b(i, k);
  return B;
}

// max |x_cholmod − x_ref| / max |x_ref|
double difference(const cholmod_dense* X, const RowMat3d& ref) {
  const auto* x = static_cast<const double*>(X->x);
  double d = 0;
  for (Eigen::Index i = 0; i < ref.rows(); ++i)
    for (int k = 0; k < 3; ++k) d = std::max(d, std::abs(x[static_cast<size_t>(k * ref.rows() + i)] - ref(i, k)));
  return d / ref.cwiseAbs().maxCoeff();
}

// CHOLMOD's prefactored solve of the same three right-hand sides with its supernodal factor:
// cholmod_solve2 (its workspace and result kept between calls, as a loop would) and cholmod_solve
// (allocating the result each call).
void cholmod_solve_bench(benchmark::State& state, const std::string& name, bool reuse) {
  Cholmod& ch = cholmod_of(name);
  const SpringModel& model = uncut(name);
  const RowMat3d b = rhs(model);
  cholmod_dense* B = to_dense(b, &ch.c);
  cholmod_dense *X = nullptr, *Y = nullptr, *E = nullptr;
  for (auto _ : state) {
    if (reuse) {
      cholmod_solve2(CHOLMOD_A, ch.super, B, nullptr, &X, nullptr, &Y, &E, &ch.c);
    } else {
      cholmod_free_dense(&X, &ch.c);
      X = cholmod_solve(CHOLMOD_A, ch.super, B, &ch.c);
    }
    benchmark::DoNotOptimize(X->x);
  }
  RowMat3d ref(b.rows(), 3);
  std::vector<double> scratch(spring::supernodal_scratch(model.predictor, model.solver->supernodes) + 8);
  spring::solve_supernodal(model.predictor, model.solver->supernodes, b, ref, spring::align64(scratch.data()));
  state.counters["vs_palpate"] = difference(X, ref);
  state.counters["nnz_L"] = ch.c.lnz;
  state.counters["factor_ms"] = ch.factor_ms;
  state.counters["ordering"] = ch.c.method[ch.c.selected].ordering;  // CHOLMOD_AMD 2, CHOLMOD_METIS 3, ...
  cholmod_free_dense(&X, &ch.c);
  cholmod_free_dense(&Y, &ch.c);
  cholmod_free_dense(&E, &ch.c);
  cholmod_free_dense(&B, &ch.c);
}
void BM_CutPeerSolve_Cholmod_Block10(benchmark::State& s) { cholmod_solve_bench(s, "block10", true); }
void BM_CutPeerSolve_Cholmod_Block20(benchmark::State& s) { cholmod_solve_bench(s, "block20", true); }
void BM_CutPeerSolve_Cholmod_Organ11k(benchmark::State& s) { cholmod_solve_bench(s, "organ11k", true); }
void BM_CutPeerSolve_CholmodAlloc_Block10(benchmark::State& s) { cholmod_solve_bench(s, "block10", false); }
void BM_CutPeerSolve_CholmodAlloc_Block20(benchmark::State& s) { cholmod_solve_bench(s, "block20", false); }
void BM_CutPeerSolve_CholmodAlloc_Organ11k(benchmark::State& s) { cholmod_solve_bench(s, "organ11k", false); }
BENCHMARK(BM_CutPeerSolve_Cholmod_Block10)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CutPeerSolve_Cholmod_Block20)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CutPeerSolve_Cholmod_Organ11k)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CutPeerSolve_CholmodAlloc_Block10)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CutPeerSolve_CholmodAlloc_Block20)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CutPeerSolve_CholmodAlloc_Organ11k)->Unit(benchmark::kMicrosecond);

// CHOLMOD's rank-k downdate for the same cut: A' = A − C Cᵀ, C's column e = √w_e (e_i − e_j) (the
// anchored end's entry dropped), its rows permuted as the factor's (cholmod_updown modifies the
// factor of P A Pᵀ). Each iteration downdates a fresh copy of the simplicial factor (the copy not
// timed). vs_palpate: the downdated factor's solve against palpate's corrected one.
void cholmod_update(benchmark::State& state, const std::string& name) {
  const int k = static_cast<int>(state.range(0));
  Cholmod& ch = cholmod_of(name);
  const SpringModel& model = uncut(name);
  const size_t n = model.network.size();
  const std::vector<spring::EdgeWeight> removed = removed_weights(model, cut_springs(model, k));
  const auto* perm = static_cast<const int*>(ch.simplicial->Perm);
  std::vector<int> inverse(n);
  for (size_t i = 0; i < n; ++i) inverse[static_cast<size_t>(perm[i])] = static_cast<int>(i);
  cholmod_sparse* C = cholmod_allocate_sparse(n, removed.size(), 2 * removed.size(), true, true, 0, CHOLMOD_REAL, &ch.c);
  auto* cp = static_cast<int*>(C->p);
  auto* ci = static_cast<int*>(C->i);
  auto* cx = static_cast<double*>(C->x);
  int nz = 0;
  for (size_t e = 0; e < removed.size(); ++e) {
    cp[e] = nz;
    std::vector<std::pair<int, double>> entries;
    const double s = std::sqrt(removed[e].w);
    if (!model.anchored[static_cast<size_t>(removed[e].i)]) entries.push_back({inverse[static_cast<size_t>(removed[e].i)], s});
    if (!model.anchored[static_cast<size_t>(removed[e].j)]) entries.push_back({inverse[static_cast<size_t>(removed[e].j)], -s});
    std::sort(entries.begin(), entries.end());
    for (const auto& [row, value] : entries) {
      ci[nz] = row;
      cx[nz++] = value;
    }
  }
  cp[removed.size()] = nz;
  cholmod_factor* L = nullptr;
  for (auto _ : state) {
    cholmod_free_factor(&L, &ch.c);
    L = cholmod_copy_factor(ch.simplicial, &ch.c);
    const auto t0 = Clock::now();
    cholmod_updown(false, C, L, &ch.c);
    state.SetIterationTime(std::chrono::duration<double>(Clock::now() - t0).count());
  }
  // Check: the downdated factor solves the cut network's system as palpate's correction does.
  const RowMat3d b = rhs(model);
  RowMat3d ref(b.rows(), 3);
  spring::PredictorCorrection corr = spring::build_correction(model.predictor, model.anchored, removed);
  std::vector<double> scratch(spring::supernodal_scratch(model.predictor, model.solver->supernodes) + 8);
  spring::solve_supernodal(model.predictor, model.solver->supernodes, b, ref, spring::align64(scratch.data()),
                           spring::SolveIsa::best, &corr);
  cholmod_dense* B = to_dense(b, &ch.c);
  cholmod_dense* X = cholmod_solve(CHOLMOD_A, L, B, &ch.c);
  state.counters["vs_palpate"] = difference(X, ref);
  state.counters["status"] = ch.c.status;
  cholmod_free_dense(&X, &ch.c);
  cholmod_free_dense(&B, &ch.c);
  cholmod_free_factor(&L, &ch.c);
  cholmod_free_sparse(&C, &ch.c);
}
void BM_CutPeerUpdate_Cholmod_Block20(benchmark::State& s) { cholmod_update(s, "block20"); }
void BM_CutPeerUpdate_Cholmod_Organ11k(benchmark::State& s) { cholmod_update(s, "organ11k"); }
BENCHMARK(BM_CutPeerUpdate_Cholmod_Block20)->Arg(10)->Arg(25)->Arg(50)->UseManualTime()->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CutPeerUpdate_Cholmod_Organ11k)->Arg(10)->Arg(25)->Arg(50)->UseManualTime()->Unit(benchmark::kMicrosecond);

#endif  // PALPATE_BENCH_CHOLMOD

}  // namespace
