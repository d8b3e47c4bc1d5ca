// laws.h — the spring model's force laws, each once as a scalar function with its equation and
// source, and beside it its vector form on the types of core/simd.h (the kernels in all_pairs.cpp,
// spring_pass.cpp and volume_pass.cpp call these and nothing else for the physics); each vector
// form is tested against its scalar law (tests/test_spring_laws.cpp) to a stated bound: the vector
// forms fuse multiply-adds the scalar laws round twice (internal).
//
// A vector form is a function of its own rather than the scalar template instantiated on d4: GCC
// inlines an instruction-set function only into one compiled for that set, so the form carries
// the set's target (PALPATE_AVX2 …), which the scalar law, called from portable code, cannot.
#pragma once

#include "core/simd.h"

#include <algorithm>

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

// ---- Generic networks (spring_pass.cpp) ----

// The Hooke spring with a damper along it, on any graph of springs (DESIGN.md §2; the seed paper's
// mass-spring-damper organ, docs/models/mass-spring.md "Forces"):
//   f_i += g d,  f_j −= g d,  g = [k (l − L) + c (Δv·u)] / l,
// d = x_j − x_i (m), l = |d|, u = d/l, Δv = v_j − v_i (m/s); k (N/m), c (N·s/m), L (m);
// dvu = Δv·u (m/s), inv_l = 1/l (1/m). Returns g (N/m), evaluated as (k (l − L) + c dvu) inv_l.
template <typename T>
inline T spring_factor(T k, T c, T L, T l, T inv_l, T dvu) noexcept {
  return (k * (l - L) + c * dvu) * inv_l;
}
// The same operations lane-wise on d4. Where FMA is enabled GCC contracts a product and a sum into
// one fused operation (C++'s default -ffp-contract=fast), so within a few ulps of the scalar law,
// not equal to it (bound: tests/test_spring_laws.cpp).
[[gnu::always_inline]] PALPATE_AVX2 inline simd::d4 spring_factor_avx2(simd::d4 k, simd::d4 c, simd::d4 L, simd::d4 l,
                                                                      simd::d4 inv_l, simd::d4 dvu) noexcept {
  using namespace simd;
  return (k * (l - L) + c * dvu) * inv_l;
}

// A spring's exact share of the stiffness matrix in the −h K v term of the predictor's right-hand
// side (SpringModelOptions::directional_correction; docs/models/mass-spring.md): for w = v_j − v_i,
//   K_e w = k [u uᵀ + max(0, 1 − L/l)(I − u uᵀ)] w = k w − μ/h (w − (u·w) u),  μ = h k min(1, L/l),
// so r_i += h KP w − μ w + ν d,  ν = μ (d·w)/l²  (KP the spring's predictor weight). Returns μ (N·s/m)
// and ν (N·s/m³) for h (s), k, L, l.
template <typename T>
inline T directional_mu(T h, T k, T L, T l) noexcept {
  return h * k * std::min(T(1), L / l);
}
template <typename T>
inline T directional_nu(T mu, T dw, T l) noexcept {
  return mu * dw / (l * l);
}
// The vector forms with 1/l for the divisions: μ = (h k) min(1, L (1/l)), ν = (μ (d·w)) (1/l)²,
// within a few ulps of the scalar law (bound: tests/test_spring_laws.cpp).
[[gnu::always_inline]] PALPATE_AVX2 inline simd::d4 directional_mu_avx2(simd::d4 hk, simd::d4 L,
                                                                       simd::d4 inv_l) noexcept {
  using namespace simd;
  return hk * min(broadcast<d4>(1.0), L * inv_l);
}
[[gnu::always_inline]] PALPATE_AVX2 inline simd::d4 directional_nu_avx2(simd::d4 mu, simd::d4 dw,
                                                                       simd::d4 inv_l) noexcept {
  using namespace simd;
  return (mu * dw) * (inv_l * inv_l);
}

// ---- The volume term (volume_pass.cpp) ----

// A tetrahedron's energy ½ κ (V − V0)²/V0 (docs/models/mass-spring.md "Volume"; the per-element
// volume constraint of Teschner et al. 2004 as a penalty): p = κ (V − V0)/V0 and f_c = −p ∇_c V.
// With its edges a, b, c from corner 0 (m): 6 ∇V at corners 1, 2, 3 is b × c, c × a, a × b (corner
// 0's minus their sum), 6 V = a · (b × c). g[k] is corner k + 1's 6 ∇V (m²), v6 = 6 V (m³).
template <typename T>
struct TetGradients {
  T g[3][3];  // [corner − 1][x, y, z]
  T v6;
};
template <typename T>
inline TetGradients<T> tet_gradients(T ax, T ay, T az, T bx, T by, T bz, T cx, T cy, T cz) noexcept {
  TetGradients<T> t{{{by * cz - bz * cy, bz * cx - bx * cz, bx * cy - by * cx},
                     {cy * az - cz * ay, cz * ax - cx * az, cx * ay - cy * ax},
                     {ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx}},
                    T(0)};
  t.v6 = ax * t.g[0][0] + ay * t.g[0][1] + az * t.g[0][2];
  return t;
}
// The factor s with f_c = s (6 ∇_c V): s = −p/6 = −κ (V − V0)/(6 V0), V = v6/6 (N/m²).
template <typename T>
inline T volume_force_factor(T kappa, T v0, T v6) noexcept {
  const T dv = v6 / 6 - v0;
  return -kappa * dv / (6 * v0);
}
// The same with κ/6 and κ/(36 V0) precomputed (SolverLayouts::volume_scale): s = κ/6 − κ/(36 V0) · 6V.
template <typename T>
inline T volume_force_factor_precomputed(T kappa6, T scale, T v6) noexcept {
  return kappa6 - scale * v6;
}

// The vector forms: the cross products and 6 V as fused multiply-subtracts (b_y c_z − b_z c_y in one
// rounding after b_z c_y), the factor as one fused κ/6 − scale · 6V; within a few ulps of the scalar
// law (bound: tests/test_spring_laws.cpp).
[[gnu::always_inline]] PALPATE_AVX2 inline TetGradients<simd::d4> tet_gradients_avx2(simd::d4 ax, simd::d4 ay,
                                                                                    simd::d4 az, simd::d4 bx,
                                                                                    simd::d4 by, simd::d4 bz,
                                                                                    simd::d4 cx, simd::d4 cy,
                                                                                    simd::d4 cz) noexcept {
  using namespace simd;
  TetGradients<d4> t{{{fms(by, cz, bz * cy), fms(bz, cx, bx * cz), fms(bx, cy, by * cx)},
                      {fms(cy, az, cz * ay), fms(cz, ax, cx * az), fms(cx, ay, cy * ax)},
                      {fms(ay, bz, az * by), fms(az, bx, ax * bz), fms(ax, by, ay * bx)}},
                     {}};
  t.v6 = fma(az, t.g[0][2], fma(ay, t.g[0][1], ax * t.g[0][0]));
  return t;
}
[[gnu::always_inline]] PALPATE_AVX2 inline simd::d4 volume_force_factor_avx2(simd::d4 kappa6, simd::d4 scale,
                                                                            simd::d4 v6) noexcept {
  return simd::fnma(scale, v6, kappa6);
}

}  // namespace palpate::spring
