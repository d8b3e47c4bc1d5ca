// test_spring_damping.cpp — how much a transverse mode is damped per period by the predictors
// (desbrun, sparse) and by exact backward Euler, on a pre-tensioned chain (issue 21's measurement):
// the predictors' transverse stiffness h²k(I − uuᵀ), dropped from the true Jacobian's k(1 − L/l)
// part, damps it more. Recorded, with the ordering asserted.
#include <palpate/spring.h>

#include "spring_fixtures.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

namespace {

using namespace palpate;

// A chain of 11 masses (1 g) on springs (100 N/m, rest 1 cm) stretched 10 %, its ends held, released
// from its first transverse mode (1 mm amplitude, no damping terms). Amplitude kept per period:
// the middle mass's successive positive peaks, geometric mean over the first `periods`.
double kept_per_period(SpringSolver solver, int periods) {
  const int n = 11;
  const double L = 0.01, stretch = 1.1;
  SpringNetwork net;
  net.rest.resize(n, 3);
  for (int i = 0; i < n; ++i) net.rest.row(i) << i * L * stretch, 0, 0;  // rest = the stretched line
  net.mass.assign(n, 1e-3);
  for (int i = 0; i + 1 < n; ++i) net.springs.push_back({i, i + 1});
  net.rest_length.assign(n - 1, L);
  net.stiffness.assign(n - 1, 100.0);
  net.damping.assign(n - 1, 0.0);
  net.anchors = {0, n - 1};
  SpringModelOptions o;
  o.solver = solver;
  o.point_damping = 0;
  o.gravity = false;
  const SpringModel model = spring_test::must_build(std::move(net), o);
  SpringState s = make_state(model);
  for (int i = 0; i < n; ++i) s.x(i, 1) = 0.001 * std::sin(M_PI * i / (n - 1));
  std::vector<double> peaks;
  double prev2 = 0, prev = s.x(n / 2, 1);
  for (int k = 0; k < 20000 && static_cast<int>(peaks.size()) <= periods; ++k) {
    EXPECT_TRUE(step(model, s, nullptr));
    const double y = s.x(n / 2, 1);
    if (k > 1 && prev > prev2 && prev >= y && prev > 0) peaks.push_back(prev);
    prev2 = prev;
    prev = y;
  }
  if (peaks.size() < 2) return 0;
  return std::pow(peaks.back() / peaks.front(), 1.0 / static_cast<double>(peaks.size() - 1));
}

}  // namespace

TEST(SpringDamping, PredictorsDampATransverseModeMoreThanBackwardEuler) {
  const double exact = kept_per_period(SpringSolver::exact, 3);
  const double desbrun = kept_per_period(SpringSolver::desbrun, 3);
  const double sparse = kept_per_period(SpringSolver::sparse, 3);
  std::printf("transverse mode, amplitude kept per period: exact %.3f, desbrun %.3f, sparse %.3f\n", exact, desbrun,
              sparse);
  RecordProperty("kept_per_period_exact", std::to_string(exact));
  RecordProperty("kept_per_period_desbrun", std::to_string(desbrun));
  EXPECT_GT(exact, 0.5);
  EXPECT_LT(exact, 1.0);  // backward Euler's own numerical damping
  EXPECT_NEAR(desbrun, sparse, 1e-6);
  EXPECT_LT(desbrun, exact);
}
