// simd.h — palpate's small SIMD vector types (after Box2D's b2FloatW): the instruction set lives here
// and nowhere else, so a kernel written on these reads as algebra (Box2D's contact_solver.c,
// MuJoCo's engine_util_blas_avx.h).
//
//   d4  four doubles   (AVX2 + FMA)          f8  eight floats (AVX2 + FMA)
//   d8  eight doubles  (AVX-512 F)           k8  a mask of eight lanes (AVX-512)
//
// Every operation is one instruction (or a fixed sequence, named for what it computes), so a kernel
// keeps the operation order it spells — fma(a, b, c) is one rounding, a * b + c two — and results
// are reproducible bit for bit. The functions carry their instruction set as a target attribute and
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

namespace palpate::simd {

#define PALPATE_SIMD_AVX2 __attribute__((target("avx2,fma"), always_inline)) inline
#define PALPATE_SIMD_AVX512 __attribute__((target("avx512f,avx2,fma"), always_inline)) inline

// GCC 12's AVX-512 intrinsics pass _mm512_undefined_pd() (a self-initialised variable) as the unused
// merge source, which -Wmaybe-uninitialized reports at every use: a false positive.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

struct d4 {
  __m256d v;
};
struct f8 {
  __m256 v;
};
struct d8 {
  __m512d v;
};
using k8 = __mmask8;

// The scalar type and lane count of a vector type.
template <typename V>
struct lanes;
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

// ---- d4: four doubles, AVX2 + FMA ----
template <>
PALPATE_SIMD_AVX2 d4 broadcast<d4>(double a) noexcept { return {_mm256_set1_pd(a)}; }
template <>
PALPATE_SIMD_AVX2 d4 zero<d4>() noexcept { return {_mm256_setzero_pd()}; }
template <>
PALPATE_SIMD_AVX2 d4 loadu<d4>(const double* p) noexcept { return {_mm256_loadu_pd(p)}; }
PALPATE_SIMD_AVX2 void storeu(double* p, d4 a) noexcept { _mm256_storeu_pd(p, a.v); }
PALPATE_SIMD_AVX2 d4 operator+(d4 a, d4 b) noexcept { return {_mm256_add_pd(a.v, b.v)}; }
PALPATE_SIMD_AVX2 d4 operator-(d4 a, d4 b) noexcept { return {_mm256_sub_pd(a.v, b.v)}; }
PALPATE_SIMD_AVX2 d4 operator*(d4 a, d4 b) noexcept { return {_mm256_mul_pd(a.v, b.v)}; }
PALPATE_SIMD_AVX2 d4 fma(d4 a, d4 b, d4 c) noexcept { return {_mm256_fmadd_pd(a.v, b.v, c.v)}; }   // a b + c
PALPATE_SIMD_AVX2 d4 fnma(d4 a, d4 b, d4 c) noexcept { return {_mm256_fnmadd_pd(a.v, b.v, c.v)}; } // c − a b
PALPATE_SIMD_AVX2 d4 max(d4 a, d4 b) noexcept { return {_mm256_max_pd(a.v, b.v)}; }
// All ones in the lanes where a ≥ b (false for NaN), zeros elsewhere; select_or_zero keeps a's lanes there.
PALPATE_SIMD_AVX2 d4 greater_equal(d4 a, d4 b) noexcept { return {_mm256_cmp_pd(a.v, b.v, _CMP_GE_OQ)}; }
PALPATE_SIMD_AVX2 d4 select_or_zero(d4 mask, d4 a) noexcept { return {_mm256_and_pd(a.v, mask.v)}; }
// 1/√a to about 12 bits: the single-precision estimate, widened.
PALPATE_SIMD_AVX2 d4 rsqrt_estimate(d4 a) noexcept { return {_mm256_cvtps_pd(_mm_rsqrt_ps(_mm256_cvtpd_ps(a.v)))}; }
// The lanes' sum as (a0 + a1) + (a2 + a3).
PALPATE_SIMD_AVX2 double sum(d4 a) noexcept {
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

#pragma GCC diagnostic pop

#undef PALPATE_SIMD_AVX2
#undef PALPATE_SIMD_AVX512

}  // namespace palpate::simd
