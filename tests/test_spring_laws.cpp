// test_spring_laws.cpp — the force laws' vector forms (src/tissue/spring/laws.h, on core/simd.h's
// types) against their scalar forms on random inputs, and the all-pairs kernels built on them
// against the scalar kernel. The vector forms fuse multiply-adds the scalar forms round twice, so
// they agree to a few ulps of the terms' magnitudes (stated per test), not bit for bit.
#include <palpate/spring.h>

#include "tissue/spring/cpu.h"
#include "tissue/spring/forces.h"
#include "tissue/spring/laws.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

using namespace palpate;
using namespace palpate::spring;

namespace {

// The vector forms lane by lane: out[q] = the law at (k[q], …) for one vector of W lanes.
template <typename V>
PALPATE_AVX2 void factor_avx2(const simd::scalar_t<V>* k, const simd::scalar_t<V>* c, const simd::scalar_t<V>* L,
                              const simd::scalar_t<V>* r, const simd::scalar_t<V>* dvd, simd::scalar_t<V>* out) {
  using namespace simd;
  storeu(out, all_pairs_spring_factor_avx2(loadu<V>(k), loadu<V>(c), loadu<V>(L), loadu<V>(r), loadu<V>(dvd)));
}
template <typename V>
PALPATE_AVX2 void newton_avx2(const simd::scalar_t<V>* a, const simd::scalar_t<V>* r, simd::scalar_t<V>* out) {
  using namespace simd;
  storeu(out, rsqrt_newton_step_avx2(loadu<V>(a), loadu<V>(r)));
}

PALPATE_AVX512 void factor_avx512(const double* k, const double* c, const double* L, const double* r,
                                  const double* dvd, double* out) {
  using namespace simd;
  storeu(out, all_pairs_spring_factor_avx512(loadu<d8>(k), loadu<d8>(c), loadu<d8>(L), loadu<d8>(r), loadu<d8>(dvd)));
}
PALPATE_AVX512 void newton_avx512(const double* a, const double* r, double* out) {
  using namespace simd;
  storeu(out, rsqrt_newton_step_avx512(loadu<d8>(a), loadu<d8>(r)));
}

// |vector − scalar| ≤ 8 ε (|k| + |k L r| + |c dvd r²|): each of the few roundings is at most ε of a term.
template <typename V, typename Form>
void expect_factor_matches(Form form) {
  using T = simd::scalar_t<V>;
  constexpr int W = simd::lanes<V>::count;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> U(0, 1);
  const T eps = std::numeric_limits<T>::epsilon();
  for (int trial = 0; trial < 2000; ++trial) {
    T k[W], c[W], L[W], r[W], dvd[W], got[W];
    for (int q = 0; q < W; ++q) {
      k[q] = T(1 + 1e4 * U(rng));                 // N/m
      c[q] = T(10 * U(rng));                      // N·s/m
      L[q] = T(1e-3 + 0.1 * U(rng));              // m
      r[q] = T(1 / (1e-3 + 0.2 * U(rng)));        // 1/m
      dvd[q] = T(2e-3 * (U(rng) - 0.5));          // m²/s
    }
    form(k, c, L, r, dvd, got);
    for (int q = 0; q < W; ++q) {
      const T want = all_pairs_spring_factor(k[q], c[q], L[q], r[q], dvd[q]);
      const T scale = std::abs(k[q]) + std::abs(k[q] * L[q] * r[q]) + std::abs(c[q] * dvd[q] * r[q] * r[q]);
      ASSERT_LE(std::abs(got[q] - want), 8 * eps * scale) << "trial " << trial << " lane " << q;
    }
  }
}

// One Newton step: 3 − (a r) r is one rounding in the vector form, two in the scalar one, and
// a r² ≈ 1 near the root: |vector − scalar| ≤ 8 ε |scalar|.
template <typename V, typename Form>
void expect_newton_matches(Form form) {
  using T = simd::scalar_t<V>;
  constexpr int W = simd::lanes<V>::count;
  std::mt19937_64 rng(12);
  std::uniform_real_distribution<double> U(0, 1);
  const T eps = std::numeric_limits<T>::epsilon();
  for (int trial = 0; trial < 2000; ++trial) {
    T a[W], r[W], got[W];
    for (int q = 0; q < W; ++q) {
      a[q] = T(1e-6 + U(rng));
      r[q] = T((1 + 1e-3 * (U(rng) - 0.5)) / std::sqrt(double(a[q])));  // an estimate within 1e-3
    }
    form(a, r, got);
    for (int q = 0; q < W; ++q) {
      const T want = rsqrt_newton_step(a[q], r[q]);
      ASSERT_LE(std::abs(got[q] - want), 8 * eps * std::abs(want)) << "trial " << trial << " lane " << q;
    }
  }
}

}  // namespace

