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

// ---- The generic-network and volume laws (spring_pass.cpp, volume_pass.cpp) ----

namespace {

PALPATE_AVX2 void spring_factor_lanes(const double* k, const double* c, const double* L, const double* l,
                                      const double* il, const double* dvu, double* out) {
  using namespace simd;
  storeu(out, spring_factor_avx2(loadu<d4>(k), loadu<d4>(c), loadu<d4>(L), loadu<d4>(l), loadu<d4>(il),
                                 loadu<d4>(dvu)));
}
PALPATE_AVX2 void directional_lanes(const double* hk, const double* L, const double* il, const double* dw,
                                    double* mu, double* nu) {
  using namespace simd;
  const d4 m = directional_mu_avx2(loadu<d4>(hk), loadu<d4>(L), loadu<d4>(il));
  storeu(mu, m);
  storeu(nu, directional_nu_avx2(m, loadu<d4>(dw), loadu<d4>(il)));
}
// Lane l of a, b, c: tetrahedron l's edges; g[k][c] lane l its gradient k's coordinate c.
PALPATE_AVX2 void tet_lanes(const double (*e)[4], double g[3][3][4], double* v6, const double* k6,
                            const double* scale, double* s) {
  using namespace simd;
  const TetGradients<d4> t = tet_gradients_avx2(loadu<d4>(e[0]), loadu<d4>(e[1]), loadu<d4>(e[2]), loadu<d4>(e[3]),
                                                loadu<d4>(e[4]), loadu<d4>(e[5]), loadu<d4>(e[6]), loadu<d4>(e[7]),
                                                loadu<d4>(e[8]));
  for (int k = 0; k < 3; ++k)
    for (int c = 0; c < 3; ++c) storeu(g[k][c], t.g[k][c]);
  storeu(v6, t.v6);
  storeu(s, volume_force_factor_avx2(loadu<d4>(k6), loadu<d4>(scale), t.v6));
}

}  // namespace

TEST(SpringLaws, SpringFactorVectorFormMatchesTheScalarLaw) {
  // The same operations in the same order; compiled with FMA, the products and sums may be fused:
  // |vector − scalar| ≤ 4 ε (|k (l − L)| + |c dvu|) / l.
  if (!has_avx2_fma()) GTEST_SKIP() << "no AVX2 + FMA";
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> U(0, 1);
  const double eps = std::numeric_limits<double>::epsilon();
  for (int trial = 0; trial < 2000; ++trial) {
    double k[4], c[4], L[4], l[4], il[4], dvu[4], got[4];
    for (int q = 0; q < 4; ++q) {
      k[q] = 1 + 1e4 * U(rng), c[q] = 10 * U(rng), L[q] = 1e-3 + 0.05 * U(rng);
      l[q] = 1e-4 + 0.1 * U(rng), il[q] = 1 / l[q], dvu[q] = 0.2 * (U(rng) - 0.5);
    }
    spring_factor_lanes(k, c, L, l, il, dvu, got);
    for (int q = 0; q < 4; ++q) {
      const double want = spring_factor(k[q], c[q], L[q], l[q], il[q], dvu[q]);
      const double bound = 4 * eps * (std::abs(k[q] * (l[q] - L[q])) + std::abs(c[q] * dvu[q])) * il[q];
      ASSERT_LE(std::abs(got[q] - want), bound) << "trial " << trial << " lane " << q;
    }
  }
  // The law itself: a spring stretched by 1 mm beyond L = 1 cm at rest pulls with k (l − L) = 1 N
  // at k = 1000 N/m: g l = 1 N.
  EXPECT_NEAR(spring_factor(1000.0, 0.5, 0.01, 0.011, 1 / 0.011, 0.0) * 0.011, 1.0, 1e-12);
  // A closing velocity of 0.1 m/s along the spring adds c Δv·u = 0.05 N of damping force.
  EXPECT_NEAR(spring_factor(1000.0, 0.5, 0.01, 0.01, 1 / 0.01, -0.1) * 0.01, -0.05, 1e-12);
}

