// all_pairs.cpp — the all-pairs spring forces (the seed paper's topology: every vertex to every
// other), O(n²) per step on structure-of-arrays copies: the scalar reference and the AVX2, AVX-512
// and single-precision AVX2 kernels.
#include <palpate/spring.h>

#include "core/simd.h"
#include "tissue/spring/cpu.h"
#include "tissue/spring/forces.h"
#include "tissue/spring/laws.h"
#include "tissue/spring/stages.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

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
      const double g = all_pairs_spring_factor(k, c, net.rest_length[e], r, dvd);
      sx += g * dx; sy += g * dy; sz += g * dz;
      FX[j] -= g * dx; FY[j] -= g * dy; FZ[j] -= g * dz;
    }
    FX[i] += sx; FY[i] += sy; FZ[i] += sz;
  }
}

// The same on a vector type of core/simd.h, W = 4 (d4) or 8 (f8) springs at a time with AVX2 + FMA;
// the last (n − i − 1) mod W of a row one at a time by the scalar law. 1/l comes from the 12-bit
// reciprocal square root estimate and Newton steps r ← (r/2)(3 − (l² r) r) (rsqrt_newton_step, here
// with one rounding for 3 − (l² r) r): three in double (≈ 48 bits, then rounding), one in float
// (≈ 23 bits): no square root or division in the loop. RL, KS, CS: rest lengths, stiffnesses and
// dampings per spring (Uniform: KS[0], CS[0] for every spring); p as all_pairs_portable's, N apart.
template <typename V, bool Uniform, typename T = simd::scalar_t<V>>
PALPATE_AVX2 void all_pairs_avx2(int n, const T* RL, const T* KS, const T* CS, T* p, size_t N) noexcept {
  using namespace simd;
  constexpr int W = lanes<V>::count;
  constexpr int kNewtonSteps = sizeof(T) == sizeof(double) ? 3 : 1;
  constexpr T kTiny = sizeof(T) == sizeof(double) ? T(1e-30) : 1e-30f;  // m², coincident below
  const T *X = p, *Y = p + N, *Z = p + 2 * N, *VX = p + 3 * N, *VY = p + 4 * N, *VZ = p + 5 * N;
  T *FX = p + 6 * N, *FY = p + 7 * N, *FZ = p + 8 * N;
  const V tiny = broadcast<V>(kTiny);
  // Uniform: one stiffness and damping, read once (f's stores could alias KS and CS as far as the
  // compiler knows, so a read in the loop would be repeated).
  const T k0 = KS[0], c0 = CS[0];
  const V k0v = broadcast<V>(k0), c0v = broadcast<V>(c0);
  size_t e = 0;
  for (int i = 0; i + 1 < n; ++i) {
    const V xi = broadcast<V>(X[i]), yi = broadcast<V>(Y[i]), zi = broadcast<V>(Z[i]);
    const V vxi = broadcast<V>(VX[i]), vyi = broadcast<V>(VY[i]), vzi = broadcast<V>(VZ[i]);
    V sx = zero<V>(), sy = sx, sz = sx;
    int j = i + 1;
    for (; j + W <= n; j += W, e += W) {
      const V dx = loadu<V>(X + j) - xi, dy = loadu<V>(Y + j) - yi, dz = loadu<V>(Z + j) - zi;
      const V l2 = fma(dz, dz, fma(dy, dy, dx * dx));
      const V ok = greater_equal(l2, tiny);
      const V l2c = max(l2, tiny);
      V r = rsqrt_estimate(l2c);
      for (int it = 0; it < kNewtonSteps; ++it) r = rsqrt_newton_step_avx2(l2c, r);
      const V k = Uniform ? k0v : loadu<V>(KS + e);
      const V c = Uniform ? c0v : loadu<V>(CS + e);
      const V dvd = fma(loadu<V>(VZ + j) - vzi, dz, fma(loadu<V>(VY + j) - vyi, dy, (loadu<V>(VX + j) - vxi) * dx));
      // g = k − k L r + c (Δv·d) r², zero where the vertices coincide.
      const V g = select_or_zero(ok, all_pairs_spring_factor_avx2(k, c, loadu<V>(RL + e), r, dvd));
      const V fx = g * dx, fy = g * dy, fz = g * dz;
      sx = sx + fx; sy = sy + fy; sz = sz + fz;
      storeu(FX + j, loadu<V>(FX + j) - fx);
      storeu(FY + j, loadu<V>(FY + j) - fy);
      storeu(FZ + j, loadu<V>(FZ + j) - fz);
    }
    T tx = sum(sx), ty = sum(sy), tz = sum(sz);
    for (; j < n; ++j, ++e) {
      const T dx = X[j] - X[i], dy = Y[j] - Y[i], dz = Z[j] - Z[i];
      const T l2 = dx * dx + dy * dy + dz * dz;
      if (!(l2 >= kTiny)) continue;
      const T r = T(1) / std::sqrt(l2);
      const T dvd = (VX[j] - VX[i]) * dx + (VY[j] - VY[i]) * dy + (VZ[j] - VZ[i]) * dz;
      const T g = all_pairs_spring_factor(Uniform ? k0 : KS[e], Uniform ? c0 : CS[e], RL[e], r, dvd);
      tx += g * dx; ty += g * dy; tz += g * dz;
      FX[j] -= g * dx; FY[j] -= g * dy; FZ[j] -= g * dz;
    }
    FX[i] += tx; FY[i] += ty; FZ[i] += tz;
  }
}

