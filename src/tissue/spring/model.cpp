// model.cpp — the precompute phase of the mass-spring model: the constant implicit matrix
// A = M + h(γI + C_L) + h²K_L (Desbrun, Schröder & Barr 1999, §4), its dense inverse or sparse
// LDLᵀ factor, and the model and state built around it.
#include <palpate/spring.h>

#include "core/memory.h"

#include <Eigen/Cholesky>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>

#include "tissue/spring/cut.h"
#include "tissue/spring/forces.h"
#include "tissue/spring/ordering.h"
#include "tissue/spring/solve.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <span>
#include <string>
#include <unordered_map>

namespace palpate {

namespace {

std::vector<std::uint8_t> anchored_flags(const SpringNetwork& net) {
  std::vector<std::uint8_t> a(net.size(), 0);
  for (int i : net.anchors) a[static_cast<size_t>(i)] = 1;
  return a;
}

// The triplets of A: diagonal m_i + hγ + Σ(hc + h²k), off-diagonal −(hc + h²k) per spring;
// anchored rows and columns are the identity (their velocity change is zero).
std::vector<Eigen::Triplet<double>> predictor_triplets(const SpringNetwork& net, const SpringModelOptions& o) {
  const double h = o.dt;
  const auto anchored = anchored_flags(net);
  const std::vector<double> k = predictor_stiffness(net);
  std::vector<double> diag(net.size());
  for (size_t i = 0; i < net.size(); ++i) diag[i] = net.mass[i] + h * o.point_damping;
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(net.size() + 2 * net.springs.size());
  for (size_t e = 0; e < net.springs.size(); ++e) {
    const auto [a, b] = net.springs[e];
    const double w = h * net.damping[e] + h * h * k[e];
    diag[static_cast<size_t>(a)] += w;
    diag[static_cast<size_t>(b)] += w;
    if (anchored[static_cast<size_t>(a)] || anchored[static_cast<size_t>(b)]) continue;
    t.emplace_back(a, b, -w);
    t.emplace_back(b, a, -w);
  }
  for (size_t i = 0; i < net.size(); ++i) {
    const int ii = static_cast<int>(i);
    t.emplace_back(ii, ii, anchored[i] ? 1.0 : diag[i]);
  }
  return t;
}

// The predictor's fields from an Eigen factor of P A Pᵀ: L's strictly-lower entries by column,
// 1/D, and perm (the new index of each vertex).
Status take_factor(const Eigen::SparseMatrix<double>& L, const Eigen::VectorXd& D, std::vector<int> perm,
                   SpringPredictor& p) {
  const int n = static_cast<int>(D.size());
  p.perm = std::move(perm);
  p.col_start.assign(static_cast<size_t>(n) + 1, 0);
  p.row.clear();
  p.value.clear();
  p.row.reserve(static_cast<size_t>(L.nonZeros()));
  p.value.reserve(static_cast<size_t>(L.nonZeros()));
  for (int c = 0; c < n; ++c) {
    for (Eigen::SparseMatrix<double>::InnerIterator it(L, c); it; ++it)
      if (it.row() > c) {
        p.row.push_back(static_cast<int>(it.row()));
        p.value.push_back(it.value());
      }
    p.col_start[static_cast<size_t>(c) + 1] = static_cast<int>(p.row.size());
  }
  p.inv_diag.resize(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    const double d = D[i];
    if (!(d > 0)) return Error{"the predictor matrix is not positive definite (pivot " + std::to_string(i) + ")"};
    p.inv_diag[static_cast<size_t>(i)] = 1.0 / d;
  }
  return {};
}

bool is_all_pairs(const SpringNetwork& net) {
  const size_t n = net.size();
  if (net.springs.size() != n * (n - 1) / 2) return false;
  size_t e = 0;
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j, ++e)
      if (net.springs[e][0] != static_cast<int>(i) || net.springs[e][1] != static_cast<int>(j)) return false;
  return true;
}

Status check_options(const SpringModelOptions& o) {
  if (!(o.dt > 0) || !(o.dt < 1)) return Error{"dt must be in (0, 1) s, got " + std::to_string(o.dt)};
  if (!(o.point_damping >= 0)) return Error{"point_damping must be >= 0"};
  if (!(o.contact_stiffness >= 0) || !(o.grasp_stiffness >= 0)) return Error{"contact and grasp stiffness must be >= 0"};
  return {};
}

}  // namespace

