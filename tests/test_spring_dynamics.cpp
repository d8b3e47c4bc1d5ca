// test_spring_dynamics.cpp — accuracy of the mass-spring integrators against analytic answers
// (period, backward-Euler amplitude factor, hanging chain) and between the solvers.
#include "spring_fixtures.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <numbers>
#include <sstream>
#include <string>
#include <tuple>

using namespace palpate;
using namespace spring_test;

namespace {

const SpringSolver kAllSolvers[] = {SpringSolver::desbrun, SpringSolver::sparse, SpringSolver::exact};

std::string solver_label(SpringSolver s) {
  return s == SpringSolver::desbrun ? "desbrun" : s == SpringSolver::sparse ? "sparse" : "exact";
}

// One mass m on one spring k, its other end anchored at the origin; the mass at (rest + offset, 0, 0).
SpringNetwork one_spring(double m, double k, double rest) {
  SpringNetwork net;
  net.rest = RowMat3d(2, 3);
  net.rest << 0, 0, 0, rest, 0, 0;
  net.mass = {m, m};
  net.springs = {{0, 1}};
  net.rest_length = {rest};
  net.stiffness = {k};
  net.damping = {0.0};
  net.anchors = {0};
  return net;
}

SpringModelOptions quiet(double dt, SpringSolver solver) {
  SpringModelOptions o;
  o.dt = dt;
  o.solver = solver;
  o.point_damping = 0;
  o.gravity = false;
  return o;
}

// Rows of a CSV with '#' comments and one header line.
std::vector<std::map<std::string, std::string>> read_csv(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  std::vector<std::string> header;
  std::vector<std::map<std::string, std::string>> rows;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> cells;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) cells.push_back(cell);
    if (header.empty()) {
      header = cells;
      continue;
    }
    std::map<std::string, std::string> row;
    for (size_t c = 0; c < cells.size() && c < header.size(); ++c) row[header[c]] = cells[c];
    rows.push_back(row);
  }
  return rows;
}

double total_energy(const SpringModel& m, const SpringState& s) { return kinetic_energy(m, s) + elastic_energy(m, s); }

}  // namespace

TEST(SpringOscillator, PeriodWithinOnePercentOfAnalytic) {
  const double m = 0.02, k = 50.0;
  const double period = 2 * std::numbers::pi * std::sqrt(m / k);
  const double dt = period / 2000;
  for (SpringSolver solver : kAllSolvers) {
    SpringModel model = must_build(one_spring(m, k, 0.05), quiet(dt, solver));
    SpringState s = make_state(model);
    s.x(1, 0) += 0.001;
    // Upward zero crossings of the displacement, linearly interpolated.
    std::vector<double> crossings;
    double prev = s.x(1, 0) - 0.05;
    for (int i = 0; i < 8000 && crossings.size() < 3; ++i) {
      ASSERT_TRUE(step(model, s, nullptr));
      const double now = s.x(1, 0) - 0.05;
      if (prev < 0 && now >= 0) crossings.push_back(s.time - dt * now / (now - prev));
      prev = now;
    }
    ASSERT_EQ(crossings.size(), 3u) << solver_label(solver);
    const double measured = (crossings[2] - crossings[0]) / 2;
    EXPECT_NEAR(measured, period, 0.01 * period) << solver_label(solver);
  }
}

TEST(SpringOscillator, BackwardEulerAmplitudeFactorPerStep) {
  const auto rows = read_csv(std::string(PALPATE_DATA_DIR) + "/analytic/implicit_euler_oscillator.csv");
  ASSERT_GE(rows.size(), 5u);
  const double m = 0.01, k = 100.0, w = std::sqrt(k / m);
  for (const auto& row : rows) {
    const double wh = std::stod(row.at("w_h"));
    const double factor = std::stod(row.at("implicit_amp_per_step"));
    for (SpringSolver solver : kAllSolvers) {
      SpringModel model = must_build(one_spring(m, k, 0.1), quiet(wh / w, solver));
      SpringState s = make_state(model);
      s.x(1, 0) += 0.001;
      // In (x, v/ω) backward Euler is a rotation scaled by 1/√(1 + (ωh)²) each step.
      auto amplitude = [&] { return std::hypot(s.x(1, 0) - 0.1, s.v(1, 0) / w); };
      const double a0 = amplitude();
      const int steps = 10;
      for (int i = 0; i < steps; ++i) ASSERT_TRUE(step(model, s, nullptr));
      EXPECT_NEAR(amplitude() / a0, std::pow(factor, steps), 1e-6) << "wh " << wh << " " << solver_label(solver);
    }
  }
}