// The same with AVX-512 (d8), eight springs at a time and the row's last (n − i − 1) mod 8 springs
// in one masked pass (no scalar tail). 1/l comes from the double-precision estimate rsqrt14
// (relative error below 2⁻¹⁴) and two Newton steps r ← (r/2)(3 − (l² r) r): the error e becomes
// ≈ 1.5 e² per step, 2⁻¹⁴ → 2⁻²⁷ → 2⁻⁵³, i.e. rounding, the same accuracy as the AVX2 kernel's three
// steps from the 12-bit float estimate.
#if !defined(__clang__)  // GCC's warnings (clang has no -Wmaybe-uninitialized)
#pragma GCC diagnostic push  // GCC 12's AVX-512 intrinsics: see core/simd.h
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
// Eight doubles from a (a vertex array at the block's first j), or only the lanes in m (the others
// zero) when the block is not full.
template <bool Full>
[[gnu::always_inline]] PALPATE_AVX512 inline simd::d8 load8(simd::k8 m, const double* a) noexcept {
  return Full ? simd::loadu<simd::d8>(a) : simd::loadu(m, a);
}

// The same for a per-spring array from the block's first spring e: consecutive values into the
// lanes of m (contiguous), the first into its lowest lane.
template <bool Full>
[[gnu::always_inline]] PALPATE_AVX512 inline simd::d8 load8_springs(simd::k8 m, const double* a) noexcept {
  return Full ? simd::loadu<simd::d8>(a) : simd::expand_load(m, a);
}

// One row i against the block of columns j … j + 7 (lanes in m): its sums s and f_j updated.
template <bool Uniform, bool Full>
[[gnu::always_inline]] PALPATE_AVX512 inline void all_pairs_avx512_block(
    const double* X, const double* Y, const double* Z, const double* VX, const double* VY, const double* VZ,
    double* FX, double* FY, double* FZ, const double* RL, const double* KS, const double* CS, size_t e, int j,
    simd::k8 m, simd::d8 xi, simd::d8 yi, simd::d8 zi, simd::d8 vxi, simd::d8 vyi, simd::d8 vzi, simd::d8& sx,
    simd::d8& sy, simd::d8& sz) noexcept {
  using namespace simd;
  const d8 tiny = broadcast<d8>(1e-30);
  const d8 dx = load8<Full>(m, X + j) - xi, dy = load8<Full>(m, Y + j) - yi, dz = load8<Full>(m, Z + j) - zi;
  const d8 l2 = fma(dz, dz, fma(dy, dy, dx * dx));
  const k8 ok = greater_equal(m, l2, tiny);
  const d8 l2c = max(l2, tiny);
  d8 r = rsqrt_estimate(l2c);
  for (int it = 0; it < 2; ++it) r = rsqrt_newton_step_avx512(l2c, r);
  const d8 k = Uniform ? broadcast<d8>(KS[0]) : load8_springs<Full>(m, KS + e);
  const d8 c = Uniform ? broadcast<d8>(CS[0]) : load8_springs<Full>(m, CS + e);
  const d8 dvd = fma(load8<Full>(m, VZ + j) - vzi, dz,
                     fma(load8<Full>(m, VY + j) - vyi, dy, (load8<Full>(m, VX + j) - vxi) * dx));
  // g = k − k L r + c (Δv·d) r², zero where the vertices coincide and in the lanes past the row.
  const d8 g = select_or_zero(ok, all_pairs_spring_factor_avx512(k, c, load8_springs<Full>(m, RL + e), r, dvd));
  const d8 fx = g * dx, fy = g * dy, fz = g * dz;
  sx = sx + fx; sy = sy + fy; sz = sz + fz;
  if (Full) {
    storeu(FX + j, loadu<d8>(FX + j) - fx);
    storeu(FY + j, loadu<d8>(FY + j) - fy);
    storeu(FZ + j, loadu<d8>(FZ + j) - fz);
  } else {
    storeu(FX + j, m, loadu(m, FX + j) - fx);
    storeu(FY + j, m, loadu(m, FY + j) - fy);
    storeu(FZ + j, m, loadu(m, FZ + j) - fz);
  }
}

