// all_pairs.cpp — the all-pairs spring forces (the seed paper's topology: every vertex to every
// other), O(n²) per step on structure-of-arrays copies: the scalar reference and the AVX2, AVX-512
// and single-precision AVX2 kernels.
#include <palpate/spring.h>

#include "tissue/spring/cpu.h"
#include "tissue/spring/forces.h"
#include "tissue/spring/stages.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <immintrin.h>

namespace palpate::spring {

namespace {

// The all-pairs spring forces, rows i = 0 … n − 2 against j = i + 1 … n − 1 (the springs in
// is_all_pairs order; rest lengths L, stiffnesses K, dampings C, or k, c when uniform):
//   g = k (1 − L/l) + c (Δv·d)/l²,  f_i += g d,  f_j −= g d,  d = x_j − x_i, l = |d|,
// the same force as add_spring_forces written with r = 1/l. p is the structure-of-arrays block
// (x, y, z, vx, vy, vz, fx, fy, fz), n each, N apart (N ≥ n). Coincident vertices (l² below 1e-30 m²) get no force.
template <bool Uniform>
inline void all_pairs_portable(int n, const SpringNetwork& net, double* p, size_t N) noexcept {
  const double *X = p, *Y = p + N, *Z = p + 2 * N, *VX = p + 3 * N, *VY = p + 4 * N, *VZ = p + 5 * N;
  double *FX = p + 6 * N, *FY = p + 7 * N, *FZ = p + 8 * N;
  size_t e = 0;
  for (int i = 0; i + 1 < n; ++i) {
    double sx = 0, sy = 0, sz = 0;
    for (int j = i + 1; j < n; ++j, ++e) {
      const double dx = X[j] - X[i], dy = Y[j] - Y[i], dz = Z[j] - Z[i];
      const double l2 = dx * dx + dy * dy + dz * dz;
      if (!(l2 >= 1e-30)) continue;
      const double r = 1.0 / std::sqrt(l2);
      const double k = Uniform ? net.stiffness[0] : net.stiffness[e], c = Uniform ? net.damping[0] : net.damping[e];
      const double dvd = (VX[j] - VX[i]) * dx + (VY[j] - VY[i]) * dy + (VZ[j] - VZ[i]) * dz;
      const double g = k - k * net.rest_length[e] * r + c * dvd * r * r;
      sx += g * dx; sy += g * dy; sz += g * dz;
      FX[j] -= g * dx; FY[j] -= g * dy; FZ[j] -= g * dz;
    }
    FX[i] += sx; FY[i] += sy; FZ[i] += sz;
  }
}

// The same with AVX2 + FMA, four springs at a time. 1/l comes from the single-precision estimate
// (12 bits) refined by three Newton steps r ← r (3 − l² r²)/2 in double (≈ 48 bits, then rounding):
// no square root or division in the loop.
template <bool Uniform>
__attribute__((target("avx2,fma"))) void all_pairs_avx2(int n, const SpringNetwork& net, double* p, size_t N) noexcept {
  const double *X = p, *Y = p + N, *Z = p + 2 * N, *VX = p + 3 * N, *VY = p + 4 * N, *VZ = p + 5 * N;
  double *FX = p + 6 * N, *FY = p + 7 * N, *FZ = p + 8 * N;
  const double* RL = net.rest_length.data();
  const double* KS = net.stiffness.data();
  const double* CS = net.damping.data();
  const __m256d half = _mm256_set1_pd(0.5), three = _mm256_set1_pd(3.0), tiny = _mm256_set1_pd(1e-30);
  size_t e = 0;
  for (int i = 0; i + 1 < n; ++i) {
    const __m256d xi = _mm256_set1_pd(X[i]), yi = _mm256_set1_pd(Y[i]), zi = _mm256_set1_pd(Z[i]);
    const __m256d vxi = _mm256_set1_pd(VX[i]), vyi = _mm256_set1_pd(VY[i]), vzi = _mm256_set1_pd(VZ[i]);
    __m256d sx = _mm256_setzero_pd(), sy = sx, sz = sx;
    int j = i + 1;
    for (; j + 4 <= n; j += 4, e += 4) {
      const __m256d dx = _mm256_sub_pd(_mm256_loadu_pd(X + j), xi);
      const __m256d dy = _mm256_sub_pd(_mm256_loadu_pd(Y + j), yi);
      const __m256d dz = _mm256_sub_pd(_mm256_loadu_pd(Z + j), zi);
      const __m256d l2 = _mm256_fmadd_pd(dz, dz, _mm256_fmadd_pd(dy, dy, _mm256_mul_pd(dx, dx)));
      const __m256d ok = _mm256_cmp_pd(l2, tiny, _CMP_GE_OQ);
      const __m256d l2c = _mm256_max_pd(l2, tiny);
      __m256d r = _mm256_cvtps_pd(_mm_rsqrt_ps(_mm256_cvtpd_ps(l2c)));
      for (int it = 0; it < 3; ++it)
        r = _mm256_mul_pd(_mm256_mul_pd(half, r), _mm256_fnmadd_pd(_mm256_mul_pd(l2c, r), r, three));
      const __m256d k = Uniform ? _mm256_set1_pd(KS[0]) : _mm256_loadu_pd(KS + e);
      const __m256d c = Uniform ? _mm256_set1_pd(CS[0]) : _mm256_loadu_pd(CS + e);
      const __m256d dvd = _mm256_fmadd_pd(
          _mm256_sub_pd(_mm256_loadu_pd(VZ + j), vzi), dz,
          _mm256_fmadd_pd(_mm256_sub_pd(_mm256_loadu_pd(VY + j), vyi), dy,
                          _mm256_mul_pd(_mm256_sub_pd(_mm256_loadu_pd(VX + j), vxi), dx)));
      // g = k − k L r + c (Δv·d) r², zero where the vertices coincide.
      __m256d g = _mm256_fnmadd_pd(_mm256_mul_pd(k, _mm256_loadu_pd(RL + e)), r, k);
      g = _mm256_fmadd_pd(_mm256_mul_pd(c, dvd), _mm256_mul_pd(r, r), g);
      g = _mm256_and_pd(g, ok);
      const __m256d fx = _mm256_mul_pd(g, dx), fy = _mm256_mul_pd(g, dy), fz = _mm256_mul_pd(g, dz);
      sx = _mm256_add_pd(sx, fx); sy = _mm256_add_pd(sy, fy); sz = _mm256_add_pd(sz, fz);
      _mm256_storeu_pd(FX + j, _mm256_sub_pd(_mm256_loadu_pd(FX + j), fx));
      _mm256_storeu_pd(FY + j, _mm256_sub_pd(_mm256_loadu_pd(FY + j), fy));
      _mm256_storeu_pd(FZ + j, _mm256_sub_pd(_mm256_loadu_pd(FZ + j), fz));
    }
    alignas(32) double hx[4], hy[4], hz[4];
    _mm256_store_pd(hx, sx); _mm256_store_pd(hy, sy); _mm256_store_pd(hz, sz);
    double tx = (hx[0] + hx[1]) + (hx[2] + hx[3]), ty = (hy[0] + hy[1]) + (hy[2] + hy[3]),
           tz = (hz[0] + hz[1]) + (hz[2] + hz[3]);
    for (; j < n; ++j, ++e) {
      const double dx = X[j] - X[i], dy = Y[j] - Y[i], dz = Z[j] - Z[i];
      const double l2 = dx * dx + dy * dy + dz * dz;
      if (!(l2 >= 1e-30)) continue;
      const double r = 1.0 / std::sqrt(l2);
      const double k = Uniform ? KS[0] : KS[e], c = Uniform ? CS[0] : CS[e];
      const double dvd = (VX[j] - VX[i]) * dx + (VY[j] - VY[i]) * dy + (VZ[j] - VZ[i]) * dz;
      const double g = k - k * RL[e] * r + c * dvd * r * r;
      tx += g * dx; ty += g * dy; tz += g * dz;
      FX[j] -= g * dx; FY[j] -= g * dy; FZ[j] -= g * dz;
    }
    FX[i] += tx; FY[i] += ty; FZ[i] += tz;
  }
}

// The same with AVX-512, eight springs at a time and the row's last (n − i − 1) mod 8 springs in
// one masked pass (no scalar tail). 1/l comes from the double-precision estimate rsqrt14 (relative
// error below 2⁻¹⁴) and two Newton steps r ← r (3 − l² r²)/2: the error e becomes ≈ 1.5 e² per
// step, 2⁻¹⁴ → 2⁻²⁷ → 2⁻⁵³, i.e. rounding, the same accuracy as the AVX2 kernel's three steps
// from the 12-bit float estimate.
// GCC 12's AVX-512 intrinsics pass _mm512_undefined_pd() (a self-initialised variable) as the
// unused merge source, which -Wmaybe-uninitialized reports at every use: a false positive.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
// Eight doubles from a (a vertex array at the block's first j), or only the lanes in m (the others
// zero) when the block is not full.
template <bool Full>
__attribute__((target("avx512f"), always_inline)) inline __m512d load8(__mmask8 m, const double* a) noexcept {
  return Full ? _mm512_loadu_pd(a) : _mm512_maskz_loadu_pd(m, a);
}

// The same for a per-spring array from the block's first spring e: consecutive values into the
// lanes of m (contiguous), the first into its lowest lane.
template <bool Full>
__attribute__((target("avx512f"), always_inline)) inline __m512d load8_springs(__mmask8 m, const double* a) noexcept {
  return Full ? _mm512_loadu_pd(a) : _mm512_maskz_expandloadu_pd(m, a);
}

template <bool Uniform, bool Full>
__attribute__((target("avx512f"), always_inline)) inline void all_pairs_avx512_block(
    const double* X, const double* Y, const double* Z, const double* VX, const double* VY, const double* VZ,
    double* FX, double* FY, double* FZ, const double* RL, const double* KS, const double* CS, size_t e, int j,
    __mmask8 m, __m512d xi, __m512d yi, __m512d zi, __m512d vxi, __m512d vyi, __m512d vzi, __m512d& sx,
    __m512d& sy, __m512d& sz) noexcept {
  const __m512d half = _mm512_set1_pd(0.5), three = _mm512_set1_pd(3.0), tiny = _mm512_set1_pd(1e-30);
  const __m512d dx = _mm512_sub_pd(load8<Full>(m, X + j), xi);
  const __m512d dy = _mm512_sub_pd(load8<Full>(m, Y + j), yi);
  const __m512d dz = _mm512_sub_pd(load8<Full>(m, Z + j), zi);
  const __m512d l2 = _mm512_fmadd_pd(dz, dz, _mm512_fmadd_pd(dy, dy, _mm512_mul_pd(dx, dx)));
  const __mmask8 ok = _mm512_mask_cmp_pd_mask(m, l2, tiny, _CMP_GE_OQ);
  const __m512d l2c = _mm512_max_pd(l2, tiny);
  __m512d r = _mm512_rsqrt14_pd(l2c);
  for (int it = 0; it < 2; ++it)
    r = _mm512_mul_pd(_mm512_mul_pd(half, r), _mm512_fnmadd_pd(_mm512_mul_pd(l2c, r), r, three));
  const __m512d k = Uniform ? _mm512_set1_pd(KS[0]) : load8_springs<Full>(m, KS + e);
  const __m512d c = Uniform ? _mm512_set1_pd(CS[0]) : load8_springs<Full>(m, CS + e);
  const __m512d dvd = _mm512_fmadd_pd(
      _mm512_sub_pd(load8<Full>(m, VZ + j), vzi), dz,
      _mm512_fmadd_pd(_mm512_sub_pd(load8<Full>(m, VY + j), vyi), dy, _mm512_mul_pd(_mm512_sub_pd(load8<Full>(m, VX + j), vxi), dx)));
  // g = k − k L r + c (Δv·d) r², zero where the vertices coincide and in the lanes past the row.
  __m512d g = _mm512_fnmadd_pd(_mm512_mul_pd(k, load8_springs<Full>(m, RL + e)), r, k);
  g = _mm512_fmadd_pd(_mm512_mul_pd(c, dvd), _mm512_mul_pd(r, r), g);
  g = _mm512_maskz_mov_pd(ok, g);
  const __m512d fx = _mm512_mul_pd(g, dx), fy = _mm512_mul_pd(g, dy), fz = _mm512_mul_pd(g, dz);
  sx = _mm512_add_pd(sx, fx); sy = _mm512_add_pd(sy, fy); sz = _mm512_add_pd(sz, fz);
  if (Full) {
    _mm512_storeu_pd(FX + j, _mm512_sub_pd(_mm512_loadu_pd(FX + j), fx));
    _mm512_storeu_pd(FY + j, _mm512_sub_pd(_mm512_loadu_pd(FY + j), fy));
    _mm512_storeu_pd(FZ + j, _mm512_sub_pd(_mm512_loadu_pd(FZ + j), fz));
  } else {
    _mm512_mask_storeu_pd(FX + j, m, _mm512_sub_pd(_mm512_maskz_loadu_pd(m, FX + j), fx));
    _mm512_mask_storeu_pd(FY + j, m, _mm512_sub_pd(_mm512_maskz_loadu_pd(m, FY + j), fy));
    _mm512_mask_storeu_pd(FZ + j, m, _mm512_sub_pd(_mm512_maskz_loadu_pd(m, FZ + j), fz));
  }
}

// One row's share of a block of eight columns j: the force g d on each vertex j from row vertex i
// (lanes in m; the others zero), added to the row's sums and to f (the block's total, subtracted
// from f_j by the caller).
struct AllPairsRow {
  __m512d xi, yi, zi, vxi, vyi, vzi, sx, sy, sz;
};

template <bool Uniform>
__attribute__((target("avx512f"), always_inline)) inline void all_pairs_avx512_row(
    __m512d xj, __m512d yj, __m512d zj, __m512d vxj, __m512d vyj, __m512d vzj, __mmask8 m, __m512d rl, __m512d k,
    __m512d c, AllPairsRow& row, __m512d& fx, __m512d& fy, __m512d& fz) noexcept {
  const __m512d half = _mm512_set1_pd(0.5), three = _mm512_set1_pd(3.0), tiny = _mm512_set1_pd(1e-30);
  const __m512d dx = _mm512_sub_pd(xj, row.xi), dy = _mm512_sub_pd(yj, row.yi), dz = _mm512_sub_pd(zj, row.zi);
  const __m512d l2 = _mm512_fmadd_pd(dz, dz, _mm512_fmadd_pd(dy, dy, _mm512_mul_pd(dx, dx)));
  const __mmask8 ok = _mm512_mask_cmp_pd_mask(m, l2, tiny, _CMP_GE_OQ);
  const __m512d l2c = _mm512_max_pd(l2, tiny);
  __m512d r = _mm512_rsqrt14_pd(l2c);
  for (int it = 0; it < 2; ++it)
    r = _mm512_mul_pd(_mm512_mul_pd(half, r), _mm512_fnmadd_pd(_mm512_mul_pd(l2c, r), r, three));
  const __m512d dvd = _mm512_fmadd_pd(
      _mm512_sub_pd(vzj, row.vzi), dz,
      _mm512_fmadd_pd(_mm512_sub_pd(vyj, row.vyi), dy, _mm512_mul_pd(_mm512_sub_pd(vxj, row.vxi), dx)));
  __m512d g = _mm512_fnmadd_pd(_mm512_mul_pd(k, rl), r, k);
  g = _mm512_fmadd_pd(_mm512_mul_pd(c, dvd), _mm512_mul_pd(r, r), g);
  g = _mm512_maskz_mov_pd(ok, g);
  const __m512d gx = _mm512_mul_pd(g, dx), gy = _mm512_mul_pd(g, dy), gz = _mm512_mul_pd(g, dz);
  row.sx = _mm512_add_pd(row.sx, gx); row.sy = _mm512_add_pd(row.sy, gy); row.sz = _mm512_add_pd(row.sz, gz);
  fx = _mm512_add_pd(fx, gx); fy = _mm512_add_pd(fy, gy); fz = _mm512_add_pd(fz, gz);
}

// A row's per-spring value for a block: Mode 0, the row's first block (values from a into the lanes
// of m, which start past lane 0: expand-load); 1, a full block; 2, the row's last (lanes from 0).
template <int Mode>
__attribute__((target("avx512f"), always_inline)) inline __m512d all_pairs_spring_values(__mmask8 m,
                                                                                          const double* a) noexcept {
  if constexpr (Mode == 0) return _mm512_maskz_expandloadu_pd(m, a);
  else if constexpr (Mode == 1) return _mm512_loadu_pd(a);
  else return _mm512_maskz_loadu_pd(m, a);
}

// Two rows i, i + 1 against one aligned block of eight columns j: the vertex values at j are loaded,
// and f_j loaded and stored, once for both. ea, eb: the index of row a's, b's spring at the
// block's first lane it holds (Mode 0) or at lane 0 (Modes 1, 2).
template <bool Uniform, int Mode>
__attribute__((target("avx512f"), always_inline)) inline void all_pairs_avx512_two(
    const double* X, const double* Y, const double* Z, const double* VX, const double* VY, const double* VZ,
    double* FX, double* FY, double* FZ, const double* RL, const double* KS, const double* CS, int j, size_t ea,
    size_t eb, __mmask8 ma, __mmask8 mb, AllPairsRow& a, AllPairsRow& b) noexcept {
  const __mmask8 m = static_cast<__mmask8>(ma | mb);
#define PALPATE_LOADJ(q) (Mode == 1 ? _mm512_load_pd(q) : _mm512_maskz_load_pd(m, q))
  const __m512d xj = PALPATE_LOADJ(X + j), yj = PALPATE_LOADJ(Y + j), zj = PALPATE_LOADJ(Z + j);
  const __m512d vxj = PALPATE_LOADJ(VX + j), vyj = PALPATE_LOADJ(VY + j), vzj = PALPATE_LOADJ(VZ + j);
#undef PALPATE_LOADJ
  __m512d fx = _mm512_setzero_pd(), fy = fx, fz = fx;
  const __m512d ka = Uniform ? _mm512_set1_pd(KS[0]) : all_pairs_spring_values<Mode>(ma, KS + ea);
  const __m512d ca = Uniform ? _mm512_set1_pd(CS[0]) : all_pairs_spring_values<Mode>(ma, CS + ea);
  all_pairs_avx512_row<Uniform>(xj, yj, zj, vxj, vyj, vzj, ma, all_pairs_spring_values<Mode>(ma, RL + ea), ka, ca, a,
                                fx, fy, fz);
  const __m512d kb = Uniform ? _mm512_set1_pd(KS[0]) : all_pairs_spring_values<Mode>(mb, KS + eb);
  const __m512d cb = Uniform ? _mm512_set1_pd(CS[0]) : all_pairs_spring_values<Mode>(mb, CS + eb);
  all_pairs_avx512_row<Uniform>(xj, yj, zj, vxj, vyj, vzj, mb, all_pairs_spring_values<Mode>(mb, RL + eb), kb, cb, b,
                                fx, fy, fz);
  if (Mode == 1) {
    _mm512_store_pd(FX + j, _mm512_sub_pd(_mm512_load_pd(FX + j), fx));
    _mm512_store_pd(FY + j, _mm512_sub_pd(_mm512_load_pd(FY + j), fy));
    _mm512_store_pd(FZ + j, _mm512_sub_pd(_mm512_load_pd(FZ + j), fz));
  } else {
    _mm512_mask_store_pd(FX + j, m, _mm512_sub_pd(_mm512_maskz_load_pd(m, FX + j), fx));
    _mm512_mask_store_pd(FY + j, m, _mm512_sub_pd(_mm512_maskz_load_pd(m, FY + j), fy));
    _mm512_mask_store_pd(FZ + j, m, _mm512_sub_pd(_mm512_maskz_load_pd(m, FZ + j), fz));
  }
}

// p must be 64-byte aligned and N a multiple of 8: every block then starts at a multiple of 8,
// so its loads and stores of x … fz are aligned (unaligned 512-bit accesses split across two cache
// lines, which cost more than the arithmetic); a row's first block is masked below j = i + 1 and
// its rest lengths (per-spring arrays start at the row's first spring, not aligned) expand-loaded.
// Rows go two at a time, sharing each block's loads of x … vz and its load and store of f.
template <bool Uniform>
__attribute__((target("avx512f"))) void all_pairs_avx512(int n, const SpringNetwork& net, double* p, size_t N) noexcept {
  const double *X = p, *Y = p + N, *Z = p + 2 * N, *VX = p + 3 * N, *VY = p + 4 * N, *VZ = p + 5 * N;
  double *FX = p + 6 * N, *FY = p + 7 * N, *FZ = p + 8 * N;
  const double* RL = net.rest_length.data();
  const double* KS = net.stiffness.data();
  const double* CS = net.damping.data();
  size_t e = 0;
  int i = 0;
  // Rows two at a time: row i + 1's springs start n − i − 1 after row i's.
  for (; i + 2 < n; i += 2) {
#define PALPATE_ROW(q)                                                                                      \
  AllPairsRow{_mm512_set1_pd(X[q]),  _mm512_set1_pd(Y[q]),  _mm512_set1_pd(Z[q]),  _mm512_set1_pd(VX[q]), \
              _mm512_set1_pd(VY[q]), _mm512_set1_pd(VZ[q]), _mm512_setzero_pd(),   _mm512_setzero_pd(),   \
              _mm512_setzero_pd()}
    AllPairsRow a = PALPATE_ROW(i), b = PALPATE_ROW(i + 1);
#undef PALPATE_ROW
    const size_t eb = e + static_cast<size_t>(n - i - 1);  // row i + 1's first spring (i + 1, i + 2)
    const int j0 = (i + 1) & ~7;
    const int hi = std::min(8, n - j0);
    auto lanes_from = [hi](int lo) {
      return lo >= 8 ? __mmask8{0} : static_cast<__mmask8>(((1u << hi) - 1) & ~((1u << lo) - 1));
    };
    all_pairs_avx512_two<Uniform, 0>(X, Y, Z, VX, VY, VZ, FX, FY, FZ, RL, KS, CS, j0, e, eb, lanes_from(i + 1 - j0),
                                     lanes_from(i + 2 - j0), a, b);
    // Spring index at lane 0 of the block at j: row i's at e + (j − i − 1), row i + 1's at eb + (j − i − 2).
    int j = j0 + 8;
    for (; j + 8 <= n; j += 8)
      all_pairs_avx512_two<Uniform, 1>(X, Y, Z, VX, VY, VZ, FX, FY, FZ, RL, KS, CS, j,
                                       e + static_cast<size_t>(j - i - 1), eb + static_cast<size_t>(j - i - 2), 0xFF,
                                       0xFF, a, b);
    if (j < n) {
      const __mmask8 m = static_cast<__mmask8>((1u << (n - j)) - 1);
      all_pairs_avx512_two<Uniform, 2>(X, Y, Z, VX, VY, VZ, FX, FY, FZ, RL, KS, CS, j,
                                       e + static_cast<size_t>(j - i - 1), eb + static_cast<size_t>(j - i - 2), m, m,
                                       a, b);
    }
    FX[i] += _mm512_reduce_add_pd(a.sx); FY[i] += _mm512_reduce_add_pd(a.sy); FZ[i] += _mm512_reduce_add_pd(a.sz);
    FX[i + 1] += _mm512_reduce_add_pd(b.sx); FY[i + 1] += _mm512_reduce_add_pd(b.sy);
    FZ[i + 1] += _mm512_reduce_add_pd(b.sz);
    e = eb + static_cast<size_t>(n - i - 2);
  }
  for (; i + 1 < n; ++i) {  // the last row when n − 1 is odd
    const __m512d xi = _mm512_set1_pd(X[i]), yi = _mm512_set1_pd(Y[i]), zi = _mm512_set1_pd(Z[i]);
    const __m512d vxi = _mm512_set1_pd(VX[i]), vyi = _mm512_set1_pd(VY[i]), vzi = _mm512_set1_pd(VZ[i]);
    __m512d sx = _mm512_setzero_pd(), sy = sx, sz = sx;
    // First block: lanes j = i + 1 … within [j0, j0 + 8) and below n.
    const int j0 = (i + 1) & ~7;
    const int lo = i + 1 - j0, hi = std::min(8, n - j0);
    const __mmask8 m0 = static_cast<__mmask8>(((1u << hi) - 1) & ~((1u << lo) - 1));
    all_pairs_avx512_block<Uniform, false>(X, Y, Z, VX, VY, VZ, FX, FY, FZ, RL, KS, CS, e, j0, m0, xi, yi, zi, vxi,
                                           vyi, vzi, sx, sy, sz);
    e += static_cast<size_t>(hi - lo);
    int j = j0 + 8;
    for (; j + 8 <= n; j += 8, e += 8)
      all_pairs_avx512_block<Uniform, true>(X, Y, Z, VX, VY, VZ, FX, FY, FZ, RL, KS, CS, e, j, 0xFF, xi, yi, zi, vxi,
                                            vyi, vzi, sx, sy, sz);
    if (j < n) {
      const int left = n - j;  // 1 … 7
      const __mmask8 m = static_cast<__mmask8>((1u << left) - 1);
      all_pairs_avx512_block<Uniform, false>(X, Y, Z, VX, VY, VZ, FX, FY, FZ, RL, KS, CS, e, j, m, xi, yi, zi, vxi,
                                             vyi, vzi, sx, sy, sz);
      e += static_cast<size_t>(left);
    }
    FX[i] += _mm512_reduce_add_pd(sx); FY[i] += _mm512_reduce_add_pd(sy); FZ[i] += _mm512_reduce_add_pd(sz);
  }
}

#pragma GCC diagnostic pop

// The uniform all-pairs forces in single precision (SpringModelOptions::single_precision), eight
// springs at a time: 1/l from the reciprocal square root estimate and one Newton step (≈ 23 bits).
// p is (9n) floats: x, y, z, vx, vy, vz, fx, fy, fz; RL the (s) rest lengths in float.
__attribute__((target("avx2,fma"))) void all_pairs_avx2_single(int n, const float* RL, float k, float c,
                                                                float* p) noexcept {
  const size_t N = static_cast<size_t>(n);
  const float *X = p, *Y = p + N, *Z = p + 2 * N, *VX = p + 3 * N, *VY = p + 4 * N, *VZ = p + 5 * N;
  float *FX = p + 6 * N, *FY = p + 7 * N, *FZ = p + 8 * N;
  const __m256 half = _mm256_set1_ps(0.5f), three = _mm256_set1_ps(3.0f), tiny = _mm256_set1_ps(1e-30f);
  const __m256 kv = _mm256_set1_ps(k), cv = _mm256_set1_ps(c);
  size_t e = 0;
  for (int i = 0; i + 1 < n; ++i) {
    const __m256 xi = _mm256_set1_ps(X[i]), yi = _mm256_set1_ps(Y[i]), zi = _mm256_set1_ps(Z[i]);
    const __m256 vxi = _mm256_set1_ps(VX[i]), vyi = _mm256_set1_ps(VY[i]), vzi = _mm256_set1_ps(VZ[i]);
    __m256 sx = _mm256_setzero_ps(), sy = sx, sz = sx;
    int j = i + 1;
    for (; j + 8 <= n; j += 8, e += 8) {
      const __m256 dx = _mm256_sub_ps(_mm256_loadu_ps(X + j), xi);
      const __m256 dy = _mm256_sub_ps(_mm256_loadu_ps(Y + j), yi);
      const __m256 dz = _mm256_sub_ps(_mm256_loadu_ps(Z + j), zi);
      const __m256 l2 = _mm256_fmadd_ps(dz, dz, _mm256_fmadd_ps(dy, dy, _mm256_mul_ps(dx, dx)));
      const __m256 ok = _mm256_cmp_ps(l2, tiny, _CMP_GE_OQ);
      const __m256 l2c = _mm256_max_ps(l2, tiny);
      __m256 r = _mm256_rsqrt_ps(l2c);
      r = _mm256_mul_ps(_mm256_mul_ps(half, r), _mm256_fnmadd_ps(_mm256_mul_ps(l2c, r), r, three));
      const __m256 dvd = _mm256_fmadd_ps(
          _mm256_sub_ps(_mm256_loadu_ps(VZ + j), vzi), dz,
          _mm256_fmadd_ps(_mm256_sub_ps(_mm256_loadu_ps(VY + j), vyi), dy,
                          _mm256_mul_ps(_mm256_sub_ps(_mm256_loadu_ps(VX + j), vxi), dx)));
      __m256 g = _mm256_fnmadd_ps(_mm256_mul_ps(kv, _mm256_loadu_ps(RL + e)), r, kv);
      g = _mm256_fmadd_ps(_mm256_mul_ps(cv, dvd), _mm256_mul_ps(r, r), g);
      g = _mm256_and_ps(g, ok);
      const __m256 fx = _mm256_mul_ps(g, dx), fy = _mm256_mul_ps(g, dy), fz = _mm256_mul_ps(g, dz);
      sx = _mm256_add_ps(sx, fx); sy = _mm256_add_ps(sy, fy); sz = _mm256_add_ps(sz, fz);
      _mm256_storeu_ps(FX + j, _mm256_sub_ps(_mm256_loadu_ps(FX + j), fx));
      _mm256_storeu_ps(FY + j, _mm256_sub_ps(_mm256_loadu_ps(FY + j), fy));
      _mm256_storeu_ps(FZ + j, _mm256_sub_ps(_mm256_loadu_ps(FZ + j), fz));
    }
    alignas(32) float hx[8], hy[8], hz[8];
    _mm256_store_ps(hx, sx); _mm256_store_ps(hy, sy); _mm256_store_ps(hz, sz);
    float tx = 0, ty = 0, tz = 0;
    for (int q = 0; q < 8; ++q) {
      tx += hx[q]; ty += hy[q]; tz += hz[q];
    }
    for (; j < n; ++j, ++e) {
      const float dx = X[j] - X[i], dy = Y[j] - Y[i], dz = Z[j] - Z[i];
      const float l2 = dx * dx + dy * dy + dz * dz;
      if (!(l2 >= 1e-30f)) continue;
      const float r = 1.0f / std::sqrt(l2);
      const float dvd = (VX[j] - VX[i]) * dx + (VY[j] - VY[i]) * dy + (VZ[j] - VZ[i]) * dz;
      const float g = k - k * RL[e] * r + c * dvd * r * r;
      tx += g * dx; ty += g * dy; tz += g * dz;
      FX[j] -= g * dx; FY[j] -= g * dy; FZ[j] -= g * dz;
    }
    FX[i] += tx; FY[i] += ty; FZ[i] += tz;
  }
}

void all_pairs_rows(const SpringNetwork& net, bool uniform, double* p, size_t N,
                    spring::SpringKernel kernel = spring::SpringKernel::best) noexcept {
  using spring::SpringKernel;
  const int n = static_cast<int>(net.size());
  const bool best = kernel == SpringKernel::best;
  const bool aligned = reinterpret_cast<std::uintptr_t>(p) % 64 == 0 && N % 8 == 0;
  if ((best || kernel == SpringKernel::avx512) && aligned && has_avx512()) {
    if (uniform) all_pairs_avx512<true>(n, net, p, N);
    else all_pairs_avx512<false>(n, net, p, N);
  } else if (kernel != SpringKernel::scalar && has_avx2_fma()) {
    if (uniform) all_pairs_avx2<true>(n, net, p, N);
    else all_pairs_avx2<false>(n, net, p, N);
  } else {
    if (uniform) all_pairs_portable<true>(n, net, p, N);
    else all_pairs_portable<false>(n, net, p, N);
  }
}

}  // namespace

// The same forces for every pair (the seed paper's topology), on structure-of-arrays copies so the
// inner loop over j > i is contiguous and vectorised. s.soa holds all_pairs_scratch() doubles: x, y,
// z, vx, vy, vz, fx, fy, fz, each n long, all_pairs_stride(n) apart from its first 64-byte boundary; with the model's single-precision rest lengths (and AVX2)
// the float kernel on s.soa_single instead.
void add_all_pair_forces(const SpringModel& model, const RowMat3d& x, const RowMat3d& v, RowMat3d& f,
                         SpringState& s) noexcept {
  const SpringNetwork& net = model.network;
  const bool uniform = model.uniform_stiffness > 0 && model.uniform_damping;
  const Eigen::Index n = x.rows();
  if (!model.solver->rest_length_single.empty() && has_avx2_fma()) {
    using ArrF = Eigen::Map<Eigen::ArrayXf>;
    float* q = s.soa_single.data();
    ArrF X(q, n), Y(q + n, n), Z(q + 2 * n, n), VX(q + 3 * n, n), VY(q + 4 * n, n), VZ(q + 5 * n, n);
    ArrF FX(q + 6 * n, n), FY(q + 7 * n, n), FZ(q + 8 * n, n);
    X = x.col(0).array().cast<float>(); Y = x.col(1).array().cast<float>(); Z = x.col(2).array().cast<float>();
    VX = v.col(0).array().cast<float>(); VY = v.col(1).array().cast<float>(); VZ = v.col(2).array().cast<float>();
    FX.setZero(); FY.setZero(); FZ.setZero();
    all_pairs_avx2_single(static_cast<int>(n), model.solver->rest_length_single.data(), static_cast<float>(net.stiffness[0]),
                          static_cast<float>(net.damping[0]), q);
    f.col(0).array() += FX.cast<double>(); f.col(1).array() += FY.cast<double>(); f.col(2).array() += FZ.cast<double>();
    return;
  }
  using Arr = Eigen::Map<Eigen::ArrayXd>;
  const Eigen::Index N = static_cast<Eigen::Index>(spring::all_pairs_stride(static_cast<size_t>(n)));
  double* p = spring::align64(s.soa.data());
  Arr X(p, n), Y(p + N, n), Z(p + 2 * N, n), VX(p + 3 * N, n), VY(p + 4 * N, n), VZ(p + 5 * N, n);
  Arr FX(p + 6 * N, n), FY(p + 7 * N, n), FZ(p + 8 * N, n);
  X = x.col(0).array(); Y = x.col(1).array(); Z = x.col(2).array();
  VX = v.col(0).array(); VY = v.col(1).array(); VZ = v.col(2).array();
  FX.setZero(); FY.setZero(); FZ.setZero();
  all_pairs_rows(net, uniform, p, static_cast<size_t>(N));
  f.col(0).array() += FX; f.col(1).array() += FY; f.col(2).array() += FZ;
}

void add_all_pair_forces_soa(const SpringNetwork& net, bool uniform, double* p, size_t stride,
                             SpringKernel kernel) noexcept {
  all_pairs_rows(net, uniform, p, stride, kernel);
}

size_t all_pairs_stride(size_t n) noexcept { return (n + 7) / 8 * 8; }

size_t all_pairs_scratch(size_t n) noexcept { return 9 * all_pairs_stride(n) + 8; }

}  // namespace palpate::spring
