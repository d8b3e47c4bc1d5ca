// laws.h — the spring model's force laws, each once as a scalar function with its equation and
// source; the vector kernels (all_pairs.cpp, spring_pass.cpp) compute the same laws on the vector
// types of core/simd.h and are tested against these (tests/test_spring_laws.cpp) (internal).
#pragma once

#include "core/simd.h"

namespace palpate::spring {

// The damped Hooke spring of the all-pairs network (the seed paper, "Elastically Deformable 3D
// Organs for Haptic Surgical Simulation": every vertex tied to every other by a spring and damper;
// DESIGN.md §2) written with r = 1/l, so that a kernel needs no square root or division:
//   f_i += g d,  f_j −= g d,  g = k (1 − L r) + c (Δv·d) r²,
// d = x_j − x_i (m), l = |d| = 1/r, Δv = v_j − v_i (m/s), k stiffness (N/m), c damping (N·s/m),
// L rest length (m); dvd = Δv·d (m²/s). Returns g (N/m). Evaluated as k − k L r + c dvd r r, left to
// right (the scalar kernels' order: T is double, or float in the single-precision kernel).
template <typename T>
inline T all_pairs_spring_factor(T k, T c, T L, T r, T dvd) noexcept {
  return k - k * L * r + c * dvd * r * r;
}

// One Newton step of 1/√a from an estimate r: r (3 − a r²)/2, the error e becoming ≈ 1.5 e²
// (12 bits → 23 → 46 → rounding; 14 → 27 → 53). Evaluated as (r/2)(3 − (a r) r).
template <typename T>
inline T rsqrt_newton_step(T a, T r) noexcept {
  return (T(0.5) * r) * (T(3) - (a * r) * r);
}

// The vector forms, on d4 or f8 (AVX2 + FMA; call from PALPATE_AVX2 code). all_pairs_spring_factor as
// fma(c dvd, r r, k − (k L) r): two fused operations, so within a few ulps of the scalar law, not
// equal to it (bound: tests/test_spring_laws.cpp).
template <typename V>
[[gnu::always_inline]] PALPATE_AVX2 inline V all_pairs_spring_factor_avx2(V k, V c, V L, V r, V dvd) noexcept {
  using namespace simd;
  return fma(c * dvd, r * r, fnma(k * L, r, k));
}
// rsqrt_newton_step as (r/2) fnma(a r, r, 3): 3 − (a r) r in one rounding.
template <typename V>
[[gnu::always_inline]] PALPATE_AVX2 inline V rsqrt_newton_step_avx2(V a, V r) noexcept {
  using namespace simd;
  using T = scalar_t<V>;
  return (broadcast<V>(T(0.5)) * r) * fnma(a * r, r, broadcast<V>(T(3)));
}

// The same two on d8 (AVX-512; call from PALPATE_AVX512 code), the same operations: GCC inlines a
// function only into one compiled for at least its instruction set, so one template cannot serve
// both d4 and d8.
[[gnu::always_inline]] PALPATE_AVX512 inline simd::d8 all_pairs_spring_factor_avx512(simd::d8 k, simd::d8 c, simd::d8 L,
                                                                                    simd::d8 r, simd::d8 dvd) noexcept {
  using namespace simd;
  return fma(c * dvd, r * r, fnma(k * L, r, k));
}
[[gnu::always_inline]] PALPATE_AVX512 inline simd::d8 rsqrt_newton_step_avx512(simd::d8 a, simd::d8 r) noexcept {
  using namespace simd;
  return (broadcast<d8>(0.5) * r) * fnma(a * r, r, broadcast<d8>(3.0));
}

}  // namespace palpate::spring