// One row's share of a block of eight columns j: the force g d on each vertex j from row vertex i
// (lanes in m; the others zero), added to the row's sums and to f (the block's total, subtracted
// from f_j by the caller).
struct AllPairsRow {
  simd::d8 xi, yi, zi, vxi, vyi, vzi, sx, sy, sz;
};

template <bool Uniform>
[[gnu::always_inline]] PALPATE_AVX512 inline void all_pairs_avx512_row(simd::d8 xj, simd::d8 yj, simd::d8 zj,
                                                                       simd::d8 vxj, simd::d8 vyj, simd::d8 vzj,
                                                                       simd::k8 m, simd::d8 rl, simd::d8 k, simd::d8 c,
                                                                       AllPairsRow& row, simd::d8& fx, simd::d8& fy,
                                                                       simd::d8& fz) noexcept {
  using namespace simd;
  const d8 tiny = broadcast<d8>(1e-30);
  const d8 dx = xj - row.xi, dy = yj - row.yi, dz = zj - row.zi;
  const d8 l2 = fma(dz, dz, fma(dy, dy, dx * dx));
  const k8 ok = greater_equal(m, l2, tiny);
  const d8 l2c = max(l2, tiny);
  d8 r = rsqrt_estimate(l2c);
  for (int it = 0; it < 2; ++it) r = rsqrt_newton_step_avx512(l2c, r);
  const d8 dvd = fma(vzj - row.vzi, dz, fma(vyj - row.vyi, dy, (vxj - row.vxi) * dx));
  const d8 g = select_or_zero(ok, all_pairs_spring_factor_avx512(k, c, rl, r, dvd));
  const d8 gx = g * dx, gy = g * dy, gz = g * dz;
  row.sx = row.sx + gx; row.sy = row.sy + gy; row.sz = row.sz + gz;
  fx = fx + gx; fy = fy + gy; fz = fz + gz;
}

// A row's per-spring value for a block: Mode 0, the row's first block (values from a into the lanes
// of m, which start past lane 0: expand-load); 1, a full block; 2, the row's last (lanes from 0).
template <int Mode>
[[gnu::always_inline]] PALPATE_AVX512 inline simd::d8 all_pairs_spring_values(simd::k8 m, const double* a) noexcept {
  if constexpr (Mode == 0) return simd::expand_load(m, a);
  else if constexpr (Mode == 1) return simd::loadu<simd::d8>(a);
  else return simd::loadu(m, a);
}

// A vertex array's eight values at an aligned block j: all (Mode 1) or the lanes in m.
template <int Mode>
[[gnu::always_inline]] PALPATE_AVX512 inline simd::d8 all_pairs_vertex_values(simd::k8 m, const double* a) noexcept {
  if constexpr (Mode == 1) return simd::load<simd::d8>(a);
  else return simd::load(m, a);
}