double spring::predictor_residual(const SpringNetwork& net, const SpringModelOptions& o, const SpringPredictor& p) {
  const int n = static_cast<int>(net.size());
  if (p.kind == SpringSolver::exact || p.n != n || n == 0) return std::numeric_limits<double>::quiet_NaN();
  Eigen::SparseMatrix<double> A(n, n);
  const auto triplets = predictor_triplets(net, o);
  A.setFromTriplets(triplets.begin(), triplets.end());
  // x: values in [-1, 1] from a fixed integer hash, different in each column, no structure a
  // factor of another matrix could share.
  RowMat3d x(n, 3), b(n, 3), solved(n, 3);
  std::uint64_t h = 0x9e3779b97f4a7c15ULL;
  for (int i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) {
      h ^= h >> 33;
      h *= 0xff51afd7ed558ccdULL;
      h ^= h >> 29;
      h += 0x632be59bd9b4e5bULL;
      x(i, c) = static_cast<double>(h >> 11) * 0x1.0p-52 - 1.0;
    }
  b = A * x;
  if (p.kind == SpringSolver::desbrun) {
    if (p.inverse.size() != static_cast<size_t>(n) * static_cast<size_t>(n)) return std::numeric_limits<double>::quiet_NaN();
    const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> W(p.inverse.data(), n, n);
    solved = W * b;
  } else {
    RowMat3d scratch(n, 3);
    solve_columns(p, b, solved, scratch);
  }
  if (!solved.allFinite()) return std::numeric_limits<double>::quiet_NaN();
  double norm_a = 0;  // ‖A‖∞: the largest absolute row sum (A is symmetric: column sums)
  for (int k = 0; k < A.outerSize(); ++k) {
    double sum = 0;
    for (Eigen::SparseMatrix<double>::InnerIterator it(A, k); it; ++it) sum += std::abs(it.value());
    norm_a = std::max(norm_a, sum);
  }
  const RowMat3d r = A * solved - b;
  const double denom = norm_a * solved.cwiseAbs().maxCoeff() + b.cwiseAbs().maxCoeff();
  return denom > 0 ? r.cwiseAbs().maxCoeff() / denom : std::numeric_limits<double>::quiet_NaN();
}

Result<SpringPredictor> build_predictor(const SpringNetwork& net, const SpringModelOptions& o,
                                        const Progress& progress) {
  return spring::build_predictor(net, o, spring::SparseOrdering::fewest_nonzeros, progress);
}