TEST(SpringLaws, DirectionalStiffnessVectorFormMatchesTheScalarLaw) {
  // μ = h k min(1, L/l), ν = μ (d·w)/l²; the vector form multiplies by 1/l where the law divides by
  // l: |vector − scalar| ≤ 4 ε |scalar|. And the law: a slack spring (l ≤ L) has μ = h k, its
  // transverse stiffness removed entirely; a spring stretched to 2L keeps half (μ = h k / 2).
  if (!has_avx2_fma()) GTEST_SKIP() << "no AVX2 + FMA";
  std::mt19937_64 rng(22);
  std::uniform_real_distribution<double> U(0, 1);
  const double eps = std::numeric_limits<double>::epsilon();
  for (int trial = 0; trial < 2000; ++trial) {
    double h[4], k[4], hk[4], L[4], l[4], il[4], dw[4], mu[4], nu[4];
    for (int q = 0; q < 4; ++q) {
      h[q] = 1e-3 * (0.5 + U(rng)), k[q] = 1 + 1e4 * U(rng), hk[q] = h[q] * k[q];
      L[q] = 1e-3 + 0.05 * U(rng), l[q] = L[q] * (0.5 + U(rng)), il[q] = 1 / l[q], dw[q] = 1e-3 * (U(rng) - 0.5);
    }
    directional_lanes(hk, L, il, dw, mu, nu);
    for (int q = 0; q < 4; ++q) {
      const double m = directional_mu(h[q], k[q], L[q], l[q]), n = directional_nu(m, dw[q], l[q]);
      ASSERT_LE(std::abs(mu[q] - m), 4 * eps * std::abs(m)) << "trial " << trial;
      ASSERT_LE(std::abs(nu[q] - n), 8 * eps * std::abs(n)) << "trial " << trial;
    }
  }
  EXPECT_DOUBLE_EQ(directional_mu(1e-3, 500.0, 0.01, 0.008), 0.5);
  EXPECT_DOUBLE_EQ(directional_mu(1e-3, 500.0, 0.01, 0.02), 0.25);
}

TEST(SpringLaws, VolumeGradientsVectorFormMatchTheScalarLaw) {
  // 6∇V and 6V of random tetrahedra, and the force factor: the vector form fuses each cross
  // product's multiply-subtract, so |vector − scalar| ≤ 4 ε (|a||b| products' scale).
  if (!has_avx2_fma()) GTEST_SKIP() << "no AVX2 + FMA";
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> U(-0.01, 0.01);
  const double eps = std::numeric_limits<double>::epsilon();
  for (int trial = 0; trial < 1000; ++trial) {
    double e[9][4], g[3][3][4], v6[4], k6[4], scale[4], s[4];
    for (auto& row : e)
      for (double& x : row) x = U(rng);
    for (int q = 0; q < 4; ++q) k6[q] = 1e4 / 6, scale[q] = 1e4 / (36 * 1e-7 * (1 + 100 * std::abs(U(rng))));
    tet_lanes(e, g, v6, k6, scale, s);
    for (int q = 0; q < 4; ++q) {
      const TetGradients<double> t = tet_gradients(e[0][q], e[1][q], e[2][q], e[3][q], e[4][q], e[5][q], e[6][q],
                                                   e[7][q], e[8][q]);
      const double unit = 4 * eps * 1e-4;  // |edge|² ≤ 3e-4 m²: each product below 1e-4
      for (int k = 0; k < 3; ++k)
        for (int c = 0; c < 3; ++c) ASSERT_LE(std::abs(g[k][c][q] - t.g[k][c]), unit) << "trial " << trial;
      ASSERT_LE(std::abs(v6[q] - t.v6), 8 * eps * 1e-6) << "trial " << trial;
      const double want = volume_force_factor_precomputed(k6[q], scale[q], t.v6);
      ASSERT_LE(std::abs(s[q] - want), 4 * eps * (k6[q] + std::abs(scale[q] * t.v6)) + std::abs(scale[q]) * 8 * eps * 1e-6)
          << "trial " << trial;
    }
  }
  // The law on the unit right tetrahedron (edges along the axes): 6V = 1, corner 1's 6∇V = b × c
  // = (1, 0, 0); at rest (V = V0) no force; the precomputed form is the same factor.
  const TetGradients<double> t = tet_gradients(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0);
  EXPECT_EQ(t.v6, 1.0);
  EXPECT_EQ(t.g[0][0], 1.0);
  EXPECT_EQ(t.g[2][2], 1.0);
  EXPECT_EQ(volume_force_factor(5000.0, 1.0 / 6, 1.0), 0.0);
  // Compressed to half its volume: p = κ (V − V0)/V0 = −κ/2, s = −p/6 = κ/12, pushing the corners out.
  EXPECT_NEAR(volume_force_factor(5000.0, 1.0 / 6, 0.5), 5000.0 / 12, 1e-9);
  EXPECT_NEAR(volume_force_factor_precomputed(5000.0 / 6, 5000.0 / (36 * (1.0 / 6)), 0.5), 5000.0 / 12, 1e-9);
}