// Two rows i, i + 1 against one aligned block of eight columns j: the vertex values at j are loaded,
// and f_j loaded and stored, once for both. ea, eb: the index of row a's, b's spring at the
// block's first lane it holds (Mode 0) or at lane 0 (Modes 1, 2).
template <bool Uniform, int Mode>
[[gnu::always_inline]] PALPATE_AVX512 inline void all_pairs_avx512_two(
    const double* X, const double* Y, const double* Z, const double* VX, const double* VY, const double* VZ,
    double* FX, double* FY, double* FZ, const double* RL, const double* KS, const double* CS, int j, size_t ea,
    size_t eb, simd::k8 ma, simd::k8 mb, AllPairsRow& a, AllPairsRow& b) noexcept {
  using namespace simd;
  const k8 m = static_cast<k8>(ma | mb);
  const d8 xj = all_pairs_vertex_values<Mode>(m, X + j), yj = all_pairs_vertex_values<Mode>(m, Y + j),
           zj = all_pairs_vertex_values<Mode>(m, Z + j);
  const d8 vxj = all_pairs_vertex_values<Mode>(m, VX + j), vyj = all_pairs_vertex_values<Mode>(m, VY + j),
           vzj = all_pairs_vertex_values<Mode>(m, VZ + j);
  d8 fx = zero<d8>(), fy = fx, fz = fx;
  const d8 ka = Uniform ? broadcast<d8>(KS[0]) : all_pairs_spring_values<Mode>(ma, KS + ea);
  const d8 ca = Uniform ? broadcast<d8>(CS[0]) : all_pairs_spring_values<Mode>(ma, CS + ea);
  all_pairs_avx512_row<Uniform>(xj, yj, zj, vxj, vyj, vzj, ma, all_pairs_spring_values<Mode>(ma, RL + ea), ka, ca, a,
                                fx, fy, fz);
  const d8 kb = Uniform ? broadcast<d8>(KS[0]) : all_pairs_spring_values<Mode>(mb, KS + eb);
  const d8 cb = Uniform ? broadcast<d8>(CS[0]) : all_pairs_spring_values<Mode>(mb, CS + eb);
  all_pairs_avx512_row<Uniform>(xj, yj, zj, vxj, vyj, vzj, mb, all_pairs_spring_values<Mode>(mb, RL + eb), kb, cb, b,
                                fx, fy, fz);
  if (Mode == 1) {
    store(FX + j, load<d8>(FX + j) - fx);
    store(FY + j, load<d8>(FY + j) - fy);
    store(FZ + j, load<d8>(FZ + j) - fz);
  } else {
    store(FX + j, m, load(m, FX + j) - fx);
    store(FY + j, m, load(m, FY + j) - fy);
    store(FZ + j, m, load(m, FZ + j) - fz);
  }
}

// The row sums' accumulator for vertex q: its position and velocity broadcast, the sums zero.
[[gnu::always_inline]] PALPATE_AVX512 inline AllPairsRow all_pairs_row(const double* X, const double* Y,
                                                                       const double* Z, const double* VX,
                                                                       const double* VY, const double* VZ,
                                                                       int q) noexcept {
  using namespace simd;
  return AllPairsRow{broadcast<d8>(X[q]),  broadcast<d8>(Y[q]),  broadcast<d8>(Z[q]),
                     broadcast<d8>(VX[q]), broadcast<d8>(VY[q]), broadcast<d8>(VZ[q]),
                     zero<d8>(),           zero<d8>(),           zero<d8>()};
}

