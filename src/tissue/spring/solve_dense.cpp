// solve_dense.cpp — the dense predictor's per-tick product x = A⁻¹ b (desbrun): row by row from
// the double or float inverse, or from the upper triangle of the symmetric double one (AVX-512).
#include "tissue/spring/solve.h"

#include "core/simd.h"
#include "tissue/spring/cpu.h"

#include <algorithm>
#include <cstdint>
#include <cstring>

namespace palpate::spring {

namespace {

// Four doubles: one AVX register in the x86-64-v3 build, two SSE2 registers in the default one.
typedef double vd4 __attribute__((vector_size(32)));  // GCC vector extension (portable build)

// (t0, t1, t2) = Σ_j a[j] (x[j], y[j], z[j]), j < w: one read of a for the three coordinates
// (the dense products' rows). T is the stored value type (double, or float widened to double:
// accumulation is in double). Four at a time, then one by one.
template <typename T>
__attribute__((always_inline)) inline void dot3(const T* a, const double* x, const double* y, const double* z, int w,
                                                double& t0, double& t1, double& t2) noexcept {
  int j = 0;
  double r0 = 0, r1 = 0, r2 = 0;
  vd4 s0 = {0, 0, 0, 0}, s1 = s0, s2 = s0;
  for (; j + 4 <= w; j += 4) {
    const vd4 v = {static_cast<double>(a[j]), static_cast<double>(a[j + 1]), static_cast<double>(a[j + 2]),
                  static_cast<double>(a[j + 3])};
    vd4 vx, vy, vz;
    std::memcpy(&vx, x + j, sizeof vx);
    std::memcpy(&vy, y + j, sizeof vy);
    std::memcpy(&vz, z + j, sizeof vz);
    s0 += v * vx;
    s1 += v * vy;
    s2 += v * vz;
  }
  r0 += (s0[0] + s0[1]) + (s0[2] + s0[3]);
  r1 += (s1[0] + s1[1]) + (s1[2] + s1[3]);
  r2 += (s2[0] + s2[1]) + (s2[2] + s2[3]);
  for (; j < w; ++j) {
    const double v = static_cast<double>(a[j]);
    r0 += v * x[j];
    r1 += v * y[j];
    r2 += v * z[j];
  }
  t0 = r0; t1 = r1; t2 = r2;
}

template <typename T>
__attribute__((always_inline)) inline void dense_rows(const T* W, int n, const double* bx, const double* by,
                                                      const double* bz, double* x) noexcept {
  for (int i = 0; i < n; ++i) {
    double t0, t1, t2;
    dot3(W + static_cast<size_t>(i) * static_cast<size_t>(n), bx, by, bz, n, t0, t1, t2);
    x[3 * i] = t0; x[3 * i + 1] = t1; x[3 * i + 2] = t2;
  }
}

PALPATE_TWICE(dense_double_impl,
              (const double* W, int n, const double* bx, const double* by, const double* bz, double* x),
              { dense_rows(W, n, bx, by, bz, x); })
PALPATE_TWICE(dense_single_impl,
              (const float* W, int n, const double* bx, const double* by, const double* bz, double* x),
              { dense_rows(W, n, bx, by, bz, x); })

// One block of eight columns j0 … j0 + 7 of row i of the symmetric product (lanes in m read, lanes
// in mu also update y): acc += W_ij b_j, y_j += W_ij b_i.
template <bool Full>
[[gnu::always_inline]] PALPATE_AVX512 inline void dense_symmetric_block(const double* w, const double* bx,
                                                                       const double* by, const double* bz, double* yx,
                                                                       double* yy, double* yz, simd::k8 m, simd::k8 mu,
                                                                       simd::d8 bi[3], simd::d8 acc[3]) noexcept {
  using namespace simd;
  const d8 v = Full ? loadu<d8>(w) : loadu(m, w);
  acc[0] = fma(v, Full ? load<d8>(bx) : load(m, bx), acc[0]);
  acc[1] = fma(v, Full ? load<d8>(by) : load(m, by), acc[1]);
  acc[2] = fma(v, Full ? load<d8>(bz) : load(m, bz), acc[2]);
  if (Full) {
    store(yx, fma(v, bi[0], load<d8>(yx)));
    store(yy, fma(v, bi[1], load<d8>(yy)));
    store(yz, fma(v, bi[2], load<d8>(yz)));
  } else {
    store(yx, mu, fma(v, bi[0], load(mu, yx)));
    store(yy, mu, fma(v, bi[1], load(mu, yy)));
    store(yz, mu, fma(v, bi[2], load(mu, yz)));
  }
}

// x = W b for a symmetric W (n x n, row-major) from its upper triangle only, so half of W's bytes
// are read: row i contributes Σ_{j ≥ i} W_ij b_j to x_i and W_ij b_i to x_j for j > i (the
// all-pairs kernel's pattern). b = (bx, by, bz) and y = (yx, yy, yz, the transposed sums) are n
// each, N apart (N a multiple of 8) from a 64-byte boundary, so their accesses are aligned blocks
// of eight; W's rows are read unaligned. x is (n x 3) row-major.
PALPATE_AVX512 void dense_symmetric_avx512(const double* W, int n, const double* b, double* y, size_t N,
                                           double* x) noexcept {
  using namespace simd;
  const double *bx = b, *by = b + N, *bz = b + 2 * N;
  double *yx = y, *yy = y + N, *yz = y + 2 * N;
  std::fill(y, y + 3 * N, 0.0);
  for (int i = 0; i < n; ++i) {
    const double* w = W + static_cast<size_t>(i) * static_cast<size_t>(n);
    d8 bi[3] = {broadcast<d8>(bx[i]), broadcast<d8>(by[i]), broadcast<d8>(bz[i])};
    d8 acc[3] = {zero<d8>(), zero<d8>(), zero<d8>()};
    const int j0 = i & ~7;
    const int lo = i - j0, hi = std::min(8, n - j0);
    const k8 m0 = static_cast<k8>(((1u << hi) - 1) & ~((1u << lo) - 1));
    const k8 u0 = static_cast<k8>(m0 & ~(1u << lo));  // not the diagonal
    dense_symmetric_block<false>(w + j0, bx + j0, by + j0, bz + j0, yx + j0, yy + j0, yz + j0, m0, u0, bi, acc);
    int j = j0 + 8;
    for (; j + 8 <= n; j += 8)
      dense_symmetric_block<true>(w + j, bx + j, by + j, bz + j, yx + j, yy + j, yz + j, 0xFF, 0xFF, bi, acc);
    if (j < n) {
      const k8 m = static_cast<k8>((1u << (n - j)) - 1);
      dense_symmetric_block<false>(w + j, bx + j, by + j, bz + j, yx + j, yy + j, yz + j, m, m, bi, acc);
    }
    // Row i's transposed sums are complete: rows after i only update y_j for j > i.
    x[3 * i] = sum(acc[0]) + yx[i];
    x[3 * i + 1] = sum(acc[1]) + yy[i];
    x[3 * i + 2] = sum(acc[2]) + yz[i];
  }
}

void dense_double(const double* W, int n, const double* bx, const double* by, const double* bz, double* x) noexcept {
  if (has_x86_64_v3())
    dense_double_impl_v3(W, n, bx, by, bz, x);
  else
    dense_double_impl_base(W, n, bx, by, bz, x);
}

void dense_single(const float* W, int n, const double* bx, const double* by, const double* bz, double* x) noexcept {
  if (has_x86_64_v3())
    dense_single_impl_v3(W, n, bx, by, bz, x);
  else
    dense_single_impl_base(W, n, bx, by, bz, x);
}

}  // namespace

size_t dense_scratch(int n) { return 6 * static_cast<size_t>((n + 7) / 8 * 8) + 8; }

void solve_dense(const SpringPredictor& p, const std::vector<float>& inverse_single, const RowMat3d& b, RowMat3d& x,
                 double* scratch, bool symmetric) noexcept {
  const int n = p.n;
  const size_t N = static_cast<size_t>((n + 7) / 8 * 8);
  const std::uintptr_t at = reinterpret_cast<std::uintptr_t>(scratch);
  double* bx = scratch + ((64 - at % 64) % 64) / sizeof(double);  // the first 64-byte boundary
  double* by = bx + N;
  double* bz = bx + 2 * N;
  for (int i = 0; i < n; ++i) {
    bx[i] = b(i, 0); by[i] = b(i, 1); bz[i] = b(i, 2);
  }
  if (inverse_single.empty() && symmetric && __builtin_cpu_supports("avx512f") && has_x86_64_v3())
    dense_symmetric_avx512(p.inverse.data(), n, bx, bx + 3 * N, N, x.data());
  else if (inverse_single.empty()) dense_double(p.inverse.data(), n, bx, by, bz, x.data());
  else dense_single(inverse_single.data(), n, bx, by, bz, x.data());
}

}  // namespace palpate::spring