TEST(SpringEnergy, NeverGrowsUnderAnyImplicitVariant) {
  for (SpringSolver solver : kAllSolvers) {
    for (bool anchored : {false, true}) {
      SpringModelOptions o = quiet(0.001, solver);
      SpringModel model = must_build(block_network(4, 4, 4, 0.01, 200.0, 0.05, anchored), o);
      SpringState s = make_state(model);
      // A smooth initial deformation: a shear and a bulge, 5% of the spacing.
      for (Eigen::Index i = 0; i < s.x.rows(); ++i) {
        if (model.anchored[static_cast<size_t>(i)]) continue;
        const double y = s.x(i, 1);
        s.x(i, 0) += 0.005 * y / 0.03;
        s.x(i, 2) += 0.0005 * std::sin(100 * s.x(i, 0));
      }
      double e = total_energy(model, s);
      const double e0 = e;
      for (int i = 0; i < 300; ++i) {
        ASSERT_TRUE(step(model, s, nullptr));
        const double next = total_energy(model, s);
        ASSERT_LE(next, e * (1 + 1e-9) + 1e-15) << solver_label(solver) << " step " << i;
        e = next;
      }
      EXPECT_LT(e, e0) << solver_label(solver);
    }
  }
}

TEST(SpringChain, HangingChainSettlesToAnalyticStretch) {
  const auto rows = read_csv(std::string(PALPATE_DATA_DIR) + "/analytic/hanging_spring_chain_static.csv");
  // Group the rows by chain (N, m, k).
  std::map<std::tuple<int, double, double>, std::vector<std::pair<int, double>>> chains;
  for (const auto& r : rows)
    chains[{std::stoi(r.at("N")), std::stod(r.at("m_kg")), std::stod(r.at("k_N_per_m"))}].push_back(
        {std::stoi(r.at("i")), std::stod(r.at("mass_i_displacement_m"))});
  ASSERT_GE(chains.size(), 3u);
  const double g = 9.81;  // the file's g (its header: "g=9.81")
  for (const auto& [key, expected] : chains) {
    const auto [N, m, k] = key;
    const double rest = 0.1;
    SpringNetwork net;
    net.rest = RowMat3d::Zero(N + 1, 3);
    for (int i = 0; i <= N; ++i) net.rest(i, 1) = -rest * i;
    net.mass.assign(static_cast<size_t>(N) + 1, m);
    for (int i = 0; i < N; ++i) net.springs.push_back({i, i + 1});
    net.rest_length.assign(static_cast<size_t>(N), rest);
    net.stiffness.assign(static_cast<size_t>(N), k);
    net.damping.assign(static_cast<size_t>(N), 0.0);
    net.anchors = {0};
    for (SpringSolver solver : kAllSolvers) {
      SpringModelOptions o;
      o.dt = 0.005;
      o.solver = solver;
      o.gravity_acceleration = g;
      o.point_damping = 2 * std::sqrt(k * m) * 0.5;
      SpringModel model = must_build(net, o);
      SpringState s = make_state(model);
      for (int i = 0; i < 40000; ++i) {
        ASSERT_TRUE(step(model, s, nullptr));
        if (i > 100 && kinetic_energy(model, s) < 1e-16) break;
      }
      for (const auto& [i, disp] : expected)
        EXPECT_NEAR(-(s.x(i, 1) - net.rest(i, 1)), disp, 0.01 * disp)
            << "N " << N << " mass " << i << " " << solver_label(solver);
    }
  }
}