TEST(SpringLaws, AllPairsFactorVectorFormsMatchTheScalarLaw) {
  if (!has_avx2_fma()) GTEST_SKIP() << "no AVX2 + FMA";
  expect_factor_matches<simd::d4>(factor_avx2<simd::d4>);
  expect_factor_matches<simd::f8>(factor_avx2<simd::f8>);
  if (has_avx512()) expect_factor_matches<simd::d8>(factor_avx512);
}

TEST(SpringLaws, NewtonStepVectorFormsMatchTheScalarStep) {
  if (!has_avx2_fma()) GTEST_SKIP() << "no AVX2 + FMA";
  expect_newton_matches<simd::d4>(newton_avx2<simd::d4>);
  expect_newton_matches<simd::f8>(newton_avx2<simd::f8>);
  if (has_avx512()) expect_newton_matches<simd::d8>(newton_avx512);
}

TEST(SpringLaws, AllPairsKernelsMatchTheScalarKernel) {
  // Random all-pairs networks (n not a multiple of 4 or 8, so every kernel's tail runs) and random
  // positions and velocities, one coincident pair: each kernel's forces against the scalar
  // kernel's, to 1e-12 of the largest sum of the force magnitudes on a vertex (Σ_j |g_ij d_ij|, N).
  // (The 1/l of the vector kernels is rounding-exact after its Newton steps; what differs is fused
  // multiply-adds and the order of the row sums.)
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> U(-0.05, 0.05);
  for (int n : {5, 13, 37, 64, 101}) {
    SpringNetwork net;
    net.rest = RowMat3d(n, 3);
    for (int i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) net.rest(i, c) = U(rng);
    net.mass.assign(static_cast<size_t>(n), 0.01);
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j) {
        net.springs.push_back({i, j});
        net.rest_length.push_back((net.rest.row(i) - net.rest.row(j)).norm() * (1 + 0.1 * U(rng)));
        net.stiffness.push_back(100 + 1e4 * std::abs(U(rng)));
        net.damping.push_back(0.1 + std::abs(U(rng)));
      }
    const size_t N = all_pairs_stride(static_cast<size_t>(n));
    std::vector<double> input(6 * N, 0.0);
    for (size_t k = 0; k < 6 * N; ++k) input[k] = k % N < static_cast<size_t>(n) ? U(rng) : 0.0;
    for (int c = 0; c < 3; ++c) input[c * N + 3] = input[c * N + 1];  // vertices 1 and 3 coincide
    for (bool uniform : {false, true}) {
      auto run = [&](SpringKernel kernel) {
        std::vector<double> buf(all_pairs_scratch(static_cast<size_t>(n)), 0.0);
        double* p = align64(buf.data());
        std::copy(input.begin(), input.end(), p);
        add_all_pair_forces_soa(net, uniform, p, N, kernel);
        return std::vector<double>(p + 6 * N, p + 9 * N);
      };
      const std::vector<double> want = run(SpringKernel::scalar);
      // Σ_j |g_ij d_ij| per vertex and coordinate, the scale of each sum.
      double scale = 0;
      for (int i = 0; i < n; ++i) {
        double s = 0;
        for (int j = 0; j < n; ++j) {
          if (i == j) continue;
          const int a = std::min(i, j), b = std::max(i, j);
          const size_t e = static_cast<size_t>(a) * static_cast<size_t>(n) - static_cast<size_t>(a) * (a + 1) / 2 +
                           static_cast<size_t>(b - a - 1);
          double d[3], w[3];
          for (int c = 0; c < 3; ++c) {
            d[c] = input[c * N + static_cast<size_t>(b)] - input[c * N + static_cast<size_t>(a)];
            w[c] = input[(3 + c) * N + static_cast<size_t>(b)] - input[(3 + c) * N + static_cast<size_t>(a)];
          }
          const double l2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
          if (!(l2 >= 1e-30)) continue;
          const double k = uniform ? net.stiffness[0] : net.stiffness[e], cd = uniform ? net.damping[0] : net.damping[e];
          const double g = all_pairs_spring_factor(k, cd, net.rest_length[e], 1 / std::sqrt(l2),
                                                   d[0] * w[0] + d[1] * w[1] + d[2] * w[2]);
          s += std::abs(g) * std::sqrt(l2);
        }
        scale = std::max(scale, s);
      }
      ASSERT_GT(scale, 0.0);
      for (SpringKernel kernel : {SpringKernel::avx2, SpringKernel::avx512}) {
        const std::vector<double> got = run(kernel);
        double worst = 0;
        for (size_t q = 0; q < got.size(); ++q) worst = std::max(worst, std::abs(got[q] - want[q]));
        EXPECT_LE(worst, 1e-12 * scale) << "n " << n << " uniform " << uniform << " kernel " << static_cast<int>(kernel);
      }
    }
  }
  if (!has_avx2_fma()) std::printf("no AVX2 + FMA here: the vector kernels fell back to the scalar one\n");
}
