// simd.h — palpate's small SIMD vector types (after Box2D's b2FloatW): the instruction set lives here
// and nowhere else, so a kernel written on these reads as algebra (Box2D's contact_solver.c,
// MuJoCo's engine_util_blas_avx.h).
//
//   f4  four floats    (SSE2, the baseline)
//   d4  four doubles   (AVX2 + FMA)          f8  eight floats (AVX2 + FMA)
//   d8  eight doubles  (AVX-512 F)           k8  a mask of eight lanes (AVX-512)
//   f16 sixteen floats (AVX-512 F, DQ, VL)   k16 a mask of sixteen lanes
//   i8  eight int32 indices (for gathers)
// and the layout operations the kernels need, each named for what it computes (sums, transpose3,
// splat, concat, gather …): no kernel outside this file names an instruction.
//
// Every operation is one instruction (or a fixed sequence, named for what it computes), so a kernel
// keeps the operation order it spells and its results are reproducible bit for bit: fma(a, b, c) is
// one rounding; a * b + c is two in a kernel compiled without FMA (PALPATE_AVX2_NO_FMA), while where
// FMA is enabled GCC may fuse it (C++'s default -ffp-contract=fast), the same way in every build. The functions carry their instruction set as a target attribute and
// are always inlined: call them only from functions compiled for that set (PALPATE_AVX2 /
// PALPATE_AVX512 on the kernel, after a CPU check). GCC does not inline such a function into one
// without the attribute, so a kernel template over the vector type must itself carry the target
// (a template over d4 and f8 can share PALPATE_AVX2; one over d4 and d8 cannot share one target).
#pragma once

#include <immintrin.h>

#include <cstddef>

// The targets of the kernels written on these types.
#define PALPATE_AVX2 __attribute__((target("avx2,fma")))
#define PALPATE_AVX512 __attribute__((target("avx512f,avx2,fma")))
// AVX2 without FMA, for a kernel whose every value must be its scalar expression's operation for
// operation: where FMA is enabled GCC contracts a b + c into one fused operation (C++ defaults to
// -ffp-contract=fast), vector operations included.
#define PALPATE_AVX2_NO_FMA __attribute__((target("avx2")))
// AVX-512 with its 256-bit forms (VL): d4 kernels that also use rsqrt14 (has_avx512() checks VL).
#define PALPATE_AVX512VL __attribute__((target("avx512f,avx512vl,avx2,fma")))
// AVX-512 with DQ and VL (x86-64-v4): the f16 kernels, whose halves move as f8s.
#define PALPATE_AVX512DQ __attribute__((target("avx512f,avx512dq,avx512vl,avx2,fma")))