Result<SpringPredictor> spring::build_predictor(const SpringNetwork& net, const SpringModelOptions& o,
                                                SparseOrdering sparse_ordering, const Progress& progress) {
  if (Status st = validate(net, "spring network"); !st) return st.error();
  if (Status st = check_options(o); !st) return st.error();
  SpringPredictor p;
  p.kind = o.solver;
  p.n = static_cast<int>(net.size());
  if (o.solver == SpringSolver::exact) return p;
  const int n = p.n;
  Eigen::SparseMatrix<double> A(n, n);
  const auto triplets = predictor_triplets(net, o);
  A.setFromTriplets(triplets.begin(), triplets.end());
  if (o.solver == SpringSolver::desbrun) {
    // n² doubles kept (the inverse), and about four times that at the peak of building it (the
    // dense matrix, its Cholesky factor, the inverse, a column block): refused when that cannot fit.
    const double kept = 8.0 * double(n) * double(n), need = 4.0 * kept, memory = usable_memory_bytes();
    if (net.size() > o.dense_limit || (memory > 0 && need > memory))
      return Error{"material.solver 'desbrun' keeps a dense n x n inverse: " + std::to_string(n) + " vertices, " +
                   memory_text(kept) + " kept and about " + memory_text(need) + " to build" +
                   (net.size() > o.dense_limit ? ", past its limit of " + std::to_string(o.dense_limit) + " vertices"
                                               : ", more than this machine's " + memory_text(memory) + " of memory") +
                   " (use solver: sparse)"};
    const Eigen::MatrixXd dense = Eigen::MatrixXd(A);
    Eigen::LLT<Eigen::MatrixXd> llt(dense);
    if (llt.info() != Eigen::Success) return Error{"the predictor matrix is not positive definite"};
    // A⁻¹ column block by column block, so progress can be reported.
    p.inverse.assign(static_cast<size_t>(n) * static_cast<size_t>(n), 0.0);
    Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> W(p.inverse.data(), n, n);
    const int block = 64;
    for (int c0 = 0; c0 < n; c0 += block) {
      const int w = std::min(block, n - c0);
      // A is symmetric, so rows of A⁻¹ are its columns.
      W.middleRows(c0, w) = llt.solve(Eigen::MatrixXd::Identity(n, n).middleCols(c0, w)).transpose();
      if (progress) progress(static_cast<double>(c0 + w) / n);
    }
    return p;
  }
  // Sparse: LDLᵀ of P A Pᵀ, factorised once, with the ordering that fills least: METIS nested
  // dissection (what 3-D meshes want; twice, with METIS's defaults and with ten separators per
  // level and a looser balance, which often fills less) or Eigen's approximate minimum degree
  // (better on small or thin graphs, and the fallback if METIS fails). docs/benchmarks/spring.md
  // compares nnz(L).
  if (progress) progress(0.05);
  const SparseOrdering ordering = sparse_ordering;
  SpringPredictor best;
  if (ordering != SparseOrdering::nested_dissection) {
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::AMDOrdering<int>> ldlt;
    ldlt.compute(A);
    if (ldlt.info() != Eigen::Success) return Error{"the predictor matrix could not be factorised"};
    std::vector<int> perm(static_cast<size_t>(n));
    for (int i = 0; i < n; ++i) perm[static_cast<size_t>(i)] = ldlt.permutationP().indices()[i];
    if (Status st = take_factor(ldlt.matrixL().nestedExpression(), ldlt.vectorD(), std::move(perm), best); !st)
      return st.error();
  }
  if (progress) progress(0.35);
  bool ordered = false;
  constexpr std::array<std::array<int, 2>, 2> kMetisSettings{{{1, 0}, {10, 300}}};  // separators, imbalance
  for (const auto [separators, imbalance] : ordering == SparseOrdering::amd ? std::span<const std::array<int, 2>>{}
                                                                             : std::span(kMetisSettings)) {
    std::vector<int> nd = spring::nested_dissection(n, net.springs, separators, imbalance);
    if (!nd.empty()) {
      ordered = true;
      std::vector<Eigen::Triplet<double>> pt;
      pt.reserve(triplets.size());
      for (const auto& t : triplets)
        pt.emplace_back(nd[static_cast<size_t>(t.row())], nd[static_cast<size_t>(t.col())], t.value());
      Eigen::SparseMatrix<double> PA(n, n);
      PA.setFromTriplets(pt.begin(), pt.end());
      Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::NaturalOrdering<int>> ldlt;
      ldlt.compute(PA);
      if (ldlt.info() != Eigen::Success) return Error{"the predictor matrix could not be factorised"};
      SpringPredictor q;
      if (Status st = take_factor(ldlt.matrixL().nestedExpression(), ldlt.vectorD(), std::move(nd), q); !st)
        return st.error();
      if (best.value.empty() && best.inv_diag.empty()) best = std::move(q);
      else if (q.value.size() < best.value.size()) best = std::move(q);
    }
    if (progress) progress(separators == 1 ? 0.65 : 0.95);
  }
  if (ordering == SparseOrdering::nested_dissection && !ordered)
    return Error{"METIS could not order the predictor matrix"};
  best.kind = p.kind;
  best.n = p.n;
  p = std::move(best);
  if (progress) progress(1.0);
  return p;
}