#if !defined(__clang__)  // GCC's warnings (clang has no -Wmaybe-uninitialized)
#pragma GCC diagnostic push  // GCC 12's AVX-512 intrinsics pass an undefined merge source (core/simd.h)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#endif

namespace {

PALPATE_AVX512VL void layout_ops(const double* a, double* out_sums, double* out_halves, double* out_t, double* out_s) {
  using namespace simd;
  const d4 r[4] = {loadu<d4>(a), loadu<d4>(a + 4), loadu<d4>(a + 8), loadu<d4>(a + 12)};
  storeu(out_sums, sums(r[0], r[1], r[2], r[3]));
  const d8 w[4] = {loadu<d8>(a), loadu<d8>(a + 8), loadu<d8>(a + 16), loadu<d8>(a + 24)};
  storeu(out_halves, sums_halves(w[0], w[1], w[2], w[3]));
  d4 x, y, z, back[4];
  transpose3(r, x, y, z);
  storeu(out_t, x), storeu(out_t + 4, y), storeu(out_t + 8, z);
  transpose3(x, y, z, back);
  for (int q = 0; q < 4; ++q) storeu(out_t + 12 + 4 * q, back[q]);
  const d8 h = concat(r[0], r[1]);
  storeu(out_s, splat_halves<2>(h));
  storeu(out_s + 8, low_twice(h));
  storeu(out_s + 16, concat(high(h), low(h)));
  storeu(out_s + 24, concat(splat<3>(r[2]), splat<0>(r[2])));
}

}  // namespace

#if !defined(__clang__)
#pragma GCC diagnostic pop
#endif

TEST(SimdTypes, HorizontalSumsTransposesAndLaneMovesDoWhatTheirNamesSay) {
  // The layout operations the kernels are written with (core/simd.h), against the scalar
  // arithmetic they name: sums() as (a0 + a1) + (a2 + a3) exactly, the transposes' rows and columns.
  if (!has_avx512()) GTEST_SKIP() << "no AVX-512";
  double a[32];
  std::mt19937_64 rng(24);
  std::uniform_real_distribution<double> U(-1, 1);
  for (double& x : a) x = U(rng);
  double s[4], h[8], t[28], m[32];
  layout_ops(a, s, h, t, m);
  for (int q = 0; q < 4; ++q) EXPECT_EQ(s[q], (a[4 * q] + a[4 * q + 1]) + (a[4 * q + 2] + a[4 * q + 3])) << q;
  for (int half = 0; half < 2; ++half)
    for (int q = 0; q < 4; ++q) {
      const double* p = a + 8 * q + 4 * half;
      EXPECT_EQ(h[4 * half + q], (p[0] + p[1]) + (p[2] + p[3])) << half << " " << q;
    }
  for (int l = 0; l < 4; ++l)
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(t[4 * c + l], a[4 * l + c]);                          // column c, lane l = row l's c
      EXPECT_EQ(t[12 + 4 * l + c], a[4 * l + c]);                     // and back
    }
  for (int l = 0; l < 4; ++l) EXPECT_EQ(t[12 + 4 * l + 3], 0.0);    // the rows' fourth lane: 0
  for (int q = 0; q < 4; ++q) {
    EXPECT_EQ(m[q], a[2]);
    EXPECT_EQ(m[4 + q], a[6]);                // splat_halves<2>
    EXPECT_EQ(m[8 + q], a[q]);
    EXPECT_EQ(m[12 + q], a[q]);           // low_twice
    EXPECT_EQ(m[16 + q], a[4 + q]);
    EXPECT_EQ(m[20 + q], a[q]);      // halves swapped
    EXPECT_EQ(m[24 + q], a[11]);
    EXPECT_EQ(m[28 + q], a[8]);         // splat<3>, splat<0>
  }
}