// p must be 64-byte aligned and N a multiple of 8: every block then starts at a multiple of 8,
// so its loads and stores of x … fz are aligned (unaligned 512-bit accesses split across two cache
// lines, which cost more than the arithmetic); a row's first block is masked below j = i + 1 and
// its rest lengths (per-spring arrays start at the row's first spring, not aligned) expand-loaded.
// Rows go two at a time, sharing each block's loads of x … vz and its load and store of f.
template <bool Uniform>
PALPATE_AVX512 void all_pairs_avx512(int n, const SpringNetwork& net, double* p, size_t N) noexcept {
  using namespace simd;
  const double *X = p, *Y = p + N, *Z = p + 2 * N, *VX = p + 3 * N, *VY = p + 4 * N, *VZ = p + 5 * N;
  double *FX = p + 6 * N, *FY = p + 7 * N, *FZ = p + 8 * N;
  const double* RL = net.rest_length.data();
  const double* KS = net.stiffness.data();
  const double* CS = net.damping.data();
  size_t e = 0;
  int i = 0;
  // Rows two at a time: row i + 1's springs start n − i − 1 after row i's.
  for (; i + 2 < n; i += 2) {
    AllPairsRow a = all_pairs_row(X, Y, Z, VX, VY, VZ, i), b = all_pairs_row(X, Y, Z, VX, VY, VZ, i + 1);
    const size_t eb = e + static_cast<size_t>(n - i - 1);  // row i + 1's first spring (i + 1, i + 2)
    const int j0 = (i + 1) & ~7;
    const int hi = std::min(8, n - j0);
    auto lanes_from = [hi](int lo) {
      return lo >= 8 ? k8{0} : static_cast<k8>(((1u << hi) - 1) & ~((1u << lo) - 1));
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
      const k8 m = static_cast<k8>((1u << (n - j)) - 1);
      all_pairs_avx512_two<Uniform, 2>(X, Y, Z, VX, VY, VZ, FX, FY, FZ, RL, KS, CS, j,
                                       e + static_cast<size_t>(j - i - 1), eb + static_cast<size_t>(j - i - 2), m, m,
                                       a, b);
    }
    FX[i] += sum(a.sx); FY[i] += sum(a.sy); FZ[i] += sum(a.sz);
    FX[i + 1] += sum(b.sx); FY[i + 1] += sum(b.sy); FZ[i + 1] += sum(b.sz);
    e = eb + static_cast<size_t>(n - i - 2);
  }
  for (; i + 1 < n; ++i) {  // the last row when n − 1 is odd
    AllPairsRow row = all_pairs_row(X, Y, Z, VX, VY, VZ, i);
    // First block: lanes j = i + 1 … within [j0, j0 + 8) and below n.
    const int j0 = (i + 1) & ~7;
    const int lo = i + 1 - j0, hi = std::min(8, n - j0);
    const k8 m0 = static_cast<k8>(((1u << hi) - 1) & ~((1u << lo) - 1));
    all_pairs_avx512_block<Uniform, false>(X, Y, Z, VX, VY, VZ, FX, FY, FZ, RL, KS, CS, e, j0, m0, row.xi, row.yi,
                                           row.zi, row.vxi, row.vyi, row.vzi, row.sx, row.sy, row.sz);
    e += static_cast<size_t>(hi - lo);
    int j = j0 + 8;
    for (; j + 8 <= n; j += 8, e += 8)
      all_pairs_avx512_block<Uniform, true>(X, Y, Z, VX, VY, VZ, FX, FY, FZ, RL, KS, CS, e, j, 0xFF, row.xi, row.yi,
                                            row.zi, row.vxi, row.vyi, row.vzi, row.sx, row.sy, row.sz);
    if (j < n) {
      const int left = n - j;  // 1 … 7
      const k8 m = static_cast<k8>((1u << left) - 1);
      all_pairs_avx512_block<Uniform, false>(X, Y, Z, VX, VY, VZ, FX, FY, FZ, RL, KS, CS, e, j, m, row.xi, row.yi,
                                             row.zi, row.vxi, row.vyi, row.vzi, row.sx, row.sy, row.sz);
      e += static_cast<size_t>(left);
    }
    FX[i] += sum(row.sx); FY[i] += sum(row.sy); FZ[i] += sum(row.sz);
  }
}

#if !defined(__clang__)
#pragma GCC diagnostic pop
#endif

// The uniform all-pairs forces in single precision (SpringModelOptions::single_precision) are
// all_pairs_avx2<f8, true>: eight springs at a time, 1/l from the estimate and one Newton step
// (≈ 23 bits), on (9n) floats x, y, z, vx, vy, vz, fx, fy, fz with the (s) rest lengths in float.

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
    const double *RL = net.rest_length.data(), *KS = net.stiffness.data(), *CS = net.damping.data();
    if (uniform) all_pairs_avx2<simd::d4, true>(n, RL, KS, CS, p, N);
    else all_pairs_avx2<simd::d4, false>(n, RL, KS, CS, p, N);
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
    const float k = static_cast<float>(net.stiffness[0]), c = static_cast<float>(net.damping[0]);
    all_pairs_avx2<simd::f8, true>(static_cast<int>(n), model.solver->rest_length_single.data(), &k, &c, q,
                                   static_cast<size_t>(n));
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