Result<SpringPredictor> spring::refactor_predictor(const SpringNetwork& net, const SpringModelOptions& o,
                                                   const SpringPredictor& pattern) {
  if (pattern.kind == SpringSolver::desbrun) {
    SpringModelOptions dense = o;
    dense.solver = SpringSolver::desbrun;
    auto p = build_predictor(net, dense);
    if (!p) return p.error();
    const size_t n = static_cast<size_t>(p->n);
    double* W = p->inverse.data();  // exactly symmetric, as build_spring_model makes it
    for (size_t i = 0; i < n; ++i)
      for (size_t j = i + 1; j < n; ++j) W[i * n + j] = W[j * n + i] = 0.5 * (W[i * n + j] + W[j * n + i]);
    return p;
  }
  if (pattern.kind != SpringSolver::sparse || pattern.n != static_cast<int>(net.size()))
    return Error{"refactor: the pattern is not a sparse factor of this network"};
  const int n = pattern.n;
  const auto triplets = predictor_triplets(net, o);
  std::vector<Eigen::Triplet<double>> pt;
  pt.reserve(triplets.size());
  for (const auto& t : triplets)
    pt.emplace_back(pattern.perm[static_cast<size_t>(t.row())], pattern.perm[static_cast<size_t>(t.col())], t.value());
  Eigen::SparseMatrix<double> PA(n, n);
  PA.setFromTriplets(pt.begin(), pt.end());
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::NaturalOrdering<int>> ldlt;
  ldlt.compute(PA);
  if (ldlt.info() != Eigen::Success) return Error{"refactor: the predictor matrix could not be factorised"};
  // The new L onto the old pattern: a network with fewer springs, in the same order, fills a subset
  // of the old factor's entries; the others are stored as zeros, so the supernodes stay as they are.
  SpringPredictor p;
  p.kind = pattern.kind;
  p.n = n;
  p.perm = pattern.perm;
  p.col_start = pattern.col_start;
  p.row = pattern.row;
  p.value.assign(pattern.value.size(), 0.0);
  const Eigen::SparseMatrix<double>& L = ldlt.matrixL().nestedExpression();
  for (int c = 0; c < n; ++c) {
    int q = pattern.col_start[static_cast<size_t>(c)];
    const int end = pattern.col_start[static_cast<size_t>(c) + 1];
    for (Eigen::SparseMatrix<double>::InnerIterator it(L, c); it; ++it) {
      if (it.row() <= c) continue;
      while (q < end && pattern.row[static_cast<size_t>(q)] < it.row()) ++q;
      if (q == end || pattern.row[static_cast<size_t>(q)] != it.row()) {
        if (it.value() != 0) return Error{"refactor: the new factor fills outside the old pattern"};
        continue;
      }
      p.value[static_cast<size_t>(q)] = it.value();
    }
  }
  p.inv_diag.resize(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    const double d = ldlt.vectorD()[i];
    if (!(d > 0)) return Error{"refactor: the predictor matrix is not positive definite"};
    p.inv_diag[static_cast<size_t>(i)] = 1.0 / d;
  }
  return p;
}

void spring::layout_volume_pass(SpringModel& m, const std::vector<int>& order) {
  m.solver->volume_scale.clear();
  m.solver->volume_corners.clear();
  m.solver->volume_lane.clear();
  if (!m.volume_term) return;
  const auto& tets = m.network.tets;
  const size_t T = tets.size();
  std::vector<int> seq;
  seq.reserve(T);
  if (order.size() == T) {
    seq = order;
  } else {
    // Open groups, oldest first. The generated blocks and balls need 9–17 open at a time (a
    // tetrahedron shares a corner with a few dozen others, and the mesh's order keeps them close;
    // with at most 8, 3–60 % of the groups shared a corner); where none fits and 32 are open, the
    // oldest takes the tetrahedron anyway: the pass stays exact (its corners are summed one
    // tetrahedron at a time), that group's sums only wait on each other.
    constexpr size_t kOpen = 32;
    std::vector<std::vector<int>> open;
    const auto shares = [&](const std::vector<int>& group, int t) {
      for (int u : group)
        for (int a : tets[static_cast<size_t>(u)])
          for (int b : tets[static_cast<size_t>(t)])
            if (a == b) return true;
      return false;
    };
    for (size_t t = 0; t < T; ++t) {
      const int ti = static_cast<int>(t);
      size_t k = 0;
      while (k < open.size() && shares(open[k], ti)) ++k;
      if (k == open.size()) {
        if (open.size() < kOpen) open.emplace_back();
        else k = 0;
      }
      open[k].push_back(ti);
      if (open[k].size() == 4) {
        seq.insert(seq.end(), open[k].begin(), open[k].end());
        open.erase(open.begin() + static_cast<std::ptrdiff_t>(k));
      }
    }
    for (const auto& group : open) seq.insert(seq.end(), group.begin(), group.end());
  }
  const size_t G = T / 4;
  m.solver->volume_corners.resize(4 * T);
  m.solver->volume_scale.resize(T);
  m.solver->volume_lane.assign(T, -1);
  for (size_t j = 0; j < T; ++j) {
    const size_t t = static_cast<size_t>(seq[j]);
    m.solver->volume_lane[t] = static_cast<int>(j);
    m.solver->volume_scale[j] = m.network.volume_modulus / (36 * m.network.rest_volume[t]);
    for (size_t c = 0; c < 4; ++c) {
      const size_t at = j < 4 * G ? 16 * (j / 4) + 4 * c + j % 4 : 4 * j + c;
      m.solver->volume_corners[at] = 8 * tets[t][c];
    }
  }
}

