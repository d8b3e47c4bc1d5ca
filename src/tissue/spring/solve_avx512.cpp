// solve_avx512.cpp — the sparse solve's AVX-512 kernels (declared in supernode_layout.h): the
// gathers of a wide block's rows, and its forward and back substitution in float, sixteen lanes
// at a time. Written on core/simd.h's types.
#include "core/simd.h"
#include "tissue/spring/supernode_layout.h"

#include <cstddef>

namespace palpate::spring {

// The gathers (supernode_layout.h).
__attribute__((noinline)) PALPATE_AVX512 size_t gather_rows_avx512(const int* R, size_t count, const double* z4,
                                                                   double* bx, double* by, double* bz) noexcept {
  using namespace simd;
  size_t q = 0;
  for (; q + 8 <= count; q += 8) {
    const i8 idx = load_indices(R + q) << 2;
    storeu(bx + q, gather(z4, idx));
    storeu(by + q, gather(z4 + 1, idx));
    storeu(bz + q, gather(z4 + 2, idx));
  }
  return q;
}

// Float arithmetic for a wide block on AVX-512 (the x86-64-v4 build of the float sweeps): L's
// values are float already, so its products multiply and add in float, sixteen lanes at a time —
// two columns of a panel (eight rows each, stored one after the other) per load — instead of
// widening eight values to double. Half the loads and multiply-adds of the double products;
// rounding in float (the bound is in tests/test_spring_solve.cpp). f = (fx, fy, fz): the block's
// padded rows in float. The diagonal tiles are solved one value at a time, as in sweeps.
// The kernels' inline helpers, and the entries the sweeps call (calls, not inlined).
#define PALPATE_F32 [[gnu::always_inline]] PALPATE_AVX512DQ inline
#define PALPATE_F32_CALL __attribute__((noinline)) PALPATE_AVX512DQ
#define PALPATE_F32_LAMBDA __attribute__((target("avx512f,avx512dq,avx512vl,avx2,fma"), always_inline))

// Columns 2p and 2p + 1 of a panel (16 values), or column 2p alone (the upper lanes zero) when the
// group's width is odd and p is its last pair.
template <bool Single>
PALPATE_F32 simd::f16 pair_load(const float* pp) noexcept {
  if constexpr (Single) return simd::loadu(simd::k16(0x00FF), pp);
  else return simd::loadu<simd::f16>(pp);
}
// (a, …, a, b, …, b): eight lanes each.
PALPATE_F32 simd::f16 pair_broadcast(float a, float b) noexcept {
  return simd::concat(simd::broadcast<simd::f8>(a), simd::broadcast<simd::f8>(b));
}
// The two columns' sums added: low half + high half.
PALPATE_F32 simd::f8 fold(simd::f16 v) noexcept { return simd::low(v) + simd::high(v); }

// f.operator()<P, Odd>() for a group of gw columns (1 … 8): P pairs, the last a single column when
// gw is odd — compile-time counts, so the pairs' registers are not spilled.
template <typename F>
PALPATE_F32 void by_group_width(size_t gw, F&& f) noexcept {
  switch (gw) {
    case 8: f.template operator()<4, false>(); break;
    case 7: f.template operator()<4, true>(); break;
    case 6: f.template operator()<3, false>(); break;
    case 5: f.template operator()<3, true>(); break;
    case 4: f.template operator()<2, false>(); break;
    case 3: f.template operator()<2, true>(); break;
    case 2: f.template operator()<1, false>(); break;
    default: f.template operator()<1, true>(); break;
  }
}

// Forward: per group, the diagonal tile, then every later panel's rows −= L_panel t_group with the
// group's columns in pairs (P pairs, the last a single column when Odd; the broadcasts of t built
// once per group).
template <size_t P, bool Odd>
PALPATE_F32 void wide_forward_panels(const float* pp, size_t gw, size_t c0, size_t row, size_t H, float* fx,
                                     float* fy, float* fz) noexcept {
  using namespace simd;
  f16 tx[P], ty[P], tz[P];
#pragma GCC unroll 4
  for (size_t p = 0; p < P; ++p) {
    const size_t a = c0 + 2 * p, b = 2 * p + 1 < gw ? a + 1 : a;  // b's broadcast meets zeros
    tx[p] = pair_broadcast(fx[a], fx[b]);
    ty[p] = pair_broadcast(fy[a], fy[b]);
    tz[p] = pair_broadcast(fz[a], fz[b]);
  }
  for (; row < H; row += 8, pp += 8 * gw) {
    f16 ax = zero<f16>(), ay = ax, az = ax;
#pragma GCC unroll 4
    for (size_t p = 0; p < P; ++p) {
      const f16 l = Odd && p + 1 == P ? pair_load<true>(pp + 16 * p) : pair_load<false>(pp + 16 * p);
      ax = fma(l, tx[p], ax);
      ay = fma(l, ty[p], ay);
      az = fma(l, tz[p], az);
    }
    storeu(fx + row, loadu<f8>(fx + row) - fold(ax));
    storeu(fy + row, loadu<f8>(fy + row) - fold(ay));
    storeu(fz + row, loadu<f8>(fz + row) - fold(az));
  }
}

PALPATE_F32_CALL void wide_forward_f32(const float* V, size_t w, size_t r, float* fx, float* fy, float* fz) noexcept {
  const WideShape sh = wide_shape(w, r);
  const size_t H = 8 * sh.panels, G = (w + 7) / 8;
  for (size_t grp = 0; grp < G; ++grp) {
    const size_t c0 = 8 * grp, gw = group_width(grp, w);
    const float* pan = V + sh.group_start(grp);
    tile_forward(pan, gw, fx + c0, fy + c0, fz + c0);
    const float* pp = pan + 8 * gw;
    by_group_width(gw, [&]<size_t P, bool Odd>() PALPATE_F32_LAMBDA { wide_forward_panels<P, Odd>(pp, gw, c0, c0 + 8, H, fx, fy, fz); });
  }
}

// Back: per group (last first), each column −= Σ L_panelᵀ g_panel over the later panels (the
// panel's eight rows broadcast to both halves, the pairs' sums side by side in registers), then
// the diagonal tile, last column first.
template <size_t P, bool Odd>
PALPATE_F32 void wide_back_panels(const float* pp, size_t gw, size_t c0, size_t row, size_t H, float* fx,
                                  float* fy, float* fz) noexcept {
  using namespace simd;
  f16 sx[P], sy[P], sz[P];
#pragma GCC unroll 4
  for (size_t p = 0; p < P; ++p) sx[p] = sy[p] = sz[p] = zero<f16>();
  for (; row < H; row += 8, pp += 8 * gw) {
    const f16 gx = twice(loadu<f8>(fx + row));
    const f16 gy = twice(loadu<f8>(fy + row));
    const f16 gz = twice(loadu<f8>(fz + row));
#pragma GCC unroll 4
    for (size_t p = 0; p < P; ++p) {
      const f16 l = Odd && p + 1 == P ? pair_load<true>(pp + 16 * p) : pair_load<false>(pp + 16 * p);
      sx[p] = fma(l, gx, sx[p]);
      sy[p] = fma(l, gy, sy[p]);
      sz[p] = fma(l, gz, sz[p]);
    }
  }
#pragma GCC unroll 4
  for (size_t p = 0; p < P; ++p) {
    const size_t a = c0 + 2 * p;
    fx[a] -= sum_tree(low(sx[p]));
    fy[a] -= sum_tree(low(sy[p]));
    fz[a] -= sum_tree(low(sz[p]));
    if (2 * p + 1 < gw) {
      fx[a + 1] -= sum_tree(high(sx[p]));
      fy[a + 1] -= sum_tree(high(sy[p]));
      fz[a + 1] -= sum_tree(high(sz[p]));
    }
  }
}

PALPATE_F32_CALL void wide_back_f32(const float* V, size_t w, size_t r, float* fx, float* fy, float* fz) noexcept {
  const WideShape sh = wide_shape(w, r);
  const size_t H = 8 * sh.panels, G = (w + 7) / 8;
  for (size_t grp = G; grp-- > 0;) {
    const size_t c0 = 8 * grp, gw = group_width(grp, w);
    const float* pan = V + sh.group_start(grp);
    const float* pp = pan + 8 * gw;
    by_group_width(gw, [&]<size_t P, bool Odd>() PALPATE_F32_LAMBDA { wide_back_panels<P, Odd>(pp, gw, c0, c0 + 8, H, fx, fy, fz); });
    for (size_t c = gw; c-- > 0;) {
      const float* l = pan + 8 * c;
      float t0 = 0, t1 = 0, t2 = 0;
      for (size_t j = c + 1; j < 8; ++j) {
        t0 += l[j] * fx[c0 + j]; t1 += l[j] * fy[c0 + j]; t2 += l[j] * fz[c0 + j];
      }
      fx[c0 + c] -= t0; fy[c0 + c] -= t1; fz[c0 + c] -= t2;
    }
  }
}

// The rows below of a wide block from z4 into float (x, y, z arrays), eight at a time with
// gathers; returns how many it did (the caller does the rest).
PALPATE_F32_CALL size_t gather_rows_f32(const int* R, size_t count, const double* z4, float* bx, float* by,
                                        float* bz) noexcept {
  using namespace simd;
  size_t q = 0;
  for (; q + 8 <= count; q += 8) {
    const i8 idx = load_indices(R + q) << 2;
    storeu(bx + q, to_float(gather(z4, idx)));
    storeu(by + q, to_float(gather(z4 + 1, idx)));
    storeu(bz + q, to_float(gather(z4 + 2, idx)));
  }
  return q;
}
#undef PALPATE_F32
#undef PALPATE_F32_CALL
#undef PALPATE_F32_LAMBDA

}  // namespace palpate::spring