namespace palpate::simd {

#define PALPATE_SIMD_AVX2 __attribute__((target("avx2,fma"), always_inline)) inline
#define PALPATE_SIMD_AVX2_NO_FMA __attribute__((target("avx2"), always_inline)) inline
#define PALPATE_SIMD_AVX512 __attribute__((target("avx512f,avx2,fma"), always_inline)) inline
#define PALPATE_SIMD_AVX512VL __attribute__((target("avx512f,avx512vl,avx2,fma"), always_inline)) inline
#define PALPATE_SIMD_AVX512DQ __attribute__((target("avx512f,avx512dq,avx512vl,avx2,fma"), always_inline)) inline

// GCC 12's AVX-512 intrinsics pass _mm512_undefined_pd() (a self-initialised variable) as the unused
// merge source, which -Wmaybe-uninitialized reports at every use: a false positive.
#if !defined(__clang__)  // GCC's warnings (clang has no -Wmaybe-uninitialized)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

struct f4 {  // SSE2: every x86-64 CPU has it, so no target and no CPU check
  __m128 v;
};
struct d4 {
  __m256d v;
};
struct f8 {
  __m256 v;
};
struct d8 {
  __m512d v;
};
struct f16 {
  __m512 v;
};
struct i8 {  // eight 32-bit indices
  __m256i v;
};
using k8 = __mmask8;
using k16 = __mmask16;

// The scalar type and lane count of a vector type.
template <typename V>
struct lanes;
template <>
struct lanes<f4> {
  using scalar = float;
  static constexpr int count = 4;
};
template <>
struct lanes<d4> {
  using scalar = double;
  static constexpr int count = 4;
};
template <>
struct lanes<f8> {
  using scalar = float;
  static constexpr int count = 8;
};
template <>
struct lanes<d8> {
  using scalar = double;
  static constexpr int count = 8;
};
template <>
struct lanes<f16> {
  using scalar = float;
  static constexpr int count = 16;
};
template <typename V>
using scalar_t = typename lanes<V>::scalar;

// What needs the vector type named (broadcast<V>(a), zero<V>(), loadu<V>(p), load<V>(p)): declared
// here, one specialisation per type below.
template <typename V>
V broadcast(scalar_t<V> a) noexcept;
template <typename V>
V zero() noexcept;
template <typename V>
V loadu(const scalar_t<V>* p) noexcept;
template <typename V>
V load(const scalar_t<V>* p) noexcept;  // p at a boundary of the vector's size

// ---- f4: four floats, SSE2 (the x86-64 baseline) ----
template <>
inline f4 broadcast<f4>(float a) noexcept { return {_mm_set1_ps(a)}; }
template <>
inline f4 zero<f4>() noexcept { return {_mm_setzero_ps()}; }
template <>
inline f4 loadu<f4>(const float* p) noexcept { return {_mm_loadu_ps(p)}; }
inline void storeu(float* p, f4 a) noexcept { _mm_storeu_ps(p, a.v); }
inline f4 operator+(f4 a, f4 b) noexcept { return {_mm_add_ps(a.v, b.v)}; }
inline f4 operator-(f4 a, f4 b) noexcept { return {_mm_sub_ps(a.v, b.v)}; }
inline f4 operator/(f4 a, f4 b) noexcept { return {_mm_div_ps(a.v, b.v)}; }
inline f4 sqrt(f4 a) noexcept { return {_mm_sqrt_ps(a.v)}; }
inline f4 max(f4 a, f4 b) noexcept { return {_mm_max_ps(a.v, b.v)}; }
// The lanes' sum, lane 0 first, one at a time.
inline float sum(f4 a) noexcept {
  alignas(16) float h[4];
  _mm_store_ps(h, a.v);
  return h[0] + h[1] + h[2] + h[3];
}

// ---- d4: four doubles, AVX2 + FMA ----
template <>
PALPATE_SIMD_AVX2_NO_FMA d4 broadcast<d4>(double a) noexcept { return {_mm256_set1_pd(a)}; }
template <>
PALPATE_SIMD_AVX2_NO_FMA d4 zero<d4>() noexcept { return {_mm256_setzero_pd()}; }
template <>
PALPATE_SIMD_AVX2_NO_FMA d4 loadu<d4>(const double* p) noexcept { return {_mm256_loadu_pd(p)}; }
template <>
PALPATE_SIMD_AVX2_NO_FMA d4 load<d4>(const double* p) noexcept { return {_mm256_load_pd(p)}; }  // 32-byte aligned
// (p[0], p[1], p[2], 0): a point or vector of an (n x 3) array, reading no fourth value.
PALPATE_SIMD_AVX2_NO_FMA d4 load3(const double* p) noexcept {
  return {_mm256_maskload_pd(p, _mm256_set_epi64x(0, -1, -1, -1))};
}
PALPATE_SIMD_AVX2_NO_FMA void storeu(double* p, d4 a) noexcept { _mm256_storeu_pd(p, a.v); }
PALPATE_SIMD_AVX2_NO_FMA void store(double* p, d4 a) noexcept { _mm256_store_pd(p, a.v); }  // 32-byte aligned
PALPATE_SIMD_AVX2_NO_FMA d4 operator+(d4 a, d4 b) noexcept { return {_mm256_add_pd(a.v, b.v)}; }
PALPATE_SIMD_AVX2_NO_FMA d4 operator-(d4 a, d4 b) noexcept { return {_mm256_sub_pd(a.v, b.v)}; }
PALPATE_SIMD_AVX2_NO_FMA d4 operator*(d4 a, d4 b) noexcept { return {_mm256_mul_pd(a.v, b.v)}; }
PALPATE_SIMD_AVX2_NO_FMA d4 operator/(d4 a, d4 b) noexcept { return {_mm256_div_pd(a.v, b.v)}; }
PALPATE_SIMD_AVX2_NO_FMA d4 sqrt(d4 a) noexcept { return {_mm256_sqrt_pd(a.v)}; }
PALPATE_SIMD_AVX2 d4 fma(d4 a, d4 b, d4 c) noexcept { return {_mm256_fmadd_pd(a.v, b.v, c.v)}; }   // a b + c
PALPATE_SIMD_AVX2 d4 fms(d4 a, d4 b, d4 c) noexcept { return {_mm256_fmsub_pd(a.v, b.v, c.v)}; }   // a b − c
PALPATE_SIMD_AVX2 d4 fnma(d4 a, d4 b, d4 c) noexcept { return {_mm256_fnmadd_pd(a.v, b.v, c.v)}; } // c − a b
PALPATE_SIMD_AVX2_NO_FMA d4 max(d4 a, d4 b) noexcept { return {_mm256_max_pd(a.v, b.v)}; }
PALPATE_SIMD_AVX2_NO_FMA d4 min(d4 a, d4 b) noexcept { return {_mm256_min_pd(a.v, b.v)}; }
// All ones in the lanes where a ≥ b (a > b) (false for NaN), zeros elsewhere; select_or_zero keeps
// a's lanes there.
PALPATE_SIMD_AVX2_NO_FMA d4 greater_equal(d4 a, d4 b) noexcept { return {_mm256_cmp_pd(a.v, b.v, _CMP_GE_OQ)}; }
PALPATE_SIMD_AVX2_NO_FMA d4 greater(d4 a, d4 b) noexcept { return {_mm256_cmp_pd(a.v, b.v, _CMP_GT_OQ)}; }
PALPATE_SIMD_AVX2_NO_FMA d4 select_or_zero(d4 mask, d4 a) noexcept { return {_mm256_and_pd(a.v, mask.v)}; }
// Lane Q of a in all four lanes.
template <int Q>
PALPATE_SIMD_AVX2_NO_FMA d4 splat(d4 a) noexcept {
  static_assert(Q >= 0 && Q < 4);
  return {_mm256_permute4x64_pd(a.v, Q * 0x55)};
}
// (Σ a0, Σ a1, Σ a2, Σ a3), each sum as (a[0] + a[1]) + (a[2] + a[3]): four horizontal sums at once.
PALPATE_SIMD_AVX2_NO_FMA d4 sums(d4 a0, d4 a1, d4 a2, d4 a3) noexcept {
  const __m256d t0 = _mm256_hadd_pd(a0.v, a1.v);  // a0[0]+a0[1], a1[0]+a1[1], a0[2]+a0[3], a1[2]+a1[3]
  const __m256d t1 = _mm256_hadd_pd(a2.v, a3.v);
  return {_mm256_add_pd(_mm256_permute2f128_pd(t0, t1, 0x20), _mm256_permute2f128_pd(t0, t1, 0x31))};
}
// Four (x, y, z, ·) rows → the x, y and z columns (lane l from row l): points into the
// structure-of-arrays form. The rows' fourth lanes are dropped.
PALPATE_SIMD_AVX2_NO_FMA void transpose3(const d4 r[4], d4& x, d4& y, d4& z) noexcept {
  const __m256d t0 = _mm256_unpacklo_pd(r[0].v, r[1].v), t1 = _mm256_unpackhi_pd(r[0].v, r[1].v);
  const __m256d t2 = _mm256_unpacklo_pd(r[2].v, r[3].v), t3 = _mm256_unpackhi_pd(r[2].v, r[3].v);
  x = {_mm256_permute2f128_pd(t0, t2, 0x20)};
  y = {_mm256_permute2f128_pd(t1, t3, 0x20)};
  z = {_mm256_permute2f128_pd(t0, t2, 0x31)};
}
// The inverse: x, y, z columns → four (x, y, z, 0) rows.
PALPATE_SIMD_AVX2_NO_FMA void transpose3(d4 x, d4 y, d4 z, d4 r[4]) noexcept {
  const __m256d zero = _mm256_setzero_pd();
  const __m256d t0 = _mm256_unpacklo_pd(x.v, y.v), t1 = _mm256_unpackhi_pd(x.v, y.v);  // x0 y0 x2 y2, x1 y1 x3 y3
  const __m256d t2 = _mm256_unpacklo_pd(z.v, zero), t3 = _mm256_unpackhi_pd(z.v, zero);  // z0 0 z2 0, z1 0 z3 0
  r[0] = {_mm256_permute2f128_pd(t0, t2, 0x20)};
  r[1] = {_mm256_permute2f128_pd(t1, t3, 0x20)};
  r[2] = {_mm256_permute2f128_pd(t0, t2, 0x31)};
  r[3] = {_mm256_permute2f128_pd(t1, t3, 0x31)};
}
// 1/√a with a relative error below 2⁻¹⁴ (AVX-512 VL).
PALPATE_SIMD_AVX512VL d4 rsqrt14(d4 a) noexcept { return {_mm256_rsqrt14_pd(a.v)}; }
// 1/√a to about 12 bits: the single-precision estimate, widened.
PALPATE_SIMD_AVX2_NO_FMA d4 rsqrt_estimate(d4 a) noexcept { return {_mm256_cvtps_pd(_mm_rsqrt_ps(_mm256_cvtpd_ps(a.v)))}; }
// The lanes' sum as (a0 + a1) + (a2 + a3).
PALPATE_SIMD_AVX2_NO_FMA double sum(d4 a) noexcept {
  alignas(32) double h[4];
  _mm256_store_pd(h, a.v);
  return (h[0] + h[1]) + (h[2] + h[3]);
}

// ---- f8: eight floats, AVX2 + FMA ----
template <>
PALPATE_SIMD_AVX2 f8 broadcast<f8>(float a) noexcept { return {_mm256_set1_ps(a)}; }
template <>
PALPATE_SIMD_AVX2 f8 zero<f8>() noexcept { return {_mm256_setzero_ps()}; }
template <>
PALPATE_SIMD_AVX2 f8 loadu<f8>(const float* p) noexcept { return {_mm256_loadu_ps(p)}; }
PALPATE_SIMD_AVX2 void storeu(float* p, f8 a) noexcept { _mm256_storeu_ps(p, a.v); }
PALPATE_SIMD_AVX2 f8 operator+(f8 a, f8 b) noexcept { return {_mm256_add_ps(a.v, b.v)}; }
PALPATE_SIMD_AVX2 f8 operator-(f8 a, f8 b) noexcept { return {_mm256_sub_ps(a.v, b.v)}; }
PALPATE_SIMD_AVX2 f8 operator*(f8 a, f8 b) noexcept { return {_mm256_mul_ps(a.v, b.v)}; }
PALPATE_SIMD_AVX2 f8 fma(f8 a, f8 b, f8 c) noexcept { return {_mm256_fmadd_ps(a.v, b.v, c.v)}; }
PALPATE_SIMD_AVX2 f8 fnma(f8 a, f8 b, f8 c) noexcept { return {_mm256_fnmadd_ps(a.v, b.v, c.v)}; }
PALPATE_SIMD_AVX2 f8 max(f8 a, f8 b) noexcept { return {_mm256_max_ps(a.v, b.v)}; }
PALPATE_SIMD_AVX2 f8 greater_equal(f8 a, f8 b) noexcept { return {_mm256_cmp_ps(a.v, b.v, _CMP_GE_OQ)}; }
PALPATE_SIMD_AVX2 f8 select_or_zero(f8 mask, f8 a) noexcept { return {_mm256_and_ps(a.v, mask.v)}; }
// 1/√a to about 12 bits.
PALPATE_SIMD_AVX2 f8 rsqrt_estimate(f8 a) noexcept { return {_mm256_rsqrt_ps(a.v)}; }
// The lanes' sum as a tree: ((a0 + a4) + (a2 + a6)) + ((a1 + a5) + (a3 + a7)).
PALPATE_SIMD_AVX2 float sum_tree(f8 a) noexcept {
  const __m128 s = _mm_add_ps(_mm256_castps256_ps128(a.v), _mm256_extractf128_ps(a.v, 1));
  const __m128 t = _mm_add_ps(s, _mm_movehl_ps(s, s));
  return _mm_cvtss_f32(_mm_add_ss(t, _mm_movehdup_ps(t)));
}
// The lanes' sum, lane 0 first, one at a time.
PALPATE_SIMD_AVX2 float sum(f8 a) noexcept {
  alignas(32) float h[8];
  _mm256_store_ps(h, a.v);
  float s = 0;
  for (int q = 0; q < 8; ++q) s += h[q];
  return s;
}

// ---- d8: eight doubles, AVX-512 F; k8 masks its lanes ----
template <>
PALPATE_SIMD_AVX512 d8 broadcast<d8>(double a) noexcept { return {_mm512_set1_pd(a)}; }
template <>
PALPATE_SIMD_AVX512 d8 zero<d8>() noexcept { return {_mm512_setzero_pd()}; }
template <>
PALPATE_SIMD_AVX512 d8 loadu<d8>(const double* p) noexcept { return {_mm512_loadu_pd(p)}; }
template <>
PALPATE_SIMD_AVX512 d8 load<d8>(const double* p) noexcept { return {_mm512_load_pd(p)}; }  // 64-byte aligned
// The lanes in m from p + lane, zeros in the others (aligned: p at a 64-byte boundary).
PALPATE_SIMD_AVX512 d8 loadu(k8 m, const double* p) noexcept { return {_mm512_maskz_loadu_pd(m, p)}; }
PALPATE_SIMD_AVX512 d8 load(k8 m, const double* p) noexcept { return {_mm512_maskz_load_pd(m, p)}; }
// Consecutive values from p into the lanes of m, the first into its lowest lane; zeros elsewhere.
PALPATE_SIMD_AVX512 d8 expand_load(k8 m, const double* p) noexcept { return {_mm512_maskz_expandloadu_pd(m, p)}; }
PALPATE_SIMD_AVX512 void storeu(double* p, d8 a) noexcept { _mm512_storeu_pd(p, a.v); }
PALPATE_SIMD_AVX512 void store(double* p, d8 a) noexcept { _mm512_store_pd(p, a.v); }
PALPATE_SIMD_AVX512 void storeu(double* p, k8 m, d8 a) noexcept { _mm512_mask_storeu_pd(p, m, a.v); }
PALPATE_SIMD_AVX512 void store(double* p, k8 m, d8 a) noexcept { _mm512_mask_store_pd(p, m, a.v); }
PALPATE_SIMD_AVX512 d8 operator+(d8 a, d8 b) noexcept { return {_mm512_add_pd(a.v, b.v)}; }
PALPATE_SIMD_AVX512 d8 operator-(d8 a, d8 b) noexcept { return {_mm512_sub_pd(a.v, b.v)}; }
PALPATE_SIMD_AVX512 d8 operator*(d8 a, d8 b) noexcept { return {_mm512_mul_pd(a.v, b.v)}; }
PALPATE_SIMD_AVX512 d8 fma(d8 a, d8 b, d8 c) noexcept { return {_mm512_fmadd_pd(a.v, b.v, c.v)}; }
PALPATE_SIMD_AVX512 d8 fnma(d8 a, d8 b, d8 c) noexcept { return {_mm512_fnmadd_pd(a.v, b.v, c.v)}; }
PALPATE_SIMD_AVX512 d8 max(d8 a, d8 b) noexcept { return {_mm512_max_pd(a.v, b.v)}; }
// The lanes of m where a ≥ b (false for NaN).
PALPATE_SIMD_AVX512 k8 greater_equal(k8 m, d8 a, d8 b) noexcept { return _mm512_mask_cmp_pd_mask(m, a.v, b.v, _CMP_GE_OQ); }
PALPATE_SIMD_AVX512 d8 select_or_zero(k8 m, d8 a) noexcept { return {_mm512_maskz_mov_pd(m, a.v)}; }
// 1/√a with a relative error below 2⁻¹⁴.
PALPATE_SIMD_AVX512 d8 rsqrt_estimate(d8 a) noexcept { return {_mm512_rsqrt14_pd(a.v)}; }
// The lanes' sum in the order of _mm512_reduce_add_pd (halves added, then quarters, then pairs).
PALPATE_SIMD_AVX512 double sum(d8 a) noexcept { return _mm512_reduce_add_pd(a.v); }
// The halves of a d8 as d4s, and two d4s as one d8 (lo in lanes 0–3).
PALPATE_SIMD_AVX512 d4 low(d8 a) noexcept { return {_mm512_castpd512_pd256(a.v)}; }
PALPATE_SIMD_AVX512 d4 high(d8 a) noexcept { return {_mm512_extractf64x4_pd(a.v, 1)}; }
PALPATE_SIMD_AVX512 d8 concat(d4 lo, d4 hi) noexcept { return {_mm512_insertf64x4(_mm512_castpd256_pd512(lo.v), hi.v, 1)}; }
// The low half in both halves.
PALPATE_SIMD_AVX512 d8 low_twice(d8 a) noexcept { return {_mm512_shuffle_f64x2(a.v, a.v, 0x44)}; }
// Lane Q of each half across its half: (a[Q] ×4, a[4 + Q] ×4).
template <int Q>
PALPATE_SIMD_AVX512 d8 splat_halves(d8 a) noexcept {
  static_assert(Q >= 0 && Q < 4);
  return {_mm512_permutexvar_pd(_mm512_set_epi64(4 + Q, 4 + Q, 4 + Q, 4 + Q, Q, Q, Q, Q), a.v)};
}
// Eight indices from p; each shifted left by n bits (times 2ⁿ).
PALPATE_SIMD_AVX512 i8 load_indices(const int* p) noexcept {
  return {_mm256_loadu_si256(reinterpret_cast<const __m256i*>(p))};
}
PALPATE_SIMD_AVX512 i8 operator<<(i8 a, int n) noexcept { return {_mm256_slli_epi32(a.v, n)}; }
// (base[idx0], …, base[idx7]): eight doubles gathered.
PALPATE_SIMD_AVX512 d8 gather(const double* base, i8 idx) noexcept { return {_mm512_i32gather_pd(idx.v, base, 8)}; }
// Each lane rounded to float.
PALPATE_SIMD_AVX512 f8 to_float(d8 a) noexcept { return {_mm512_cvtpd_ps(a.v)}; }
// sums() in each half: (Σ lo(a0), Σ lo(a1), Σ lo(a2), Σ lo(a3), Σ hi(a0), …, Σ hi(a3)), each sum as
// (a[0] + a[1]) + (a[2] + a[3]) like sums() (pairs per 128-bit lane side by side, then the pairs'
// halves gathered and added).
PALPATE_SIMD_AVX512 d8 sums_halves(d8 a0, d8 a1, d8 a2, d8 a3) noexcept {
  const __m512d t0 = _mm512_add_pd(_mm512_unpacklo_pd(a0.v, a1.v), _mm512_unpackhi_pd(a0.v, a1.v));
  const __m512d t1 = _mm512_add_pd(_mm512_unpacklo_pd(a2.v, a3.v), _mm512_unpackhi_pd(a2.v, a3.v));
  const __m512i lo = _mm512_set_epi64(13, 12, 5, 4, 9, 8, 1, 0), hi = _mm512_set_epi64(15, 14, 7, 6, 11, 10, 3, 2);
  return {_mm512_add_pd(_mm512_permutex2var_pd(t0, lo, t1), _mm512_permutex2var_pd(t0, hi, t1))};
}

// ---- f16: sixteen floats, AVX-512 F + DQ + VL; k16 masks its lanes ----
template <>
PALPATE_SIMD_AVX512DQ f16 zero<f16>() noexcept { return {_mm512_setzero_ps()}; }
template <>
PALPATE_SIMD_AVX512DQ f16 loadu<f16>(const float* p) noexcept { return {_mm512_loadu_ps(p)}; }
// The lanes in m from p + lane, zeros in the others.
PALPATE_SIMD_AVX512DQ f16 loadu(k16 m, const float* p) noexcept { return {_mm512_maskz_loadu_ps(m, p)}; }
PALPATE_SIMD_AVX512DQ f16 fma(f16 a, f16 b, f16 c) noexcept { return {_mm512_fmadd_ps(a.v, b.v, c.v)}; }
// The halves as f8s, two f8s as one f16 (lo in lanes 0–7), and one f8 in both halves.
PALPATE_SIMD_AVX512DQ f8 low(f16 a) noexcept { return {_mm512_castps512_ps256(a.v)}; }
PALPATE_SIMD_AVX512DQ f8 high(f16 a) noexcept { return {_mm512_extractf32x8_ps(a.v, 1)}; }
PALPATE_SIMD_AVX512DQ f16 concat(f8 lo, f8 hi) noexcept { return {_mm512_insertf32x8(_mm512_castps256_ps512(lo.v), hi.v, 1)}; }
PALPATE_SIMD_AVX512DQ f16 twice(f8 a) noexcept { return {_mm512_broadcast_f32x8(a.v)}; }

#if !defined(__clang__)
#pragma GCC diagnostic pop
#endif

#undef PALPATE_SIMD_AVX2
#undef PALPATE_SIMD_AVX512
#undef PALPATE_SIMD_AVX512VL
#undef PALPATE_SIMD_AVX512DQ
#undef PALPATE_SIMD_AVX2_NO_FMA

}  // namespace palpate::simd