Result<SpringModel> build_spring_model(SpringNetwork network, const SpringModelOptions& options,
                                       SpringPredictor predictor) {
  if (Status st = validate(network, "spring network"); !st) return st.error();
  if (Status st = check_options(options); !st) return st.error();
  if (predictor.kind != options.solver || predictor.n != static_cast<int>(network.size()) ||
      (options.solver != SpringSolver::exact && predictor.empty()))
    return Error{"the predictor does not match the model (solver or vertex count)"};
  SpringModel m;
  m.network = std::move(network);
  m.options = options;
  m.predictor = std::move(predictor);
  m.solver->supernodes = spring::make_supernodes(m.predictor, options.single_precision);
  if (m.predictor.kind == SpringSolver::desbrun && m.predictor.inverse.size() == static_cast<size_t>(m.predictor.n) * static_cast<size_t>(m.predictor.n)) {
    // A⁻¹ is symmetric; the one computed column by column (or read from a file) is so only to
    // round-off. Make it exactly symmetric, so the product from its upper triangle (solve_dense)
    // is the full product.
    const size_t n = static_cast<size_t>(m.predictor.n);
    double* W = m.predictor.inverse.data();
    for (size_t i = 0; i < n; ++i)
      for (size_t j = i + 1; j < n; ++j) W[i * n + j] = W[j * n + i] = 0.5 * (W[i * n + j] + W[j * n + i]);
  }
  if (options.single_precision && m.predictor.kind == SpringSolver::desbrun)
    m.solver->inverse_single.assign(m.predictor.inverse.begin(), m.predictor.inverse.end());
  if (!m.network.stiffness.empty() &&
      std::all_of(m.network.stiffness.begin(), m.network.stiffness.end(),
                  [&](double k) { return k == m.network.stiffness.front(); }))
    m.uniform_stiffness = m.network.stiffness.front();
  m.uniform_damping = !m.network.damping.empty() &&
                      std::all_of(m.network.damping.begin(), m.network.damping.end(),
                                  [&](double c) { return c == m.network.damping.front(); });
  m.anchored = anchored_flags(m.network);
  m.predictor_stiffness = predictor_stiffness(m.network);
  m.volume_term = !m.network.tets.empty() && m.network.volume_modulus > 0;
  spring::layout_volume_pass(m);
  {
    std::vector<std::uint8_t> on_surface(m.network.size(), 0);
    for (const auto& t : m.network.triangles)
      for (int v : t) on_surface[static_cast<size_t>(v)] = 1;
    m.surface_vertices.clear();
    for (size_t i = 0; i < on_surface.size(); ++i)
      if (on_surface[i]) m.surface_vertices.push_back(static_cast<int>(i));
  }
  const size_t n = m.network.size();
  const double h = options.dt;
  m.max_contact_stiffness.resize(n);
  for (size_t i = 0; i < n; ++i) m.max_contact_stiffness[i] = (m.network.mass[i] + h * options.point_damping) / (h * h);
  m.adjacency_start.assign(n + 1, 0);
  for (const auto& s : m.network.springs) {
    ++m.adjacency_start[static_cast<size_t>(s[0]) + 1];
    ++m.adjacency_start[static_cast<size_t>(s[1]) + 1];
  }
  for (size_t i = 0; i < n; ++i) m.adjacency_start[i + 1] += m.adjacency_start[i];
  m.adjacency.resize(2 * m.network.springs.size());
  std::vector<int> fill(m.adjacency_start.begin(), m.adjacency_start.end() - 1);
  for (size_t e = 0; e < m.network.springs.size(); ++e)
    for (int v : m.network.springs[e]) m.adjacency[static_cast<size_t>(fill[static_cast<size_t>(v)]++)] = static_cast<int>(e);
  m.total_mass = 0;
  for (double mi : m.network.mass) m.total_mass += mi;
  m.contact_compliance.resize(n);
  for (size_t i = 0; i < n; ++i)
    m.contact_compliance[i] = m.anchored[i] ? 0.0 : 1.0 / (m.network.mass[i] + h * options.point_damping);
  {
    // Closed: every undirected edge of the drawn triangles is used exactly twice.
    std::unordered_map<std::uint64_t, int> uses;
    for (const auto& t : m.network.triangles)
      for (int k = 0; k < 3; ++k) {
        const int a = std::min(t[static_cast<size_t>(k)], t[static_cast<size_t>((k + 1) % 3)]);
        const int b = std::max(t[static_cast<size_t>(k)], t[static_cast<size_t>((k + 1) % 3)]);
        ++uses[(static_cast<std::uint64_t>(static_cast<std::uint32_t>(a)) << 32) | static_cast<std::uint32_t>(b)];
      }
    m.closed_surface = !m.network.triangles.empty() &&
                       std::all_of(uses.begin(), uses.end(), [](const auto& u) { return u.second == 2; });
  }
  m.all_pairs = n > 2 && is_all_pairs(m.network);
  if (m.all_pairs && options.single_precision && m.uniform_stiffness > 0 && m.uniform_damping)
    m.solver->rest_length_single.assign(m.network.rest_length.begin(), m.network.rest_length.end());
  return m;
}

