// step.cpp — the per-tick kernels of the mass-spring model: forces, the predictor solve
// (Desbrun, Schröder & Barr 1999), the angular-momentum correction, tool contact and grasping,
// and the exact backward-Euler reference (Newton).
#include <palpate/spring.h>

#include "core/triangle.h"
#include "tissue/spring/forces.h"
#include "tissue/spring/solve.h"

#include <Eigen/SparseCholesky>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#include <immintrin.h>
#include <limits>

namespace palpate {

namespace {

using RowMatXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// Internal spring forces (Hooke about the rest length plus a damper along the spring):
//   f_i += [k_e (l − L_e) + c_e (v_j − v_i)·u] u,  f_j −= the same,  u = (x_j − x_i)/l.
// x, v, f are (n x 3); f is added to.
void add_spring_forces(const SpringNetwork& net, const RowMat3d& x, const RowMat3d& v, RowMat3d& f) noexcept {
  const size_t s = net.springs.size();
  for (size_t e = 0; e < s; ++e) {
    const int i = net.springs[e][0], j = net.springs[e][1];
    const double dx = x(j, 0) - x(i, 0), dy = x(j, 1) - x(i, 1), dz = x(j, 2) - x(i, 2);
    const double l = std::sqrt(dx * dx + dy * dy + dz * dz);
    if (!(l > 0)) continue;
    const double inv_l = 1.0 / l;
    const double dvu = ((v(j, 0) - v(i, 0)) * dx + (v(j, 1) - v(i, 1)) * dy + (v(j, 2) - v(i, 2)) * dz) * inv_l;
    const double g = (net.stiffness[e] * (l - net.rest_length[e]) + net.damping[e] * dvu) * inv_l;
    f(i, 0) += g * dx; f(i, 1) += g * dy; f(i, 2) += g * dz;
    f(j, 0) -= g * dx; f(j, 1) -= g * dy; f(j, 2) -= g * dz;
  }
  if (!net.tets.empty() && net.volume_modulus > 0) spring::add_volume_forces(net, x.data(), 3, f.data(), 3);
}

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

using spring::has_avx2_fma;

using spring::has_avx512;

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

// The same forces for every pair (the seed paper's topology), on structure-of-arrays copies so the
// inner loop over j > i is contiguous and vectorised. s.soa holds all_pairs_scratch() doubles: x, y,
// z, vx, vy, vz, fx, fy, fz, each n long, all_pairs_stride(n) apart from its first 64-byte boundary; with the model's single-precision rest lengths (and AVX2)
// the float kernel on s.soa_single instead.
void add_all_pair_forces(const SpringModel& model, const RowMat3d& x, const RowMat3d& v, RowMat3d& f,
                         SpringState& s) noexcept {
  const SpringNetwork& net = model.network;
  const bool uniform = model.uniform_stiffness > 0 && model.uniform_damping;
  const Eigen::Index n = x.rows();
  if (!model.rest_length_single.empty() && has_avx2_fma()) {
    using ArrF = Eigen::Map<Eigen::ArrayXf>;
    float* q = s.soa_single.data();
    ArrF X(q, n), Y(q + n, n), Z(q + 2 * n, n), VX(q + 3 * n, n), VY(q + 4 * n, n), VZ(q + 5 * n, n);
    ArrF FX(q + 6 * n, n), FY(q + 7 * n, n), FZ(q + 8 * n, n);
    X = x.col(0).array().cast<float>(); Y = x.col(1).array().cast<float>(); Z = x.col(2).array().cast<float>();
    VX = v.col(0).array().cast<float>(); VY = v.col(1).array().cast<float>(); VZ = v.col(2).array().cast<float>();
    FX.setZero(); FY.setZero(); FZ.setZero();
    all_pairs_avx2_single(static_cast<int>(n), model.rest_length_single.data(), static_cast<float>(net.stiffness[0]),
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

Vec3 gravity_vector(const SpringModelOptions& o) {
  return o.gravity ? Vec3(0, -o.gravity_acceleration, 0) : Vec3::Zero();
}

// Forces from the tool, added to f (n x 3), and their reaction on the tool.
// Probe: a penalty on every vertex inside the sphere (tip, radius), f = k_c (r − |x − tip|) n̂ minus a
// normal damper, k_c clamped to max_contact_stiffness so the explicit penalty stays stable.
// Grasp: vertices within radius + grasp_radius when the grasp starts follow the tool on springs; let
// go, the springs fade out over grasp_release_time (a grasped organ's pull does not vanish in a tick).
Vec3 add_tool_forces(const SpringModel& model, SpringState& s, const ToolState& tool, RowMat3d& f) noexcept {
  const SpringModelOptions& o = model.options;
  const Eigen::Index n = s.x.rows();
  Vec3 on_tool = Vec3::Zero();
  s.contacts = 0;
  const double r = std::max(tool.radius, 0.0);
  if (tool.grasp && !s.grasping) {
    // Grab the nearest vertices within reach (at most kMaxGrasped), nearest first.
    s.grasped_count = 0;
    const double reach = r + o.grasp_radius;
    for (Eigen::Index i = 0; i < n; ++i) {
      if (model.anchored[static_cast<size_t>(i)]) continue;
      const double d = (s.x.row(i).transpose() - tool.tip).norm();
      if (d > reach) continue;
      int slot = s.grasped_count;
      if (slot == SpringState::kMaxGrasped) {
        // Replace the farthest if this one is nearer.
        int far = 0;
        double far_d = -1;
        for (int k = 0; k < slot; ++k) {
          const double dk = (s.x.row(s.grasped[static_cast<size_t>(k)]).transpose() - tool.tip).norm();
          if (dk > far_d) { far_d = dk; far = k; }
        }
        if (far_d <= d) continue;
        slot = far;
      } else {
        ++s.grasped_count;
      }
      s.grasped[static_cast<size_t>(slot)] = static_cast<int>(i);
      s.grasp_offset[static_cast<size_t>(slot)] = s.x.row(i).transpose() - tool.tip;
    }
    s.grasping = true;
    s.grasp_hold = 1;
  } else if (!tool.grasp && s.grasped_count > 0) {
    s.grasping = false;
    s.grasp_hold = o.grasp_release_time > 0 ? s.grasp_hold - step_length(o) / o.grasp_release_time : 0.0;
    if (!(s.grasp_hold > 0)) {
      s.grasp_hold = 0;
      s.grasped_count = 0;
    }
  } else if (!tool.grasp) {
    s.grasping = false;
  }
  // Faded by smoothstep of the time left (no kink in the force where the release starts or ends).
  const double hold = s.grasp_hold * s.grasp_hold * (3.0 - 2.0 * s.grasp_hold);
  for (int k = 0; k < s.grasped_count; ++k) {
    const int i = s.grasped[static_cast<size_t>(k)];
    const double kg = hold * std::min(o.grasp_stiffness, model.max_contact_stiffness[static_cast<size_t>(i)]);
    const Vec3 target = tool.tip + s.grasp_offset[static_cast<size_t>(k)];
    const Vec3 fi = kg * (target - s.x.row(i).transpose());
    f.row(i) += fi.transpose();
    on_tool -= fi;
  }
  if (o.contact == SpringContact::surface) {
    // The contact force the last step ended with acts through this one (surface_contact corrects it
    // after the solve).
    s.carried_on_tool.setZero();
    for (int k = 0; k < s.contact_vertex_count; ++k) {
      const int i = s.contact_vertex[static_cast<size_t>(k)];
      f.row(i) += s.contact_load[static_cast<size_t>(k)].transpose();
      s.carried_on_tool -= s.contact_load[static_cast<size_t>(k)];
    }
    return on_tool + s.carried_on_tool;
  }
  if (r <= 0 || o.contact_stiffness <= 0) return on_tool;
  const double r2 = r * r;
  for (Eigen::Index i = 0; i < n; ++i) {
    const Vec3 d = s.x.row(i).transpose() - tool.tip;
    const double d2 = d.squaredNorm();
    if (d2 >= r2 || model.anchored[static_cast<size_t>(i)]) continue;
    const double dist = std::sqrt(d2);
    const Vec3 normal = dist > 1e-12 * r ? Vec3(d / dist) : Vec3(-tool.axis.normalized());
    const double kc = std::min(o.contact_stiffness, model.max_contact_stiffness[static_cast<size_t>(i)]);
    const double approach = (s.v.row(i).transpose() - tool.velocity).dot(normal);
    const double magnitude = std::max(0.0, kc * (r - dist) - o.contact_damping * approach);
    const Vec3 fi = magnitude * normal;
    f.row(i) += fi.transpose();
    on_tool -= fi;
    ++s.contacts;
  }
  return on_tool;
}

// External and point-damping-free forces: gravity, then the tool. Returns the force on the tool.
Vec3 external_forces(const SpringModel& model, SpringState& s, const ToolState* tool, RowMat3d& f) noexcept {
  const Vec3 g = gravity_vector(model.options);
  const Eigen::Index n = s.x.rows();
  for (Eigen::Index i = 0; i < n; ++i) f.row(i) = (model.network.mass[static_cast<size_t>(i)] * g).transpose();
  return tool ? add_tool_forces(model, s, *tool, f) : Vec3::Zero();
}

// The post-step correction for the dropped non-linear part (DS99 §4.3): spring forces are
// central, so they must not change the angular momentum; the predictor's transverse stiffness
// (K_L ⊗ I3 instead of the true k uuᵀ) does. The spurious change
//   δL = Σ m_i x_i × Δv_i − h (τ_ext + Σ x_i × (−γ v_i⁺))
// (τ_ext = Σ x_i × f_ext,i, about the origin) is removed by a rigid angular velocity ω = I⁺ δL,
// I the inertia tensor about the centre of mass c: Δv_i −= ω × (x_i − c). Linear momentum is
// unchanged since Σ m_i (x_i − c) = 0. Free bodies only: anchors exert torques implicitly.
void correct_angular_momentum(const SpringModel& model, const SpringState& s, const Vec3& ext_torque,
                              RowMat3d& dv) noexcept {
  const double h = model.options.dt;
  const double gamma = model.options.point_damping;
  const Eigen::Index n = s.x.rows();
  Vec3 c = Vec3::Zero();
  for (Eigen::Index i = 0; i < n; ++i) c += model.network.mass[static_cast<size_t>(i)] * s.x.row(i).transpose();
  c /= model.total_mass;
  Vec3 delta = -h * ext_torque;
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();
  for (Eigen::Index i = 0; i < n; ++i) {
    const double m = model.network.mass[static_cast<size_t>(i)];
    const Vec3 xi = s.x.row(i).transpose();
    const Vec3 dvi = dv.row(i).transpose();
    const Vec3 v_new = s.v.row(i).transpose() + dvi;
    delta += xi.cross(m * dvi + h * gamma * v_new);
    const Vec3 r = xi - c;
    inertia += m * (r.squaredNorm() * Eigen::Matrix3d::Identity() - r * r.transpose());
  }
  // Pseudo-inverse: a collinear body has no inertia about its own axis.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(inertia);
  const double top = eig.eigenvalues().maxCoeff();
  if (!(top > 0)) return;
  Vec3 w = eig.eigenvectors().transpose() * delta;
  for (int k = 0; k < 3; ++k) w[k] = eig.eigenvalues()[k] > 1e-12 * top ? w[k] / eig.eigenvalues()[k] : 0.0;
  const Vec3 omega = eig.eigenvectors() * w;
  for (Eigen::Index i = 0; i < n; ++i) dv.row(i) -= omega.cross(s.x.row(i).transpose() - c).transpose();
}

// Force of the organ on its anchors: everything acting on the anchored vertices (springs, their
// weight). f_all is the total force (n x 3) at the start of the step.
Vec3 anchor_load(const SpringModel& model, const RowMat3d& f_all) noexcept {
  Vec3 sum = Vec3::Zero();
  for (int a : model.network.anchors) sum += f_all.row(a).transpose();
  return sum;
}

bool finite_and_slow(const SpringModel& model, const SpringState& s) noexcept {
  const double vmax2 = model.options.max_speed * model.options.max_speed;
  const Eigen::Index n = s.x.rows();
  for (Eigen::Index i = 0; i < n; ++i) {
    const double v2 = s.v.row(i).squaredNorm();
    if (!(v2 <= vmax2) || !std::isfinite(s.x(i, 0) + s.x(i, 1) + s.x(i, 2))) return false;
  }
  return true;
}

// Closest points of the segments [p1, q1] and [p2, q2] (Ericson 2005, §5.1.9): their parameters
// s, t in [0, 1]. Parallel segments have a set of closest pairs; then s is the middle of the part of
// [p1, q1] that faces [p2, q2] (a shaft lying along an edge is carried at the middle of the overlap).
void closest_on_segments(const Vec3& p1, const Vec3& q1, const Vec3& p2, const Vec3& q2, double& s,
                         double& t) noexcept {
  const Vec3 d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  if (!(a > 0) && !(e > 0)) { s = t = 0; return; }
  if (!(a > 0)) { s = 0; t = std::clamp(f / e, 0.0, 1.0); return; }
  const double c = d1.dot(r);
  if (!(e > 0)) { t = 0; s = std::clamp(-c / a, 0.0, 1.0); return; }
  const double b = d1.dot(d2), denom = a * e - b * b;
  if (denom > 1e-12 * a * e) {
    s = std::clamp((b * f - c * e) / denom, 0.0, 1.0);
  } else {  // parallel: the middle of [p1, q1]'s part over [p2, q2]
    const double s0 = std::clamp(-c / a, 0.0, 1.0), s1 = std::clamp((b - c) / a, 0.0, 1.0);
    s = 0.5 * (s0 + s1);
  }
  t = (b * s + f) / e;
  if (t < 0) { t = 0; s = std::clamp(-c / a, 0.0, 1.0); }
  else if (t > 1) { t = 1; s = std::clamp((b - c) / a, 0.0, 1.0); }
}

// The closest points of the segment [p0, p1] (a needle's shaft) and the triangle (a, b, c): q on the
// segment, the point on the triangle returned with its barycentric weights w; the distance is
// |q − returned|. Candidates (Ericson 2005, §5.1.10): each end against the triangle, the segment
// against each edge; a segment through the triangle is at distance 0 (q = the crossing). A shaft
// lying parallel to the face (within 1e-3 rad) over it has a set of closest pairs: it is then carried
// at the middle of its part over the triangle (clipped against the three edges), so that a needle laid
// on a face loads it symmetrically, not at whichever end round-off picks.
Vec3 closest_segment_triangle(const Vec3& p0, const Vec3& p1, const Vec3& a, const Vec3& b, const Vec3& c, Vec3& q,
                              Vec3& w) noexcept {
  const Vec3 d = p1 - p0, nf = (b - a).cross(c - a);
  const double len2 = d.squaredNorm(), area2 = nf.squaredNorm();
  if (area2 > 0 && len2 > 0) {
    const double h0 = nf.dot(p0 - a), h1 = nf.dot(p1 - a);
    const Vec3 edge[3][2] = {{a, b}, {b, c}, {c, a}};
    if ((h0 < 0 && h1 > 0) || (h0 > 0 && h1 < 0)) {  // crosses the plane: inside the triangle?
      const Vec3 x = p0 + (h0 / (h0 - h1)) * d;
      bool in = true;
      for (const auto& E : edge) in = in && nf.dot((E[1] - E[0]).cross(x - E[0])) >= 0;
      if (in) {
        q = x;
        return closest_on_triangle(x, a, b, c, w);
      }
    }
    if (std::abs(nf.dot(d)) <= 1e-3 * std::sqrt(area2 * len2)) {
      // Parallel to the face: the part of the segment whose projection lies inside (Cyrus–Beck).
      double lo = 0, hi = 1;
      for (const auto& E : edge) {
        const Vec3 m = nf.cross(E[1] - E[0]);  // in the plane, pointing into the triangle
        const double g0 = m.dot(p0 - E[0]), gd = m.dot(d);
        if (gd > 0) lo = std::max(lo, -g0 / gd);
        else if (gd < 0) hi = std::min(hi, -g0 / gd);
        else if (g0 < 0) hi = -1;
      }
      if (lo <= hi) {
        q = p0 + (0.5 * (lo + hi)) * d;
        return closest_on_triangle(q, a, b, c, w);
      }
    }
  }
  Vec3 wk;
  Vec3 best = closest_on_triangle(p0, a, b, c, w);
  q = p0;
  double best_d2 = (p0 - best).squaredNorm();
  {
    const Vec3 pk = closest_on_triangle(p1, a, b, c, wk);
    const double d2 = (p1 - pk).squaredNorm();
    if (d2 < best_d2) { best_d2 = d2; best = pk; q = p1; w = wk; }
  }
  const Vec3 corner[3] = {a, b, c};
  for (int k = 0; k < 3; ++k) {
    const Vec3 &e0 = corner[k], &e1 = corner[(k + 1) % 3];
    double s, t;
    closest_on_segments(p0, p1, e0, e1, s, t);
    const Vec3 qs = p0 + s * d, pe = e0 + t * (e1 - e0);
    const double d2 = (qs - pe).squaredNorm();
    if (d2 < best_d2) {
      best_d2 = d2;
      best = pe;
      q = qs;
      w.setZero();
      w[k] = 1 - t;
      w[(k + 1) % 3] = t;
    }
  }
  return best;
}

// Surface contact, after the solve (docs/models/mass-spring.md, "Contact"). The tool's sphere
// (centre c, radius r) against the surface triangles at the new positions: each triangle t whose
// closest point p_t lies within r, on its outer side, is pressed with weight φ_t = r − |c − p_t|
// along n_t = (c − p_t)/|c − p_t| (weights ω_t ∝ φ_t with |Σ ω_t n_t| = 1); a centre inside a closed surface presses only the nearest
// triangle, by r + its distance, along its outward normal, so the tool is pushed out. The depth
// Φ = max φ_t. The force F on the tool is a penalty k_c Φ, made stable whatever the vertex masses
// by solving for it implicitly each tick against the contact vertices' compliance
// c = Σ_i |g_i|² / (m_i + hγ), g_i = Σ_t (φ_t / Σφ) w_t,i n_t (an upper bound of the true one, since
// A ≥ M + hγ: the update under-relaxes, never overshoots):
//   F⁺ = max(0, k_c (Φ + h² c F) / (1 + k_c h² c)),
// the step having already carried F. The difference F⁺ − F moves the contact vertices now
// (Δv_i = −h (F⁺ − F) g_i / (m_i + hγ)) and acts as −F⁺ g_i in the next step. At rest F⁺ = F, so
// F = k_c Φ: a penalty of stiffness k_c in series with the tissue, independent of the masses.
// A needle (tool.needle, tool.length > 0) is a capsule: each triangle is pressed from the shaft's
// point closest to it (closest_segment_triangle) instead of the centre, and once in contact a
// triangle the shaft has been pushed behind presses it by r plus that distance along its normal.
void surface_contact(const SpringModel& model, SpringState& s, const ToolState& tool) noexcept {
  const SpringNetwork& net = model.network;
  const double h = model.options.dt, kc = model.options.contact_stiffness;
  const double r = std::max(tool.radius, 0.0);
  const double f_prev = s.contact_vertex_count > 0 ? s.contact_force : 0.0;
  // Whether the centre may be inside a closed surface deeper than r (then no triangle is within r
  // and the nearest one decides): only after a contact (the tool went in through the surface, or
  // faster than r per step) or on the first step (a tool that starts inside). Otherwise the pass
  // over the triangles is a bounding-box test each.
  const bool search_inside = model.closed_surface && (s.contact_vertex_count > 0 || s.time == 0);
  const double depth_prev = s.contact_vertex_count > 0 ? s.contact_depth : 0.0;
  s.tool_force -= s.carried_on_tool;  // replaced below by the corrected force
  s.carried_on_tool.setZero();
  s.contact_vertex_count = 0;
  s.contact_force = 0;
  s.contact_depth = 0;
  s.contacts = 0;
  if (r <= 0 || kc <= 0 || net.triangles.empty()) return;
  const Vec3 c = tool.tip;
  // A needle's shaft: the segment [tip − length·axis, tip] of radius r (a capsule), each triangle
  // pressed from the shaft's point closest to it. A sphere (or a needle of no length): the tip only.
  const double axis_norm = tool.axis.norm();
  const bool shaft = tool.needle && tool.length > 0 && axis_norm > 0;
  const Vec3 back = shaft ? Vec3(c - (tool.length / axis_norm) * tool.axis) : c;
  const Vec3 tool_lo = c.cwiseMin(back), tool_hi = c.cwiseMax(back);
  // A shaft that was in contact may have been pushed behind the faces it presses (the depth is not
  // bounded by a thin needle's radius, as the tip's is by the inside test): a triangle whose plane
  // the shaft's closest point is behind, over the triangle, by less than the last depth plus r,
  // still presses it, by r plus that distance, along its outward normal. Only on a closed surface
  // (inside is defined), after a contact (it went in through the surface).
  const double behind = shaft && model.closed_surface && depth_prev > 0 ? depth_prev + r : 0.0;
  const double reach = r + behind;
  // Triangles within reach of the tool (the deepest kept when there are more than fit), and the
  // nearest triangle to the tip overall when the tip may be inside.
  struct Hit {
    int tri;
    double dist;   // m, from the tool's point to the triangle's
    Vec3 w, p, q;  // barycentric weights and point on the triangle; the tool's point closest to it
    double phi;    // m, the depth it is pressed by
    Vec3 n;        // its direction (unit), out of the organ
    bool behind = false;  // a shaft pushed behind the face: the whole triangle pressed by phi along n
  };
  std::array<Hit, SpringState::kMaxContactTriangles> hits;
  int nhits = 0;
  int nearest = -1;
  double nearest_d2 = std::numeric_limits<double>::infinity(), nearest_cos = 0;
  Vec3 nearest_w = Vec3::Zero(), nearest_p = Vec3::Zero();
  auto visit = [&](size_t t) {
    const auto& T = net.triangles[t];
    const Vec3 a = s.x.row(T[0]).transpose(), b = s.x.row(T[1]).transpose(), q = s.x.row(T[2]).transpose();
    // Bounding-box distance first: most triangles are far.
    const Vec3 lo = a.cwiseMin(b).cwiseMin(q), hi = a.cwiseMax(b).cwiseMax(q);
    const double box_d2 = (c.cwiseMax(lo).cwiseMin(hi) - c).squaredNorm();
    const double tool_box_d2 =
        shaft ? (lo - tool_hi).cwiseMax(tool_lo - hi).cwiseMax(0.0).squaredNorm() : box_d2;
    if (tool_box_d2 >= reach * reach && (!search_inside || box_d2 > nearest_d2)) return;
    Vec3 w;
    const Vec3 p = closest_on_triangle(c, a, b, q, w);
    const double d2 = (c - p).squaredNorm();
    if (model.closed_surface) {
      // Nearest triangle; at a shared edge or corner (equal distances), the one whose plane the
      // centre is most clearly in front of or behind decides the side (its |cos| is largest).
      const Vec3 nf = (b - a).cross(q - a);
      const double len = nf.norm() * std::sqrt(d2);
      const double cosine = len > 0 ? (c - p).dot(nf) / len : 0.0;
      const bool tie = std::abs(d2 - nearest_d2) <= 1e-12 * std::max(d2, 1e-30);
      if (d2 < nearest_d2 && !tie) {
        nearest = static_cast<int>(t); nearest_d2 = d2; nearest_cos = cosine; nearest_w = w; nearest_p = p;
      } else if (tie && std::abs(cosine) > std::abs(nearest_cos)) {
        nearest = static_cast<int>(t); nearest_cos = cosine; nearest_w = w; nearest_p = p;
      }
    }
    Hit hit{static_cast<int>(t), 0.0, w, p, c, 0.0, Vec3::Zero(), false};
    if (shaft) {
      if (tool_box_d2 >= reach * reach) return;
      hit.p = closest_segment_triangle(back, c, a, b, q, hit.q, hit.w);
      hit.dist = (hit.q - hit.p).norm();
      const Vec3 nf = (b - a).cross(q - a);
      const double side = (hit.q - hit.p).dot(nf);
      const bool over = hit.w.minCoeff() > 0;  // the shaft's point is over the triangle, not past an edge
      if (hit.dist < r && side > 0) {
        hit.phi = r - hit.dist;
        hit.n = (hit.q - hit.p) / hit.dist;
      } else if (behind > 0 && over && hit.dist < behind && side <= 0 && nf.squaredNorm() > 0) {
        hit.phi = r + hit.dist;  // behind the face (or through it): pushed out along its normal
        hit.behind = true;
        hit.n = nf.normalized();
      } else {
        return;
      }
    } else {
      if (d2 >= r * r) return;
      hit.dist = std::sqrt(d2);
      hit.phi = r - hit.dist;
    }
    if (nhits < SpringState::kMaxContactTriangles) {
      hits[static_cast<size_t>(nhits++)] = hit;
    } else {
      int far = 0;
      for (int k = 1; k < nhits; ++k) if (hits[static_cast<size_t>(k)].phi < hits[static_cast<size_t>(far)].phi) far = k;
      if (hit.phi > hits[static_cast<size_t>(far)].phi) hits[static_cast<size_t>(far)] = hit;
    }
    };
  // The cull: each surface vertex's outcode against the tool's box grown by reach (a bit per side per
  // axis); a triangle whose three corners share a bit lies wholly outside that box, so its bounding
  // box is farther than reach from the tool (it can be no hit) and from the tip. Those are visited
  // only when the nearest triangle is wanted and none within reach was found among the others.
  const size_t n_vertices = static_cast<size_t>(s.x.rows());
  const bool cull = s.contact_code.size() == n_vertices && !model.surface_vertices.empty();
  if (cull) {
    const Vec3 lo = tool_lo - Vec3::Constant(reach), hi = tool_hi + Vec3::Constant(reach);
    const double* xd = s.x.data();
    for (const int v : model.surface_vertices) {
      const double* p = xd + 3 * static_cast<size_t>(v);
      s.contact_code[static_cast<size_t>(v)] = static_cast<std::uint8_t>(
          (p[0] < lo.x()) | (p[0] > hi.x()) << 1 | (p[1] < lo.y()) << 2 | (p[1] > hi.y()) << 3 |
          (p[2] < lo.z()) << 4 | (p[2] > hi.z()) << 5);
    }
    const std::uint8_t* code = s.contact_code.data();
    const auto outside = [&](size_t t) {
      const auto& T = net.triangles[t];
      return (code[T[0]] & code[T[1]] & code[T[2]]) != 0;
    };
    for (size_t t = 0; t < net.triangles.size(); ++t)
      if (!outside(t)) visit(t);
    if (search_inside && !(nearest_d2 < reach * reach))
      for (size_t t = 0; t < net.triangles.size(); ++t)
        if (outside(t)) visit(t);
  } else {
    for (size_t t = 0; t < net.triangles.size(); ++t) visit(t);
  }
  // (A shaft that presses triangles is carried by them even when its tip is inside.)
  const bool inside = model.closed_surface && nearest >= 0 && nearest_cos < 0 &&
                      (search_inside || nearest_d2 < r * r) && !(shaft && nhits > 0);
  // Contact vertices and their direction sums g_i (up to kMaxContactVertices).
  std::array<Vec3, SpringState::kMaxContactVertices> g;
  const bool slots = s.contact_slot.size() == static_cast<size_t>(s.x.rows());
  auto add = [&](int vertex, const Vec3& gi) {
    if (slots) {
      int& slot = s.contact_slot[static_cast<size_t>(vertex)];
      if (slot >= 0) { g[static_cast<size_t>(slot)] += gi; return; }
      if (s.contact_vertex_count == SpringState::kMaxContactVertices) return;
      slot = s.contact_vertex_count;
    } else {
      for (int k = 0; k < s.contact_vertex_count; ++k)
        if (s.contact_vertex[static_cast<size_t>(k)] == vertex) { g[static_cast<size_t>(k)] += gi; return; }
      if (s.contact_vertex_count == SpringState::kMaxContactVertices) return;
    }
    s.contact_vertex[static_cast<size_t>(s.contact_vertex_count)] = vertex;
    g[static_cast<size_t>(s.contact_vertex_count++)] = gi;
  };
  auto clear_slots = [&] {
    if (slots)
      for (int k = 0; k < s.contact_vertex_count; ++k) s.contact_slot[static_cast<size_t>(s.contact_vertex[static_cast<size_t>(k)])] = -1;
  };
  // The tool's pressure over the part of triangle t inside it (docs/models/mass-spring.md, Contact):
  // p ∝ the local depth r − |q − x| along (q − x)/|q − x|, q the tool's point nearest x (the centre
  // of a sphere; on a needle's shaft, the segment's point nearest x), integrated at the centroids of
  // an N × N split of the triangle (N = ⌈6 × its longest rest edge / r⌉, 2 to 6) and shared by each
  // point's barycentric weights. Added to g unscaled; returns the triangle's resultant. Each point
  // joins with zero depth, so the load moves continuously as the patch grows over the mesh.
  const Vec3 axis_seg = c - back;
  const double axis_len2 = axis_seg.squaredNorm();
  auto rest_edge_of = [&](int tri) {
    const auto& T = net.triangles[static_cast<size_t>(tri)];
    return std::sqrt(std::max({(net.rest.row(T[1]) - net.rest.row(T[0])).squaredNorm(),
                               (net.rest.row(T[2]) - net.rest.row(T[1])).squaredNorm(),
                               (net.rest.row(T[0]) - net.rest.row(T[2])).squaredNorm()}));
  };
  auto spread_over_area = [&](int tri) -> Vec3 {
    const auto& T = net.triangles[static_cast<size_t>(tri)];
    const Vec3 a = s.x.row(T[0]).transpose(), b = s.x.row(T[1]).transpose(), q = s.x.row(T[2]).transpose();
    const double rest_edge = rest_edge_of(tri);
    const int N = static_cast<int>(std::clamp(std::ceil(6.0 * rest_edge / r), 2.0, 6.0));
    const double dA = 0.5 * (b - a).cross(q - a).norm() / (N * N);
    Vec3 corner[3] = {Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
    Vec3 total = Vec3::Zero();
    const double r2 = r * r;
    for (int i = 0; i < N; ++i)
      for (int j = 0; i + j < N; ++j)
        for (int down = 0; down < 2; ++down) {
          if (down && i + j > N - 2) break;
          const double u = (i + (down ? 2.0 : 1.0) / 3.0) / N, v = (j + (down ? 2.0 : 1.0) / 3.0) / N;
          const double w0 = 1.0 - u - v;
          const Vec3 x = w0 * a + u * b + v * q;
          Vec3 d = c - x;
          if (axis_len2 > 0) {
            const double along = std::clamp((x - back).dot(axis_seg) / axis_len2, 0.0, 1.0);
            if (along < 1.0) d = back + along * axis_seg - x;
          }
          const double dist2 = d.squaredNorm();
          if (dist2 >= r2) continue;
          const double dist = std::sqrt(dist2);
          if (!(dist > 1e-12 * r)) continue;
          const Vec3 load = ((r - dist) * dA / dist) * d;
          corner[0] += w0 * load;
          corner[1] += u * load;
          corner[2] += v * load;
          total += load;
        }
    for (int k = 0; k < 3; ++k)
      if (corner[k].squaredNorm() > 0) add(T[static_cast<size_t>(k)], corner[k]);
    return total;
  };
  double depth = 0;
  if (inside) {
    const auto& T = net.triangles[static_cast<size_t>(nearest)];
    const Vec3 a = s.x.row(T[0]).transpose(), b = s.x.row(T[1]).transpose(), q = s.x.row(T[2]).transpose();
    const Vec3 n = (b - a).cross(q - a).normalized();  // outward
    depth = r + std::sqrt(nearest_d2);
    for (int k = 0; k < 3; ++k) add(T[static_cast<size_t>(k)], nearest_w[k] * n);
    s.contacts = 1;
  } else {
    double sum = 0;
    int used = 0;
    for (int k = 0; k < nhits; ++k) {
      Hit hit = hits[static_cast<size_t>(k)];
      if (!shaft) {
        if (!(hit.dist > 1e-12 * r)) continue;  // the centre on the surface: no direction (rare; next tick)
        if (model.closed_surface) {  // only triangles the tool is in front of (not the back of a thin part)
          const auto& T = net.triangles[static_cast<size_t>(hit.tri)];
          const Vec3 nf = (s.x.row(T[1]) - s.x.row(T[0])).transpose().cross((s.x.row(T[2]) - s.x.row(T[0])).transpose());
          if ((hit.q - hit.p).dot(nf) < 0) continue;
        }
        hit.n = (hit.q - hit.p) / hit.dist;
      }
      sum += hit.phi;
      depth = std::max(depth, hit.phi);
      hits[static_cast<size_t>(used++)] = hit;
    }
    // The pressure over each triangle's area inside the tool (a triangle a shaft was pushed behind:
    // its whole area at its depth φ_t, at the shaft's closest point), scaled so that Σ_i g_i is a
    // unit vector (the tool feels exactly F along it).
    // Only where the triangles are small against the tool (every pressed triangle's longest rest
    // edge ≤ r/2: the patch spans several of them, and rings of vertices join it as it grows). On a
    // mesh coarse against the tool the patch lies on one or two triangles and each triangle's
    // closest point carries it (below), as validated there (docs/models/mass-spring.md, Contact).
    bool resolved = used > 0;
    for (int k = 0; k < used && resolved; ++k)
      resolved = hits[static_cast<size_t>(k)].behind || rest_edge_of(hits[static_cast<size_t>(k)].tri) <= 0.5 * r;
    bool spread = false;
    if (resolved) {
      Vec3 resultant = Vec3::Zero();
      for (int k = 0; k < used; ++k) {
        const Hit& hit = hits[static_cast<size_t>(k)];
        if (!hit.behind) {
          resultant += spread_over_area(hit.tri);
          continue;
        }
        const auto& T = net.triangles[static_cast<size_t>(hit.tri)];
        const double area = 0.5 * (s.x.row(T[1]) - s.x.row(T[0]))
                                      .transpose()
                                      .cross((s.x.row(T[2]) - s.x.row(T[0])).transpose())
                                      .norm();
        const Vec3 load = hit.phi * area * hit.n;
        for (int q = 0; q < 3; ++q)
          if (hit.w[q] > 0) add(T[static_cast<size_t>(q)], hit.w[q] * load);
        resultant += load;
      }
      const double norm = resultant.norm();
      if (norm > 0) {
        for (int k = 0; k < s.contact_vertex_count; ++k) g[static_cast<size_t>(k)] /= norm;
        spread = true;
      } else {
        clear_slots();
        s.contact_vertex_count = 0;
      }
    }
    // A needle's shaft, or a patch smaller than the sampling above (a first touch, a small probe on
    // a coarse mesh): each triangle's weight φ_t at its closest point, scaled so that Σ ω_t n_t is a
    // unit vector.
    Vec3 resultant = Vec3::Zero();
    for (int k = 0; k < used; ++k) resultant += hits[static_cast<size_t>(k)].phi * hits[static_cast<size_t>(k)].n;
    sum = resultant.norm();
    if (sum > 0 && !spread)
      for (int k = 0; k < used; ++k) {
        const Hit& hit = hits[static_cast<size_t>(k)];
        const Vec3 n = hit.n;
        const double weight = hit.phi / sum;
        const auto& T = net.triangles[static_cast<size_t>(hit.tri)];
        for (int q = 0; q < 3; ++q)
          if (hit.w[q] > 0) add(T[static_cast<size_t>(q)], weight * hit.w[q] * n);
      }
    s.contacts = used;
  }
  clear_slots();
  if (!(depth > 0) || s.contact_vertex_count == 0) {
    s.contact_vertex_count = 0;
    s.contacts = 0;
    return;
  }
  double compliance = 0;
  if (model.contact_compliance_exact) {  // (A⁻¹)_ii: the Cauchy–Schwarz bound (Σ_i |g_i| √(A⁻¹)_ii)²
    for (int k = 0; k < s.contact_vertex_count; ++k)
      compliance += g[static_cast<size_t>(k)].norm() *
                    std::sqrt(model.contact_compliance[static_cast<size_t>(s.contact_vertex[static_cast<size_t>(k)])]);
    compliance *= compliance;
  } else {
    for (int k = 0; k < s.contact_vertex_count; ++k)
      compliance += g[static_cast<size_t>(k)].squaredNorm() *
                    model.contact_compliance[static_cast<size_t>(s.contact_vertex[static_cast<size_t>(k)])];
  }
  // The normal damper (contact_damping) on the approach speed of the tool to the contact vertices
  // along the force's direction: explicit, so small (it is zero at rest).
  Vec3 surface_v = Vec3::Zero(), direction = Vec3::Zero();
  for (int k = 0; k < s.contact_vertex_count; ++k) {
    const int i = s.contact_vertex[static_cast<size_t>(k)];
    direction += g[static_cast<size_t>(k)];
    surface_v += g[static_cast<size_t>(k)].norm() * s.v.row(i).transpose();
  }
  const double gsum = direction.norm();
  const double approach = gsum > 0 ? (surface_v / gsum - tool.velocity).dot(direction / gsum) : 0.0;
  const double kh2c = kc * h * h * compliance;
  const double f_new = std::max(
      0.0, (kc * (depth + h * h * compliance * f_prev) + model.options.contact_damping * approach) / (1 + kh2c));
  const double df = f_new - f_prev;
  Vec3 total = Vec3::Zero();
  for (int k = 0; k < s.contact_vertex_count; ++k) {
    const int i = s.contact_vertex[static_cast<size_t>(k)];
    const Vec3 gi = g[static_cast<size_t>(k)];
    const Vec3 dv = -h * df * model.contact_compliance[static_cast<size_t>(i)] * gi;
    s.v.row(i) += dv.transpose();
    s.x.row(i) += h * dv.transpose();
    s.contact_load[static_cast<size_t>(k)] = -f_new * gi;
    total += f_new * gi;
  }
  s.contact_force = f_new;
  s.contact_depth = depth;
  s.tool_force += total;  // the tool feels F⁺, the corrected force, now
}

// All forces at the start of the step into s.force (external ones also left in s.work). With
// stiffness_term (the predictor's path, generic springs) s.rhs also receives −h K_L v.
void all_forces(const SpringModel& model, SpringState& s, const ToolState* tool, bool stiffness_term = false) noexcept {
  s.tool_force = external_forces(model, s, tool, s.work);
  s.force = s.work;
  if (stiffness_term && !model.all_pairs) {
    s.rhs.setZero();
    spring::add_spring_forces_and_stiffness_term(model, s.x, s.v, s.force, s.rhs, s.soa.data(), true);
    s.anchor_force = anchor_load(model, s.force);
    return;
  }
  if (model.all_pairs) {
    add_all_pair_forces(model, s.x, s.v, s.force, s);
  }
  else add_spring_forces(model.network, s.x, s.v, s.force);
  s.anchor_force = anchor_load(model, s.force);
}

// out += sign · (h² K y + h C w) with the exact Jacobian at x: per spring K_e = k [uuᵀ + max(0, 1 − L/l)
// (I − uuᵀ)] (the exact solver's, positive semi-definite) and C_e = c uuᵀ, and per tetrahedron the
// volume term's (κ/V0) ∇V ∇Vᵀ. Anchored vertices' rows are left for the caller to zero.
void add_exact_jacobian(const SpringModel& model, const RowMat3d& x, const RowMat3d& y, const RowMat3d& w,
                        RowMat3d& out, double sign) noexcept {
  const SpringNetwork& net = model.network;
  const double h = model.options.dt;
  for (size_t e = 0; e < net.springs.size(); ++e) {
    const int a = net.springs[e][0], b = net.springs[e][1];
    const Vec3 d = (x.row(b) - x.row(a)).transpose();
    const double l = d.norm();
    if (!(l > 0)) continue;
    const Vec3 u = d / l;
    const Vec3 dy = (y.row(a) - y.row(b)).transpose(), dw = (w.row(a) - w.row(b)).transpose();
    const double lateral = std::max(0.0, 1.0 - net.rest_length[e] / l);
    const double uy = u.dot(dy);
    const Vec3 t = sign * (h * h * net.stiffness[e] * (uy * u + lateral * (dy - uy * u)) + h * net.damping[e] * u.dot(dw) * u);
    out.row(a) += t.transpose();
    out.row(b) -= t.transpose();
  }
  if (!model.volume_term) return;
  for (size_t k = 0; k < net.tets.size(); ++k) {
    const auto& q = net.tets[k];
    const auto g = spring::tet_volume_gradients(x.row(q[0]).transpose(), x.row(q[1]).transpose(),
                                                x.row(q[2]).transpose(), x.row(q[3]).transpose());
    double gy = 0;
    for (int c = 0; c < 4; ++c) gy += g[static_cast<size_t>(c)].dot(y.row(q[static_cast<size_t>(c)]).transpose());
    const double wgt = sign * h * h * net.volume_modulus / net.rest_volume[k] * gy;
    for (int c = 0; c < 4; ++c) out.row(q[static_cast<size_t>(c)]) += wgt * g[static_cast<size_t>(c)].transpose();
  }
}

// out += sign · (h² K_p y + h C_L w): the predictor's Laplacians (weights predictor_stiffness, damping).
void add_predictor_jacobian(const SpringModel& model, const RowMat3d& y, const RowMat3d& w, RowMat3d& out,
                            double sign) noexcept {
  const SpringNetwork& net = model.network;
  const double h = model.options.dt;
  for (size_t e = 0; e < net.springs.size(); ++e) {
    const int a = net.springs[e][0], b = net.springs[e][1];
    const Eigen::RowVector3d t = sign * (h * h * model.predictor_stiffness[e] * (y.row(a) - y.row(b)) +
                                         h * net.damping[e] * (w.row(a) - w.row(b)));
    out.row(a) += t;
    out.row(b) -= t;
  }
}

void solve_predictor(const SpringModel& model, SpringState& s, const RowMat3d& b, RowMat3d& x) noexcept {
  if (model.predictor.kind == SpringSolver::desbrun)
    spring::solve_dense(model.predictor, model.inverse_single, b, x, s.soa.data());
  else if (model.supernodes.empty()) spring::solve_columns(model.predictor, b, x, s.work);
  else spring::solve_supernodal(model.predictor, model.supernodes, b, x, s.soa.data());
}

// Backward Euler's damping on request (SpringModelOptions::exact_iterations): the predictor's Δv
// solves (M + hγ + hC_L + h²K_p) Δv = h (f − h K_p v); the exact linearised backward Euler (one
// Newton step of the exact solver) has the true C and K instead. Its residual at the predictor's
// Δv is r = h² (K_p − K)(v + Δv) + h (C_L − C) Δv; preconditioned conjugate gradients (the
// predictor's matrix as the preconditioner; both symmetric positive definite) solve for the
// correction δ, A δ = r, a few iterations. Free vertices only (anchored rows zero).
void refine_toward_exact(const SpringModel& model, SpringState& s) noexcept {
  const int iterations = model.options.exact_iterations;
  if (iterations <= 0 || s.cg_r.rows() != s.x.rows() || model.all_pairs) return;
  const double h = model.options.dt, gamma = model.options.point_damping;
  const Eigen::Index n = s.x.rows();
  auto zero_anchors = [&](RowMat3d& m) {
    for (int a : model.network.anchors) m.row(a).setZero();
  };
  auto dot = [](const RowMat3d& a, const RowMat3d& b) { return (a.array() * b.array()).sum(); };
  s.cg_q = s.v + s.dv;
  s.cg_r.setZero();
  add_predictor_jacobian(model, s.cg_q, s.dv, s.cg_r, 1.0);
  add_exact_jacobian(model, s.x, s.cg_q, s.dv, s.cg_r, -1.0);
  zero_anchors(s.cg_r);
  s.cg_d.setZero();
  solve_predictor(model, s, s.cg_r, s.cg_z);
  zero_anchors(s.cg_z);
  s.cg_p = s.cg_z;
  double rz = dot(s.cg_r, s.cg_z);
  for (int it = 0; it < iterations && rz > 0; ++it) {
    // q = A p: masses and point damping, then the exact Jacobian's parts.
    for (Eigen::Index i = 0; i < n; ++i)
      s.cg_q.row(i) = (model.network.mass[static_cast<size_t>(i)] + h * gamma) * s.cg_p.row(i);
    add_exact_jacobian(model, s.x, s.cg_p, s.cg_p, s.cg_q, 1.0);
    zero_anchors(s.cg_q);
    const double pq = dot(s.cg_p, s.cg_q);
    if (!(pq > 0)) break;
    const double alpha = rz / pq;
    s.cg_d += alpha * s.cg_p;
    if (it + 1 == iterations) break;
    s.cg_r -= alpha * s.cg_q;
    solve_predictor(model, s, s.cg_r, s.cg_z);
    zero_anchors(s.cg_z);
    const double rz_next = dot(s.cg_r, s.cg_z);
    s.cg_p = s.cg_z + (rz_next / rz) * s.cg_p;
    rz = rz_next;
  }
  s.dv += s.cg_d;
}

// The doubles of SpringState::soa the fused sparse step takes: the padded spring pass, then the
// permuted right-hand side and the block being solved.
size_t fused_scratch(const SpringModel& model) {
  return spring::spring_pass_scratch(model) + spring::supernodal_scratch(model.predictor, model.supernodes);
}

// The fused step's right-hand side, row perm[i] of z4 = h (r + ((f_ext + f) − γ v)), zero when i
// is anchored; a vertex's three values in one 256-bit register (masked loads from the (n x 3)
// arrays). AVX only, not FMA: each value is the scalar expression's, operation for operation, so
// the fused and general steps stay equal bit for bit. (Masked stores into v and x were tried for
// the update and were slower: a masked load after a masked store to the same 32 bytes waits.)
__attribute__((target("avx2"))) void fused_rhs(size_t n, double h, double gamma, const int* perm,
                                                 const std::uint8_t* anchored, const double* fr, const double* work,
                                                 const double* v, double* z4) noexcept {
  const __m256i m3 = _mm256_set_epi64x(0, -1, -1, -1);
  const __m256d hv = _mm256_set1_pd(h), gv = _mm256_set1_pd(gamma), zero = _mm256_setzero_pd();
  for (size_t i = 0; i < n; ++i) {
    double* z = z4 + 4 * static_cast<size_t>(perm[i]);
    if (anchored[i]) {
      _mm256_storeu_pd(z, zero);
      continue;
    }
    const __m256d f = _mm256_add_pd(_mm256_maskload_pd(work + 3 * i, m3), _mm256_load_pd(fr + 8 * i));
    const __m256d t = _mm256_sub_pd(f, _mm256_mul_pd(gv, _mm256_maskload_pd(v + 3 * i, m3)));
    _mm256_storeu_pd(z, _mm256_mul_pd(_mm256_add_pd(_mm256_load_pd(fr + 8 * i + 4), t), hv));  // lane 3: 0
  }
}

// step_predictor's sparse step for generic springs with the supernodal factor, fused: the spring
// pass leaves its sums in the padded layout, one pass over the vertices builds the permuted
// right-hand side h (f − γ v − h K_L v) straight into the solve's z4 (anchored rows zero), the
// solve works there in place, and Δv is gathered from it for the general path's last lines. No
// (n x 3) copies of the forces or the right-hand side; the arithmetic is the general path's,
// operation for operation.
void step_sparse_fused(const SpringModel& model, SpringState& s, const ToolState* tool, bool correct) noexcept {
  const SpringNetwork& net = model.network;
  const double h = model.options.dt;
  const double gamma = model.options.point_damping;
  const size_t n = net.size();
  s.tool_force = external_forces(model, s, tool, s.work);
  Vec3 ext_torque = Vec3::Zero();
  if (correct)
    for (size_t i = 0; i < n; ++i)
      ext_torque += s.x.row(static_cast<Eigen::Index>(i)).transpose().cross(s.work.row(static_cast<Eigen::Index>(i)).transpose());
  double* p = spring::spring_pass_padded(model, s.x, s.v, s.soa.data(), spring::SpringKernel::best);
  const double* fr = p + 8 * n;  // per vertex: the springs' force, 0, their −h K_L v, 0
  double* z4 = p + 16 * n;
  const int* perm = model.predictor.perm.data();
  const double* work = s.work.data();
  const double* v = s.v.data();
  fused_rhs(n, h, gamma, perm, model.anchored.data(), fr, work, v, z4);
  Vec3 anchor = Vec3::Zero();
  for (int a : net.anchors) {
    const size_t i = static_cast<size_t>(a);
    anchor += Vec3(work[3 * i] + fr[8 * i], work[3 * i + 1] + fr[8 * i + 1], work[3 * i + 2] + fr[8 * i + 2]);
  }
  s.anchor_force = anchor;
  spring::solve_supernodal_permuted(model.predictor, model.supernodes, z4, z4 + 4 * n);
  spring::unpermute_rows(model.predictor, z4, s.dv.data());
  refine_toward_exact(model, s);
  if (correct) correct_angular_momentum(model, s, ext_torque, s.dv);
  s.v += s.dv;
  for (int a : net.anchors) s.v.row(a).setZero();
  s.x += h * s.v;
}

// One step with the precomputed predictor (DS99): the implicit system with the constant matrix,
//   (M + h(γI + C_L) + h²K_L) Δv = h (f(x, v) − γ v − h K_L v),
// solved with the stored inverse or factor, then corrected, then x⁺ = x + h v⁺.
void step_predictor(const SpringModel& model, SpringState& s, const ToolState* tool) noexcept {
  const SpringNetwork& net = model.network;
  const double h = model.options.dt;
  const double gamma = model.options.point_damping;
  const Eigen::Index n = s.x.rows();
  const bool correct = model.options.angular_momentum_correction && net.anchors.empty();
  if (!model.all_pairs && model.predictor.kind == SpringSolver::sparse && !model.supernodes.empty() &&
      spring::spring_pass_padded_available(model) && s.soa.size() >= fused_scratch(model)) {
    step_sparse_fused(model, s, tool, correct);
    return;
  }
  all_forces(model, s, tool, true);  // s.work holds the external forces afterwards; s.rhs −h K_L v
  Vec3 ext_torque = Vec3::Zero();
  if (correct)
    for (Eigen::Index i = 0; i < n; ++i) ext_torque += s.x.row(i).transpose().cross(s.work.row(i).transpose());
  if (!model.all_pairs) {
    s.rhs += s.force - gamma * s.v;  // s.rhs holds −h K_L v from the spring pass
  } else if (model.uniform_stiffness > 0) {
    // K_L v with one stiffness over every pair: (K_L v)_i = k (n v_i − Σ_j v_j).
    s.rhs = s.force - gamma * s.v;
    const Eigen::RowVector3d sum = s.v.colwise().sum();
    const double kh = h * model.uniform_stiffness;
    for (Eigen::Index i = 0; i < n; ++i) s.rhs.row(i) -= kh * (static_cast<double>(n) * s.v.row(i) - sum);
  } else {
    s.rhs = s.force - gamma * s.v;
    for (size_t e = 0; e < net.springs.size(); ++e) {
      const int i = net.springs[e][0], j = net.springs[e][1];
      const double kh = h * net.stiffness[e];
      for (int c = 0; c < 3; ++c) {
        const double d = kh * (s.v(i, c) - s.v(j, c));
        s.rhs(i, c) -= d;
        s.rhs(j, c) += d;
      }
    }
  }
  s.rhs *= h;
  for (int a : net.anchors) s.rhs.row(a).setZero();
  if (model.predictor.kind == SpringSolver::desbrun)
    spring::solve_dense(model.predictor, model.inverse_single, s.rhs, s.dv, s.soa.data());
  else if (model.supernodes.empty()) spring::solve_columns(model.predictor, s.rhs, s.dv, s.work);
  else spring::solve_supernodal(model.predictor, model.supernodes, s.rhs, s.dv, s.soa.data());
  refine_toward_exact(model, s);
  if (correct) correct_angular_momentum(model, s, ext_torque, s.dv);
  s.v += s.dv;
  for (int a : net.anchors) s.v.row(a).setZero();
  s.x += h * s.v;
}

// The exact backward Euler: solve G(Δv) = M Δv − h f(x + h(v + Δv), v + Δv) = 0 by Newton with the
// full spring Jacobian, K_e = k [uuᵀ + max(0, 1 − L/l)(I − uuᵀ)] (the transverse term clamped at
// zero in compression keeps the matrix definite; the residual stays exact), re-assembled and
// factorised (SimplicialLDLT) every iteration. External and tool forces are taken at the start.
void step_exact(const SpringModel& model, SpringState& s, const ToolState* tool) {
  const SpringNetwork& net = model.network;
  const SpringModelOptions& o = model.options;
  const double h = o.dt, gamma = o.point_damping;
  const Eigen::Index n = s.x.rows();
  all_forces(model, s, tool);
  const RowMat3d f_ext = s.work;
  RowMat3d dv = RowMat3d::Zero(n, 3);
  RowMat3d xn(n, 3), vn(n, 3), f(n, 3);
  Eigen::VectorXd residual(3 * n);
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(static_cast<size_t>(3 * n + 36 * static_cast<Eigen::Index>(net.springs.size())));
  Eigen::SparseMatrix<double> J(3 * n, 3 * n);
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver;
  s.newton_iterations = 0;
  const double vscale = 1.0 + s.v.cwiseAbs().maxCoeff();
  for (int it = 0; it < o.newton_iterations; ++it) {
    vn = s.v + dv;
    xn = s.x + h * vn;
    f = f_ext - gamma * vn;
    add_spring_forces(net, xn, vn, f);
    for (Eigen::Index i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c)
        residual[3 * i + c] = model.anchored[static_cast<size_t>(i)]
                                  ? dv(i, c)
                                  : net.mass[static_cast<size_t>(i)] * dv(i, c) - h * f(i, c);
    trip.clear();
    for (Eigen::Index i = 0; i < n; ++i) {
      const double d = model.anchored[static_cast<size_t>(i)] ? 1.0 : net.mass[static_cast<size_t>(i)] + h * gamma;
      for (int c = 0; c < 3; ++c) trip.emplace_back(3 * i + c, 3 * i + c, d);
    }
    for (size_t e = 0; e < net.springs.size(); ++e) {
      const int a = net.springs[e][0], b = net.springs[e][1];
      Vec3 d = (xn.row(b) - xn.row(a)).transpose();
      const double l = d.norm();
      if (!(l > 0)) continue;
      const Vec3 u = d / l;
      const Eigen::Matrix3d uu = u * u.transpose();
      const double lateral = std::max(0.0, 1.0 - net.rest_length[e] / l);
      const Eigen::Matrix3d B = h * h * net.stiffness[e] * (uu + lateral * (Eigen::Matrix3d::Identity() - uu)) +
                                h * net.damping[e] * uu;
      const bool fa = !model.anchored[static_cast<size_t>(a)], fb = !model.anchored[static_cast<size_t>(b)];
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
          if (fa) trip.emplace_back(3 * a + r, 3 * a + c, B(r, c));
          if (fb) trip.emplace_back(3 * b + r, 3 * b + c, B(r, c));
          if (fa && fb) {
            trip.emplace_back(3 * a + r, 3 * b + c, -B(r, c));
            trip.emplace_back(3 * b + r, 3 * a + c, -B(r, c));
          }
        }
    }
    // The volume term: its Gauss-Newton Jacobian (κ / V0) ∇V ∇Vᵀ (positive semi-definite; the
    // residual is exact, so Newton still converges to the backward-Euler step).
    for (size_t t = 0; t < net.tets.size() && net.volume_modulus > 0; ++t) {
      const auto& q = net.tets[t];
      const auto g = spring::tet_volume_gradients(xn.row(q[0]).transpose(), xn.row(q[1]).transpose(),
                                                  xn.row(q[2]).transpose(), xn.row(q[3]).transpose());
      const double w = h * h * net.volume_modulus / net.rest_volume[t];
      for (int a = 0; a < 4; ++a) {
        if (model.anchored[static_cast<size_t>(q[static_cast<size_t>(a)])]) continue;
        for (int b = 0; b < 4; ++b) {
          if (model.anchored[static_cast<size_t>(q[static_cast<size_t>(b)])]) continue;
          const Eigen::Matrix3d B = w * g[static_cast<size_t>(a)] * g[static_cast<size_t>(b)].transpose();
          for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c)
              trip.emplace_back(3 * q[static_cast<size_t>(a)] + r, 3 * q[static_cast<size_t>(b)] + c, B(r, c));
        }
      }
    }
    J.setFromTriplets(trip.begin(), trip.end());
    if (it == 0) solver.analyzePattern(J);
    solver.factorize(J);
    if (solver.info() != Eigen::Success) break;
    const Eigen::VectorXd delta = solver.solve(residual);
    for (Eigen::Index i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) dv(i, c) -= delta[3 * i + c];
    ++s.newton_iterations;
    if (delta.cwiseAbs().maxCoeff() <= o.newton_tolerance * vscale) break;
  }
  s.v += dv;
  for (int a : net.anchors) s.v.row(a).setZero();
  s.x += h * s.v;
}

}  // namespace

namespace {

// BDF2 as a backward-Euler step from an extrapolated state: x_{n+1} = x̃ + h v_{n+1} and
// v_{n+1} = ṽ + h a(x_{n+1}, v_{n+1}) with h = 2H/3, x̃ = (4 x_n − x_{n−1})/3, ṽ = (4 v_n − v_{n−1})/3,
// which is the backward-Euler step the predictor already takes, started from (x̃, ṽ). Keeps (x_n, v_n)
// as the next step's previous state. The first step after make_state or reset takes x_{n−1} = x_n.
void bdf2_start(SpringState& s) noexcept {
  if (!s.has_prev) {
    s.x_prev = s.x;
    s.v_prev = s.v;
    s.has_prev = true;
  }
  const Eigen::Index n = s.x.rows();
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index c = 0; c < 3; ++c) {
      const double x = s.x(i, c), v = s.v(i, c);
      s.x(i, c) = (4.0 * x - s.x_prev(i, c)) / 3.0;
      s.v(i, c) = (4.0 * v - s.v_prev(i, c)) / 3.0;
      s.x_prev(i, c) = x;
      s.v_prev(i, c) = v;
    }
}

}  // namespace

bool step(const SpringModel& model, SpringState& s, const ToolState* tool) noexcept {
  // A device glitch (non-finite pose) must not reach the tissue: the tool is ignored this step.
  if (tool && !(tool->tip.allFinite() && tool->velocity.allFinite() && tool->axis.allFinite() &&
                std::isfinite(tool->radius)))
    tool = nullptr;
  if (model.options.integrator == SpringIntegrator::bdf2) bdf2_start(s);
  if (model.options.solver == SpringSolver::exact) {
    try {
      step_exact(model, s, tool);
    } catch (...) {  // out of memory in the reference solver: treated as a blow-up
      s.v.setConstant(std::numeric_limits<double>::quiet_NaN());
    }
  } else {
    step_predictor(model, s, tool);
  }
  if (model.options.contact == SpringContact::surface) {
    if (tool) {
      surface_contact(model, s, *tool);
    } else {
      s.contact_vertex_count = 0;
      s.contact_force = 0;
      s.carried_on_tool.setZero();
    }
  }
  s.time += step_length(model.options);
  if (finite_and_slow(model, s)) return true;
  const std::uint64_t resets = s.resets + 1;
  reset(model, s);
  s.resets = resets;
  return false;
}

double kinetic_energy(const SpringModel& model, const SpringState& s) noexcept {
  double e = 0;
  for (Eigen::Index i = 0; i < s.v.rows(); ++i) e += 0.5 * model.network.mass[static_cast<size_t>(i)] * s.v.row(i).squaredNorm();
  return e;
}

double elastic_energy(const SpringModel& model, const SpringState& s) noexcept {
  const SpringNetwork& net = model.network;
  double e = 0;
  for (size_t k = 0; k < net.springs.size(); ++k) {
    const double l = (s.x.row(net.springs[k][0]) - s.x.row(net.springs[k][1])).norm();
    e += 0.5 * net.stiffness[k] * (l - net.rest_length[k]) * (l - net.rest_length[k]);
  }
  if (!net.tets.empty() && net.volume_modulus > 0) {
    RowMat3d scratch = RowMat3d::Zero(s.x.rows(), 3);  // not on the tick
    e += spring::add_volume_forces(net, s.x.data(), 3, scratch.data(), 3);
  }
  return e;
}

Vec3 linear_momentum(const SpringModel& model, const SpringState& s) noexcept {
  Vec3 p = Vec3::Zero();
  for (Eigen::Index i = 0; i < s.v.rows(); ++i) p += model.network.mass[static_cast<size_t>(i)] * s.v.row(i).transpose();
  return p;
}

Vec3 angular_momentum(const SpringModel& model, const SpringState& s) noexcept {
  Vec3 l = Vec3::Zero();
  for (Eigen::Index i = 0; i < s.v.rows(); ++i)
    l += model.network.mass[static_cast<size_t>(i)] * s.x.row(i).transpose().cross(s.v.row(i).transpose());
  return l;
}

double max_displacement(const SpringModel& model, const SpringState& s) noexcept {
  double d2 = 0;
  for (Eigen::Index i = 0; i < s.x.rows(); ++i) d2 = std::max(d2, (s.x.row(i) - model.network.rest.row(i)).squaredNorm());
  return std::sqrt(d2);
}

}  // namespace palpate

namespace palpate::spring {

// No function-local static: its first call would take the initialisation guard (a lock) on the
// haptic thread. libgcc fills the CPU model when it loads, so reading it is a few loads.
bool has_avx2_fma() noexcept { return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"); }

bool has_avx512() noexcept {
  return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") && has_avx2_fma();
}

void add_all_pair_forces_soa(const SpringNetwork& net, bool uniform, double* p, size_t stride,
                             SpringKernel kernel) noexcept {
  all_pairs_rows(net, uniform, p, stride, kernel);
}

size_t all_pairs_stride(size_t n) noexcept { return (n + 7) / 8 * 8; }

size_t all_pairs_scratch(size_t n) noexcept { return 9 * all_pairs_stride(n) + 8; }

double* align64(double* p) noexcept {
  const std::uintptr_t at = reinterpret_cast<std::uintptr_t>(p);
  return p + ((64 - at % 64) % 64) / sizeof(double);
}

size_t spring_pass_scratch(const SpringModel& model) { return 16 * model.network.size() + 7; }

namespace {

// SpringModelOptions::directional_correction, unless exact_iterations is on (its residual assumes the
// predictor's own right-hand side; the two are alternatives).
bool directional(const SpringModel& model) noexcept {
  return model.options.directional_correction && model.options.exact_iterations <= 0;
}

// The scalar pass (forces.h) over the springs from e on, one at a time: vertex i's position at
// x[stride i …], its velocity at v[stride i …], its sums at f and r the same way. The reference
// pass on the (n x 3) arrays (stride 3) and the vectorised passes' last s mod 4 springs on the
// padded layout (stride 8: v = x + 4, r = f + 4).
// KP: each spring's predictor weight (SpringModel::predictor_stiffness) for the −h K v term.
// Directional (SpringModelOptions::directional_correction): the spring's share of that term is its
// exact stiffness k[uuᵀ + max(0, 1 − L/l)(I − uuᵀ)] instead of k I, i.e. r_i += h KP w − μ (w − (u·w) u)
// with μ = h k min(1, L/l), w = v_j − v_i (the volume term's share of KP stays isotropic).
template <bool Directional>
void spring_loop(const SpringNetwork& net, const double* KP, double h, size_t e, size_t stride, const double* xd,
                 const double* vd, double* fd, double* rd) noexcept {
  for (; e < net.springs.size(); ++e) {
    const size_t i = stride * static_cast<size_t>(net.springs[e][0]), j = stride * static_cast<size_t>(net.springs[e][1]);
    const double dx = xd[j] - xd[i], dy = xd[j + 1] - xd[i + 1], dz = xd[j + 2] - xd[i + 2];
    const double wx = vd[j] - vd[i], wy = vd[j + 1] - vd[i + 1], wz = vd[j + 2] - vd[i + 2];
    const double kh = h * KP[e];
    const double l = std::sqrt(dx * dx + dy * dy + dz * dz);
    if constexpr (Directional) {
      double rx = kh * wx, ry = kh * wy, rz = kh * wz;
      if (l > 0) {
        const double mu = h * net.stiffness[e] * std::min(1.0, net.rest_length[e] / l);
        const double nu = mu * (wx * dx + wy * dy + wz * dz) / (l * l);
        rx += nu * dx - mu * wx; ry += nu * dy - mu * wy; rz += nu * dz - mu * wz;
      }
      rd[i] += rx; rd[i + 1] += ry; rd[i + 2] += rz;
      rd[j] -= rx; rd[j + 1] -= ry; rd[j + 2] -= rz;
    } else {
      rd[i] += kh * wx; rd[i + 1] += kh * wy; rd[i + 2] += kh * wz;
      rd[j] -= kh * wx; rd[j + 1] -= kh * wy; rd[j + 2] -= kh * wz;
    }
    if (!(l > 0)) continue;
    const double inv_l = 1.0 / l;
    const double dvu = (wx * dx + wy * dy + wz * dz) * inv_l;
    const double g = (net.stiffness[e] * (l - net.rest_length[e]) + net.damping[e] * dvu) * inv_l;
    fd[i] += g * dx; fd[i + 1] += g * dy; fd[i + 2] += g * dz;
    fd[j] -= g * dx; fd[j + 1] -= g * dy; fd[j + 2] -= g * dz;
  }
}
template <bool Directional = false>
void spring_pass_tail(const SpringNetwork& net, const double* KP, double h, size_t e, const double* xv,
                      double* fr) noexcept {
  spring_loop<Directional>(net, KP, h, e, 8, xv, xv + 4, fr, fr + 4);
}

// (Σ a0, Σ a1, Σ a2, Σ a3): the four horizontal sums in one register.
__attribute__((target("avx2,fma"), always_inline)) inline __m256d hsum4(__m256d a0, __m256d a1, __m256d a2,
                                                                         __m256d a3) noexcept {
  const __m256d t0 = _mm256_hadd_pd(a0, a1);  // a0[0]+a0[1], a1[0]+a1[1], a0[2]+a0[3], a1[2]+a1[3]
  const __m256d t1 = _mm256_hadd_pd(a2, a3);
  return _mm256_add_pd(_mm256_permute2f128_pd(t0, t1, 0x20), _mm256_permute2f128_pd(t0, t1, 0x31));
}

// The AVX2 pass, four springs at a time. xv is (8n): a vertex's x, y, z, 0, vx, vy, vz, 0 (one
// 64-byte line, so each vertex is one cache line, its position and velocity aligned 256-bit loads
// and no lane is masked); fr the same for the springs' sums, f then r. The sums go to fr one vertex
// at a time in spring order, so springs sharing a vertex in a group of four are summed like the
// scalar loop's. Directional: the −h K v term with each spring's exact stiffness (spring_loop).
template <bool Directional = false>
__attribute__((target("avx2,fma"))) void spring_pass_avx2(const SpringNetwork& net, const double* KP, double h,
                                                           const double* xv, double* fr) noexcept {
  const size_t s = net.springs.size();
  const double *K = net.stiffness.data(), *C = net.damping.data(), *L = net.rest_length.data();
  const __m256d hv = _mm256_set1_pd(h), zero = _mm256_setzero_pd(), one = _mm256_set1_pd(1.0);
  size_t e = 0;
  for (; e + 4 <= s; e += 4) {
    size_t a[4], b[4];
    __m256d d[4], w[4];
    for (int q = 0; q < 4; ++q) {
      a[q] = 8 * static_cast<size_t>(net.springs[e + q][0]);
      b[q] = 8 * static_cast<size_t>(net.springs[e + q][1]);
      d[q] = _mm256_sub_pd(_mm256_load_pd(xv + b[q]), _mm256_load_pd(xv + a[q]));
      w[q] = _mm256_sub_pd(_mm256_load_pd(xv + b[q] + 4), _mm256_load_pd(xv + a[q] + 4));
    }
    const __m256d l2 = hsum4(_mm256_mul_pd(d[0], d[0]), _mm256_mul_pd(d[1], d[1]), _mm256_mul_pd(d[2], d[2]),
                             _mm256_mul_pd(d[3], d[3]));
    const __m256d dw = hsum4(_mm256_mul_pd(d[0], w[0]), _mm256_mul_pd(d[1], w[1]), _mm256_mul_pd(d[2], w[2]),
                             _mm256_mul_pd(d[3], w[3]));
    const __m256d l = _mm256_sqrt_pd(l2);
    const __m256d ok = _mm256_cmp_pd(l, zero, _CMP_GT_OQ);  // l > 0 (false for NaN), as the scalar loop
    const __m256d inv_l = _mm256_div_pd(one, l);
    const __m256d k = _mm256_loadu_pd(K + e);
    const __m256d dvu = _mm256_mul_pd(dw, inv_l);
    __m256d g = _mm256_add_pd(_mm256_mul_pd(k, _mm256_sub_pd(l, _mm256_loadu_pd(L + e))),
                              _mm256_mul_pd(_mm256_loadu_pd(C + e), dvu));
    g = _mm256_and_pd(_mm256_mul_pd(g, inv_l), ok);
    __m256d kh = _mm256_mul_pd(hv, _mm256_loadu_pd(KP + e));
    __m256d nu = zero;
    if constexpr (Directional) {
      // μ = h k min(1, L/l), ν = μ (d·w)/l²: r += (h KP − μ) w + ν d (zero correction where l = 0).
      const __m256d mu = _mm256_and_pd(
          _mm256_mul_pd(_mm256_mul_pd(hv, k), _mm256_min_pd(one, _mm256_mul_pd(_mm256_loadu_pd(L + e), inv_l))), ok);
      nu = _mm256_and_pd(_mm256_mul_pd(_mm256_mul_pd(mu, dw), _mm256_mul_pd(inv_l, inv_l)), ok);
      kh = _mm256_sub_pd(kh, mu);
    }
    const __m256d gq[4] = {_mm256_permute4x64_pd(g, 0x00), _mm256_permute4x64_pd(g, 0x55),
                           _mm256_permute4x64_pd(g, 0xAA), _mm256_permute4x64_pd(g, 0xFF)};
    const __m256d kq[4] = {_mm256_permute4x64_pd(kh, 0x00), _mm256_permute4x64_pd(kh, 0x55),
                           _mm256_permute4x64_pd(kh, 0xAA), _mm256_permute4x64_pd(kh, 0xFF)};
    [[maybe_unused]] const __m256d nq[4] = {_mm256_permute4x64_pd(nu, 0x00), _mm256_permute4x64_pd(nu, 0x55),
                                            _mm256_permute4x64_pd(nu, 0xAA), _mm256_permute4x64_pd(nu, 0xFF)};
    for (int q = 0; q < 4; ++q) {
      const __m256d fd = _mm256_mul_pd(gq[q], d[q]);
      __m256d rw = _mm256_mul_pd(kq[q], w[q]);
      if constexpr (Directional) rw = _mm256_fmadd_pd(nq[q], d[q], rw);
      _mm256_store_pd(fr + a[q] + 4, _mm256_add_pd(_mm256_load_pd(fr + a[q] + 4), rw));
      _mm256_store_pd(fr + b[q] + 4, _mm256_sub_pd(_mm256_load_pd(fr + b[q] + 4), rw));
      _mm256_store_pd(fr + a[q], _mm256_add_pd(_mm256_load_pd(fr + a[q]), fd));
      _mm256_store_pd(fr + b[q], _mm256_sub_pd(_mm256_load_pd(fr + b[q]), fd));
    }
  }
  spring_pass_tail<Directional>(net, KP, h, e, xv, fr);
}

#pragma GCC diagnostic push  // GCC 12's AVX-512 intrinsics: see all_pairs_avx512
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

// The same with AVX-512, on whole vertices: a spring's end is one 512-bit load of its position
// and velocity and one 512-bit read-modify-write of its force and −h K_L v sums (half the memory
// operations of the AVX2 pass). 1/l without the divider: rsqrt14 and two Newton steps. Each value
// is computed as in the AVX2 pass's order of operations except 1/l (same round-off level).
// Uniform: every spring has stiffness k0 and damping c0, so the pass reads no per-spring K and C
// (16 of each spring's 32 bytes; the same values, so the same results bit for bit).
template <bool Uniform>
__attribute__((target("avx512f,avx512vl,avx2,fma"))) void spring_pass_avx512(const SpringNetwork& net, const double* KP,
                                                                              double h, const double* xv, double* fr,
                                                                              double k0 = 0, double c0 = 0) noexcept {
  const size_t s = net.springs.size();
  const double *K = net.stiffness.data(), *C = net.damping.data(), *L = net.rest_length.data();
  const __m256d k0v = _mm256_set1_pd(k0), c0v = _mm256_set1_pd(c0);
  const __m256d hv = _mm256_set1_pd(h), zero = _mm256_setzero_pd();
  const __m256d half = _mm256_set1_pd(0.5), three = _mm256_set1_pd(3.0);
  // Lane selections: (first, second) halves of two pair-sums, and each spring's (g, g, g, g, kh, kh, kh, kh).
  const __m512i lo = _mm512_set_epi64(13, 12, 5, 4, 9, 8, 1, 0), hi = _mm512_set_epi64(15, 14, 7, 6, 11, 10, 3, 2);
  const __m512i pick[4] = {_mm512_set_epi64(4, 4, 4, 4, 0, 0, 0, 0), _mm512_set_epi64(5, 5, 5, 5, 1, 1, 1, 1),
                           _mm512_set_epi64(6, 6, 6, 6, 2, 2, 2, 2), _mm512_set_epi64(7, 7, 7, 7, 3, 3, 3, 3)};
  size_t e = 0;
  for (; e + 4 <= s; e += 4) {
    size_t a[4], b[4];
    __m512d dw[4], p[4];
    for (int q = 0; q < 4; ++q) {
      a[q] = 8 * static_cast<size_t>(net.springs[e + q][0]);
      b[q] = 8 * static_cast<size_t>(net.springs[e + q][1]);
      dw[q] = _mm512_sub_pd(_mm512_load_pd(xv + b[q]), _mm512_load_pd(xv + a[q]));  // (d, w)
      p[q] = _mm512_mul_pd(dw[q], _mm512_shuffle_f64x2(dw[q], dw[q], 0x44));          // (d d, w d)
    }
    // Per 128-bit lane, the pairs' sums side by side (hsum4's first step), then both halves added:
    // (d·d of the four springs, d·w of the four), each ((x + y) + (z + 0)) as in hsum4.
    const __m512d t0 = _mm512_add_pd(_mm512_unpacklo_pd(p[0], p[1]), _mm512_unpackhi_pd(p[0], p[1]));
    const __m512d t1 = _mm512_add_pd(_mm512_unpacklo_pd(p[2], p[3]), _mm512_unpackhi_pd(p[2], p[3]));
    const __m512d sums = _mm512_add_pd(_mm512_permutex2var_pd(t0, lo, t1), _mm512_permutex2var_pd(t0, hi, t1));
    const __m256d l2 = _mm512_castpd512_pd256(sums), dwv = _mm512_extractf64x4_pd(sums, 1);
    // 1/l from rsqrt14 (relative error below 2⁻¹⁴) and two Newton steps (to round-off, see
    // all_pairs_avx512): g = k (1 − L r) + c (d·w) r².
    const __m256d ok = _mm256_cmp_pd(l2, zero, _CMP_GT_OQ);  // l > 0 (false for NaN), as the scalar loop
    __m256d r = _mm256_rsqrt14_pd(l2);
    for (int it = 0; it < 2; ++it)
      r = _mm256_mul_pd(_mm256_mul_pd(half, r), _mm256_fnmadd_pd(_mm256_mul_pd(l2, r), r, three));
    const __m256d k = Uniform ? k0v : _mm256_loadu_pd(K + e);
    const __m256d damp = Uniform ? c0v : _mm256_loadu_pd(C + e);
    __m256d g = _mm256_fnmadd_pd(_mm256_mul_pd(k, _mm256_loadu_pd(L + e)), r, k);
    g = _mm256_fmadd_pd(_mm256_mul_pd(damp, dwv), _mm256_mul_pd(r, r), g);
    g = _mm256_and_pd(g, ok);
    const __m256d kp = Uniform ? k : _mm256_loadu_pd(KP + e);  // the predictor's weight (= k without a volume term)
    const __m512d gk = _mm512_insertf64x4(_mm512_castpd256_pd512(g), _mm256_mul_pd(hv, kp), 1);
    for (int q = 0; q < 4; ++q) {
      const __m512d c = _mm512_mul_pd(_mm512_permutexvar_pd(pick[q], gk), dw[q]);  // (g d, kh w)
      _mm512_store_pd(fr + a[q], _mm512_add_pd(_mm512_load_pd(fr + a[q]), c));
      _mm512_store_pd(fr + b[q], _mm512_sub_pd(_mm512_load_pd(fr + b[q]), c));
    }
  }
  spring_pass_tail(net, KP, h, e, xv, fr);
}

#pragma GCC diagnostic pop

// x, v (n x 3) into xv's lines (x, y, z, 0, vx, vy, vz, 0) and fr's lines zeroed, a vertex at a
// time: two masked 256-bit loads and four aligned stores.
__attribute__((target("avx2"))) void pack_padded(size_t n, const double* xd, const double* vd, double* xv,
                                                   double* fr) noexcept {
  const __m256i m3 = _mm256_set_epi64x(0, -1, -1, -1);
  const __m256d zero = _mm256_setzero_pd();
  for (size_t i = 0; i < n; ++i) {
    _mm256_store_pd(xv + 8 * i, _mm256_maskload_pd(xd + 3 * i, m3));
    _mm256_store_pd(xv + 8 * i + 4, _mm256_maskload_pd(vd + 3 * i, m3));
    _mm256_store_pd(fr + 8 * i, zero);
    _mm256_store_pd(fr + 8 * i + 4, zero);
  }
}

// One tetrahedron's volume gradients from its corners p0..p3 (x, y, z each): 6 ∇V at corners 1, 2
// and 3 — b × c, c × a, a × b, with a, b, c its edges from corner 0 (corner 0's is minus their sum)
// — and 6V. Shared by the scalar volume pass and the four-wide pass's tail.
struct TetGradients {
  double g[3][3];
  double v6;
};
inline TetGradients tet_gradients(const double* p0, const double* p1, const double* p2, const double* p3) noexcept {
  const double ax = p1[0] - p0[0], ay = p1[1] - p0[1], az = p1[2] - p0[2];
  const double bx = p2[0] - p0[0], by = p2[1] - p0[1], bz = p2[2] - p0[2];
  const double cx = p3[0] - p0[0], cy = p3[1] - p0[1], cz = p3[2] - p0[2];
  TetGradients t{{{by * cz - bz * cy, bz * cx - bx * cz, bx * cy - by * cx},
                  {cy * az - cz * ay, cz * ax - cx * az, cx * ay - cy * ax},
                  {ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx}},
                 0.0};
  t.v6 = ax * t.g[0][0] + ay * t.g[0][1] + az * t.g[0][2];
  return t;
}
// s times the gradients onto the corners' forces (corner 0 gets minus their sum).
inline void add_tet_forces(const TetGradients& t, double s, double* f0, double* f1, double* f2, double* f3) noexcept {
  double* fk[3] = {f1, f2, f3};
  for (int k = 0; k < 3; ++k)
    for (int c = 0; c < 3; ++c) fk[k][c] += s * t.g[k][c];
  for (int c = 0; c < 3; ++c) f0[c] -= s * (t.g[0][c] + t.g[1][c] + t.g[2][c]);
}

}  // namespace

double add_volume_forces(const SpringNetwork& net, const double* x, size_t stride, double* f,
                         size_t fstride) noexcept {
  const double kappa = net.volume_modulus;
  double energy = 0;
  const size_t T = net.tets.size();
  for (size_t t = 0; t < T; ++t) {
    const auto& q = net.tets[t];
    const TetGradients g = tet_gradients(x + stride * static_cast<size_t>(q[0]), x + stride * static_cast<size_t>(q[1]),
                                         x + stride * static_cast<size_t>(q[2]), x + stride * static_cast<size_t>(q[3]));
    const double v0 = net.rest_volume[t];
    const double dv = g.v6 / 6 - v0;
    energy += 0.5 * kappa * dv * dv / v0;
    const double s = -kappa * dv / (6 * v0);  // −p / 6, the 1/6 of ∇V folded in
    add_tet_forces(g, s, f + fstride * static_cast<size_t>(q[0]), f + fstride * static_cast<size_t>(q[1]),
                   f + fstride * static_cast<size_t>(q[2]), f + fstride * static_cast<size_t>(q[3]));
  }
  return energy;
}

namespace {

// 4 x (x, y, z, 0) rows → x, y, z registers (lane l from row l): the edge vectors into the
// structure-of-arrays form.
__attribute__((target("avx2"))) inline void transpose_rows(const __m256d* r, __m256d& x, __m256d& y,
                                                           __m256d& z) noexcept {
  const __m256d t0 = _mm256_unpacklo_pd(r[0], r[1]), t1 = _mm256_unpackhi_pd(r[0], r[1]);  // x0 x1 z0 z1, y0 y1 0 0
  const __m256d t2 = _mm256_unpacklo_pd(r[2], r[3]), t3 = _mm256_unpackhi_pd(r[2], r[3]);
  x = _mm256_permute2f128_pd(t0, t2, 0x20);
  y = _mm256_permute2f128_pd(t1, t3, 0x20);
  z = _mm256_permute2f128_pd(t0, t2, 0x31);
}

// x, y, z registers → 4 x (x, y, z, 0) rows, the inverse: the corner forces back into per-vertex form.
__attribute__((target("avx2"))) inline void transpose_columns(__m256d x, __m256d y, __m256d z, __m256d* r) noexcept {
  const __m256d zero = _mm256_setzero_pd();
  const __m256d t0 = _mm256_unpacklo_pd(x, y), t1 = _mm256_unpackhi_pd(x, y);        // x0 y0 x2 y2, x1 y1 x3 y3
  const __m256d t2 = _mm256_unpacklo_pd(z, zero), t3 = _mm256_unpackhi_pd(z, zero);  // z0 0 z2 0, z1 0 z3 0
  r[0] = _mm256_permute2f128_pd(t0, t2, 0x20);
  r[1] = _mm256_permute2f128_pd(t1, t3, 0x20);
  r[2] = _mm256_permute2f128_pd(t0, t2, 0x31);
  r[3] = _mm256_permute2f128_pd(t1, t3, 0x31);
}

// The volume term's forces on the padded layout (x at xv[8i …], sums at fr[8i …], x, y, z, 0): the
// same forces as add_volume_forces (round-off level; the sums in another order of tetrahedra),
// four tetrahedra at a time in the order SpringModel::volume_corners lays out. Each lane is one
// tetrahedron: its edge vectors a, b, c are taken per vertex (three subtractions of 256-bit rows)
// and transposed, the cross products and 6V are then plain lane-wise FMAs (no lane rotations, no
// horizontal sum), and the four corners' forces are transposed back and added one tetrahedron at
// a time, corners 1, 2, 3, 0 as in the scalar form, each a load-add-store of its own, so a corner
// shared within a group is summed right. On the Zen 3 this was tuned on, twelve vgatherdpd per
// group instead of the loads and transposes took 1.5–2.5× as long; transposing the corners'
// positions (four transposes) instead of the edges measured the same. The last (tets mod 4) go
// one at a time.
__attribute__((target("avx2,fma"))) void volume_pass_avx2(const SpringModel& model, const double* xv,
                                                           double* fr) noexcept {
  const size_t T = model.network.tets.size(), G = T / 4;
  const double kappa = model.network.volume_modulus;
  const int* corners = model.volume_corners.data();
  const double* scale = model.volume_scale.data();
  const __m256d k6 = _mm256_set1_pd(kappa / 6);
  for (size_t g = 0; g < G; ++g) {
    const int* o = corners + 16 * g;  // corner c of lane l at o[4c + l]
    __m256d e[3][4];                  // edge k (a, b, c) of lane l as (x, y, z, 0)
    for (int l = 0; l < 4; ++l) {
      const __m256d p0 = _mm256_load_pd(xv + o[l]);
      for (int k = 0; k < 3; ++k) e[k][l] = _mm256_sub_pd(_mm256_load_pd(xv + o[4 * (k + 1) + l]), p0);
    }
    __m256d ax, ay, az, bx, by, bz, cx, cy, cz;
    transpose_rows(e[0], ax, ay, az);
    transpose_rows(e[1], bx, by, bz);
    transpose_rows(e[2], cx, cy, cz);
    // 6 ∇V at corners 1, 2, 3: b × c, c × a, a × b; lane-wise.
    __m256d gx[4], gy[4], gz[4];
    gx[1] = _mm256_fmsub_pd(by, cz, _mm256_mul_pd(bz, cy));
    gy[1] = _mm256_fmsub_pd(bz, cx, _mm256_mul_pd(bx, cz));
    gz[1] = _mm256_fmsub_pd(bx, cy, _mm256_mul_pd(by, cx));
    gx[2] = _mm256_fmsub_pd(cy, az, _mm256_mul_pd(cz, ay));
    gy[2] = _mm256_fmsub_pd(cz, ax, _mm256_mul_pd(cx, az));
    gz[2] = _mm256_fmsub_pd(cx, ay, _mm256_mul_pd(cy, ax));
    gx[3] = _mm256_fmsub_pd(ay, bz, _mm256_mul_pd(az, by));
    gy[3] = _mm256_fmsub_pd(az, bx, _mm256_mul_pd(ax, bz));
    gz[3] = _mm256_fmsub_pd(ax, by, _mm256_mul_pd(ay, bx));
    const __m256d v6 = _mm256_fmadd_pd(az, gz[1], _mm256_fmadd_pd(ay, gy[1], _mm256_mul_pd(ax, gx[1])));  // 6 V
    // −p / 6 = −κ (V − V0) / (6 V0) = κ/6 − κ/(36 V0) · 6V, the factor precomputed per tetrahedron.
    const __m256d sv = _mm256_fnmadd_pd(_mm256_loadu_pd(scale + 4 * g), v6, k6);
    // Corner 0's force is −(the others'): kept positive here and subtracted below.
    gx[0] = _mm256_mul_pd(sv, _mm256_add_pd(_mm256_add_pd(gx[1], gx[2]), gx[3]));
    gy[0] = _mm256_mul_pd(sv, _mm256_add_pd(_mm256_add_pd(gy[1], gy[2]), gy[3]));
    gz[0] = _mm256_mul_pd(sv, _mm256_add_pd(_mm256_add_pd(gz[1], gz[2]), gz[3]));
    __m256d f[4][4];  // corner c's force on lane l's tetrahedron as (x, y, z, 0)
    transpose_columns(gx[0], gy[0], gz[0], f[0]);
    for (int c = 1; c < 4; ++c)
      transpose_columns(_mm256_mul_pd(sv, gx[c]), _mm256_mul_pd(sv, gy[c]), _mm256_mul_pd(sv, gz[c]), f[c]);
    for (int l = 0; l < 4; ++l) {
      for (int c = 1; c < 4; ++c) {
        double* q = fr + o[4 * c + l];
        _mm256_store_pd(q, _mm256_add_pd(_mm256_load_pd(q), f[c][l]));
      }
      double* q = fr + o[l];
      _mm256_store_pd(q, _mm256_sub_pd(_mm256_load_pd(q), f[0][l]));
    }
  }
  for (size_t t = 4 * G; t < T; ++t) {  // the last ones, scalar
    const int* o = corners + 4 * t;
    const TetGradients g = tet_gradients(xv + o[0], xv + o[1], xv + o[2], xv + o[3]);
    add_tet_forces(g, kappa / 6 - scale[t] * g.v6, fr + o[0], fr + o[1], fr + o[2], fr + o[3]);
  }
}

}  // namespace

bool spring_pass_padded_available(const SpringModel& model) noexcept {
  return has_avx2_fma() && !model.network.springs.empty();
}

double* spring_pass_padded(const SpringModel& model, const RowMat3d& x, const RowMat3d& v, double* scratch,
                           SpringKernel kernel) noexcept {
  const SpringNetwork& net = model.network;
  const size_t n = net.size();
  double* p = align64(scratch);  // at most 7 doubles in
  double *xv = p, *fr = p + 8 * n;
  pack_padded(n, x.data(), v.data(), xv, fr);
  const bool uniform = model.uniform_stiffness > 0 && model.uniform_damping && !model.volume_term;
  const double* KP = model.predictor_stiffness.data();
  if (directional(model)) {
    // The directional term has an AVX2 form only (the AVX-512 pass packs (g d, kh w) in one register).
    spring_pass_avx2<true>(net, KP, model.options.dt, xv, fr);
  } else if ((kernel == SpringKernel::best || kernel == SpringKernel::avx512) && has_avx512()) {
    if (uniform) spring_pass_avx512<true>(net, KP, model.options.dt, xv, fr, model.uniform_stiffness, net.damping[0]);
    else spring_pass_avx512<false>(net, KP, model.options.dt, xv, fr);
  } else {
    spring_pass_avx2(net, KP, model.options.dt, xv, fr);
  }
  if (model.volume_term) {
    // The scalar form also for a model whose layout does not match its tetrahedra (one assembled
    // by hand rather than by build_spring_model). spring_pass_padded needs AVX2 + FMA anyway.
    if (kernel == SpringKernel::scalar || model.volume_scale.size() != net.tets.size() ||
        model.volume_corners.size() != 4 * net.tets.size())
      add_volume_forces(net, xv, 8, fr, 8);
    else volume_pass_avx2(model, xv, fr);
  }
  return p;
}

void add_spring_forces_and_stiffness_term(const SpringModel& model, const RowMat3d& x, const RowMat3d& v,
                                          RowMat3d& f, RowMat3d& r, double* scratch, bool vectorised,
                                          SpringKernel kernel) noexcept {
  const size_t n = model.network.size();
  if (!vectorised || kernel == SpringKernel::scalar || !spring_pass_padded_available(model) || scratch == nullptr) {
    if (directional(model))
      spring_loop<true>(model.network, model.predictor_stiffness.data(), model.options.dt, 0, 3, x.data(), v.data(),
                        f.data(), r.data());
    else
      spring_loop<false>(model.network, model.predictor_stiffness.data(), model.options.dt, 0, 3, x.data(), v.data(),
                         f.data(), r.data());
    if (model.volume_term) add_volume_forces(model.network, x.data(), 3, f.data(), 3);
    return;
  }
  const double* fr = spring_pass_padded(model, x, v, scratch, kernel) + 8 * n;
  double* fd = f.data();
  double* rd = r.data();
  for (size_t i = 0; i < n; ++i)
    for (size_t c = 0; c < 3; ++c) {
      fd[3 * i + c] += fr[8 * i + c];
      rd[3 * i + c] += fr[8 * i + 4 + c];
    }
}

}  // namespace palpate::spring