TEST(SpringSolvers, DenseAndSparsePredictorsGiveTheSameStep) {
  SpringNetwork net = block_network(5, 5, 5, 0.01, 300.0, 0.1, true, 0.05);
  SpringModelOptions o;
  o.solver = SpringSolver::desbrun;
  SpringModel dense = must_build(net, o);
  o.solver = SpringSolver::sparse;
  SpringModel sparse = must_build(net, o);
  SpringState a = make_state(dense), b = make_state(sparse);
  ToolState tool;
  tool.tip = Vec3(0.02, 0.0405, 0.02);
  tool.radius = 0.003;
  for (int i = 0; i < 100; ++i) {
    ASSERT_TRUE(step(dense, a, &tool));
    ASSERT_TRUE(step(sparse, b, &tool));
  }
  EXPECT_LT((a.x - b.x).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_GT(max_displacement(dense, a), 1e-4);  // the probe did deform it
}

TEST(SpringSolvers, PredictorsAgreeWithExactBackwardEulerForSmallDeformations) {
  // A block sagging under gravity by a fraction of a millimetre. The predictor differs from the
  // exact backward Euler only through the transverse stiffness h²k(I − uuᵀ) it adds to each spring,
  // so the gap scales with h²k/m. Stated tolerances: with h²k/m = 0.05, every sampled step of the
  // transient within 10% of the largest displacement (measured: 6.9%); at rest, within 1e-6 of it.
  SpringNetwork net = block_network(4, 4, 4, 0.01, 500.0, 0.64, true, 0.02);
  SpringModelOptions o;
  o.dt = 0.001;
  o.point_damping = 0.5;
  o.solver = SpringSolver::exact;
  SpringModel exact = must_build(net, o);
  SpringState se = make_state(exact);
  for (SpringSolver solver : {SpringSolver::desbrun, SpringSolver::sparse}) {
    o.solver = solver;
    SpringModel fast = must_build(net, o);
    SpringState sf = make_state(fast);
    palpate::reset(exact, se);
    double gap = 0, peak = 0;
    for (int i = 0; i < 300; ++i) {
      ASSERT_TRUE(step(exact, se, nullptr));
      ASSERT_TRUE(step(fast, sf, nullptr));
      gap = std::max(gap, (se.x - sf.x).cwiseAbs().maxCoeff());
      peak = std::max(peak, max_displacement(exact, se));
    }
    EXPECT_GT(peak, 1e-5);
    std::printf("%s: transient gap %.3g of the peak displacement %.3g m\n", solver_label(solver).c_str(), gap / peak, peak);
    EXPECT_LT(gap, 0.10 * peak) << solver_label(solver);
    // Both settle to the same static equilibrium: the fixed point of either is f(x) = 0.
    for (int i = 0; i < 3000; ++i) {
      ASSERT_TRUE(step(fast, sf, nullptr));
      if (kinetic_energy(fast, sf) < 1e-20) break;
    }
    SpringModelOptions oe = o;
    oe.solver = SpringSolver::exact;
    oe.dt = 0.05;  // large steps: the exact solver reaches rest quickly
    SpringModel settle = must_build(net, oe);
    SpringState ss = make_state(settle);
    for (int i = 0; i < 150; ++i) ASSERT_TRUE(step(settle, ss, nullptr));
    EXPECT_LT((ss.x - sf.x).cwiseAbs().maxCoeff(), 1e-6 * max_displacement(settle, ss)) << solver_label(solver);
  }
}

TEST(SpringSolvers, StableWithStiffnessTimesThousandAtOneMillisecond) {
  for (SpringSolver solver : {SpringSolver::desbrun, SpringSolver::sparse}) {
    SpringModelOptions o;
    o.dt = 0.001;
    o.solver = solver;
    SpringModel model = must_build(block_network(6, 6, 6, 0.01, 100.0 * 1000, 0.1, true, 0.1), o);
    SpringState s = make_state(model);
    // Start far from rest (30% squashed) and push a probe in: an explicit integrator blows up.
    for (Eigen::Index i = 0; i < s.x.rows(); ++i) s.x(i, 1) *= 0.7;
    ToolState tool;
    tool.radius = 0.004;
    double peak = 0;
    for (int i = 0; i < 1000; ++i) {
      tool.tip = Vec3(0.02, 0.053 - 0.01 * std::min(1.0, i / 300.0), 0.02);
      ASSERT_TRUE(step(model, s, &tool)) << solver_label(solver) << " step " << i;
      ASSERT_TRUE(s.x.allFinite() && s.v.allFinite());
      peak = std::max(peak, s.tool_force.norm());
    }
    EXPECT_EQ(s.resets, 0u);
    EXPECT_LT(max_displacement(model, s), 0.05);
    EXPECT_GT(peak, 0.0);
  }
}

TEST(SpringSolvers, BlowUpResetsTheStateAndReportsIt) {
  SpringModelOptions o;
  o.solver = SpringSolver::sparse;
  SpringModel model = must_build(block_network(3, 3, 3, 0.01, 100.0, 0.05, true), o);
  SpringState s = make_state(model);
  s.v(13, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(step(model, s, nullptr));
  EXPECT_EQ(s.resets, 1u);
  EXPECT_TRUE(s.x.isApprox(model.network.rest));
  EXPECT_EQ(s.v.cwiseAbs().maxCoeff(), 0.0);
  EXPECT_TRUE(step(model, s, nullptr));
}

namespace {

// m ẍ + γ ẋ + k x = 0 from x(0) = d, ẋ(0) = 0, overdamped (γ² > 4mk): x(t) and ẋ(t).
struct Overdamped {
  double m, k, gamma, d;
  double r1() const { return (-gamma + std::sqrt(gamma * gamma - 4 * m * k)) / (2 * m); }
  double r2() const { return (-gamma - std::sqrt(gamma * gamma - 4 * m * k)) / (2 * m); }
  // x = A e^{r1 t} + B e^{r2 t}, A + B = d, r1 A + r2 B = 0.
  double a() const { return -r2() * d / (r1() - r2()); }
  double b() const { return r1() * d / (r1() - r2()); }
  double x(double t) const { return a() * std::exp(r1() * t) + b() * std::exp(r2() * t); }
  double v(double t) const { return a() * r1() * std::exp(r1() * t) + b() * r2() * std::exp(r2() * t); }
};

// |x(T) − x_exact(T)| of one damped mass on an anchored spring, stepped to T with steps of `step_h`
// (s, the time each step advances) by `integrator`. BDF2's previous state is the analytic one at
// −step_h (a second-order method needs a second-order start; palpate's own start takes x_{−1} = x_0).
double overdamped_error(const Overdamped& o, SpringIntegrator integrator, double step_h, double T,
                        SpringSolver solver) {
  SpringModelOptions opt = quiet(integrator == SpringIntegrator::bdf2 ? step_h * 2 / 3 : step_h, solver);
  opt.integrator = integrator;
  opt.point_damping = o.gamma;
  opt.angular_momentum_correction = false;
  const double rest = 0.1;
  SpringModel model = must_build(one_spring(o.m, o.k, rest), opt);
  SpringState s = make_state(model);
  s.x(1, 0) = rest + o.d;
  if (integrator == SpringIntegrator::bdf2) {
    s.x_prev = s.x;
    s.v_prev = s.v;
    s.x_prev(1, 0) = rest + o.x(-step_h);
    s.v_prev(1, 0) = o.v(-step_h);
    s.has_prev = true;
  }
  const int steps = static_cast<int>(std::lround(T / step_h));
  for (int i = 0; i < steps; ++i)
    if (!step(model, s, nullptr)) return std::numeric_limits<double>::infinity();
  EXPECT_NEAR(s.time, T, 1e-9);
  return std::abs(s.x(1, 0) - rest - o.x(T));
}

}  // namespace

TEST(SpringBdf2, ConvergesAtSecondOrderWhereBackwardEulerIsFirst) {
  // Two overdamped modes, τ = 26 ms and 3.8 ms (m 10 g, k 100 N/m, γ 3 N·s/m), relaxing from 1 mm
  // for 0.1 s with steps of 4, 2 and 1 ms: halving the step divides BDF2's error by about 4 and
  // backward Euler's by about 2, and at every step BDF2 is several times closer.
  const Overdamped o{0.01, 100.0, 3.0, 0.001};
  for (SpringSolver solver : kAllSolvers) {
    double be_prev = 0, bdf_prev = 0;
    for (double h : {0.004, 0.002, 0.001}) {
      const double be = overdamped_error(o, SpringIntegrator::backward_euler, h, 0.1, solver);
      const double bdf = overdamped_error(o, SpringIntegrator::bdf2, h, 0.1, solver);
      std::printf("[ bdf2 ] %s h %.0f ms: |x - x_exact| backward Euler %.3g m, BDF2 %.3g m\n",
                  solver_label(solver).c_str(), h * 1e3, be, bdf);
      EXPECT_LT(bdf, be / 4) << solver_label(solver) << " h " << h;
      if (be_prev > 0) {
        EXPECT_NEAR(be_prev / be, 2.0, 0.3) << solver_label(solver) << " h " << h;
        EXPECT_NEAR(bdf_prev / bdf, 4.0, 0.6) << solver_label(solver) << " h " << h;
      }
      be_prev = be, bdf_prev = bdf;
    }
  }
}

TEST(SpringBdf2, StiffModesAreDampedNotRungAndTheFirstStepNeedsNoHistory) {
  // L-stable: a stiff spring (ωh = 100 at the step) released from 1 mm without damping loses its
  // amplitude within a few steps under BDF2 as under backward Euler (the trapezoidal rule would
  // ring at ≈ −1 per step), starting from make_state's own start (no previous state).
  const double m = 0.001, k = 1e5, h = 0.01;  // ω = 10⁴ rad/s
  for (SpringSolver solver : kAllSolvers) {
    SpringModelOptions opt = quiet(h * 2 / 3, solver);
    opt.integrator = SpringIntegrator::bdf2;
    SpringModel model = must_build(one_spring(m, k, 0.1), opt);
    SpringState s = make_state(model);
    EXPECT_FALSE(s.has_prev);
    s.x(1, 0) += 0.001;
    for (int i = 0; i < 5; ++i) ASSERT_TRUE(step(model, s, nullptr)) << solver_label(solver);
    EXPECT_NEAR(s.time, 5 * h, 1e-12);
    EXPECT_LT(std::abs(s.x(1, 0) - 0.1), 1e-3 * 0.01) << solver_label(solver);
    EXPECT_TRUE(s.has_prev);
    reset(model, s);
    EXPECT_FALSE(s.has_prev);
  }
}