Result<SpringModel> build_spring_model(SpringNetwork network, const SpringModelOptions& options,
                                       const Progress& progress) {
  auto p = build_predictor(network, options, progress);
  if (!p) return p.error();
  return build_spring_model(std::move(network), options, std::move(*p));
}

SpringState make_state(const SpringModel& model) {
  SpringState s;
  const Eigen::Index n = static_cast<Eigen::Index>(model.network.size());
  s.x = model.network.rest;
  s.v = RowMat3d::Zero(n, 3);
  s.force = RowMat3d::Zero(n, 3);
  s.rhs = RowMat3d::Zero(n, 3);
  s.dv = RowMat3d::Zero(n, 3);
  s.work = RowMat3d::Zero(n, 3);
  if (model.options.integrator == SpringIntegrator::bdf2) {
    s.x_prev = s.x;
    s.v_prev = s.v;
  }
  if (model.options.exact_iterations > 0 && model.predictor.kind != SpringSolver::exact) {
    s.cg_r = RowMat3d::Zero(n, 3);
    s.cg_z = RowMat3d::Zero(n, 3);
    s.cg_p = RowMat3d::Zero(n, 3);
    s.cg_q = RowMat3d::Zero(n, 3);
    s.cg_d = RowMat3d::Zero(n, 3);
  }
  size_t soa = model.all_pairs ? spring::all_pairs_scratch(static_cast<size_t>(n)) : 0;
  if (model.predictor.kind == SpringSolver::desbrun) soa = std::max(soa, spring::dense_scratch(static_cast<int>(n)));
  if (!model.solver->supernodes.empty()) soa = std::max(soa, spring::supernodal_scratch(model.predictor, model.solver->supernodes));
  if (!model.all_pairs && model.predictor.kind != SpringSolver::exact)
    soa = std::max(soa, spring::spring_pass_scratch(model));
  if (!model.all_pairs && !model.solver->supernodes.empty())  // the fused sparse step: pass, then solve
    soa = std::max(soa, spring::spring_pass_scratch(model) +
                            spring::supernodal_scratch(model.predictor, model.solver->supernodes));
  s.soa.assign(soa, 0.0);
  s.soa_single.assign(model.solver->rest_length_single.empty() ? 0 : static_cast<size_t>(n) * 9, 0.0f);
  s.contact_slot.assign(static_cast<size_t>(n), -1);
  s.contact_code.assign(static_cast<size_t>(n), 0);
  return s;
}

void reset(const SpringModel& model, SpringState& s) noexcept {
  s.x = model.network.rest;
  s.v.setZero();
  s.time = 0;
  s.has_prev = false;
  s.grasp = {};
  s.second_grasp = {};
  s.second_tool_force.setZero();
  s.tool_force.setZero();
  s.anchor_force.setZero();
  s.contacts = 0;
  s.contact_vertex_count = 0;
  s.contact_force = 0;
  s.contact_depth = 0;
  s.carried_on_tool.setZero();
}

}  // namespace palpate
