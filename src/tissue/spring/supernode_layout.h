// supernode_layout.h — where the supernodal factor's values lie: the wide blocks' panel layout,
// shared by the partition (supernodes.cpp, build time) and the sweeps (solve.cpp and, for the
// AVX-512 kernels, solve_avx512.cpp, per tick) (internal).
#pragma once

#include "core/simd.h"

#include <algorithm>
#include <cstddef>

#define PALPATE_HIDDEN __attribute__((visibility("hidden")))

namespace palpate::spring {

// Blocks narrower than this are solved in place; wider ones on a copy of their rows (see sweeps).
constexpr size_t kGatherWidth = 4;

inline size_t round8(size_t x) noexcept {
  return (x + 7) & ~static_cast<size_t>(7);
}

// A wide block (w ≥ kGatherWidth columns, r rows below) is a dense block of rows: its own w rows
// padded to W = w rounded up to 8, then its r rows below padded to a multiple of 8, in panels of
// eight rows (panel p holds rows 8p … 8p + 7). Its columns form groups of eight (the last of w mod
// 8 when that is not 0); group g (columns 8g …) stores its panels from panel g, the diagonal tile
// (L's strictly lower entries there, zeros on and above the diagonal), to the last, each panel
// column by column, eight values per column. Every product over the block then reads it from start
// to end, a column's eight rows are one aligned load, and the triangle is solved tile by tile with
// the same products. The block starts at a multiple of eight values.
struct WideShape {
  size_t own_panels, panels;  // W / 8, all panels (own and below)
  size_t group_start(size_t g) const noexcept {
    // Σ over groups before g of width × 8 × (panels from that group's diagonal on); all groups
    // but the last are eight wide.
    return 64 * (g * panels - g * (g - 1) / 2);
  }
};
inline WideShape wide_shape(size_t w, size_t r) noexcept {
  return {round8(w) / 8, round8(w) / 8 + round8(r) / 8};
}
inline size_t group_width(size_t g, size_t w) noexcept {
  return std::min<size_t>(8, w - 8 * g);
}
inline size_t wide_block_size(size_t w, size_t r) noexcept {
  const WideShape sh = wide_shape(w, r);
  const size_t G = (w + 7) / 8;
  return sh.group_start(G - 1) + group_width(G - 1, w) * 8 * (sh.panels - (G - 1));
}
// Where row `row` (0 … w − 1 the block's own, w + q the q-th row below) of column c is stored.
inline size_t wide_entry(size_t w, size_t r, size_t row, size_t c) noexcept {
  const WideShape sh = wide_shape(w, r);
  const size_t g = c / 8, gw = group_width(g, w);
  const size_t at = row < w ? row : 8 * sh.own_panels + (row - w);  // padded row
  return sh.group_start(g) + (at / 8 - g) * 8 * gw + 8 * (c - 8 * g) + at % 8;
}

// Forward through a group's diagonal tile (gw columns of eight values, entries on and above the
// diagonal zero), column by column, on the group's rows u = (ux, uy, uz) from its first column: in
// A, the arithmetic type (double, or float in the AVX-512 float path); values T widened to A.
template <typename T, typename A>
[[gnu::always_inline]] inline void tile_forward(const T* pan, size_t gw, A* ux, A* uy,
                                                A* uz) noexcept {
  for (size_t c = 0; c < gw; ++c) {
    const T* l = pan + 8 * c;
    const A a0 = ux[c], a1 = uy[c], a2 = uz[c];
    for (size_t j = c + 1; j < 8; ++j) {
      const A v = static_cast<A>(l[j]);
      ux[j] -= v * a0;
      uy[j] -= v * a1;
      uz[j] -= v * a2;
    }
  }
}

// The AVX-512 kernels of the sweeps (solve_avx512.cpp; calls, not inlined: the sweeps' template has
// no target of its own). Call only where has_x86_64_v4() (gather_rows_avx512: AVX-512 F). Hidden:
// called inside the library only, so directly rather than through the PLT.
// bx[q], by[q], bz[q] = the x, y, z of row R[q] (z4[4 R[q]] … + 2) for q < count rounded down to
// eight, eight rows at a time with gathers; returns how many rows it did.
PALPATE_HIDDEN PALPATE_AVX512 size_t gather_rows_avx512(const int* R, size_t count,
                                                        const double* z4, double* bx, double* by,
                                                        double* bz) noexcept;
// The same into float (the wide blocks of the float sweeps).
PALPATE_HIDDEN PALPATE_AVX512DQ size_t gather_rows_f32(const int* R, size_t count, const double* z4,
                                                       float* bx, float* by, float* bz) noexcept;
// A wide block's forward and back substitution in float, sixteen lanes (two panel columns) at a
// time, on its rows f = (fx, fy, fz) (padded, structure of arrays): V the block, w its width, r its
// rows below.
PALPATE_HIDDEN PALPATE_AVX512DQ void wide_forward_f32(const float* V, size_t w, size_t r, float* fx,
                                                      float* fy, float* fz) noexcept;
PALPATE_HIDDEN PALPATE_AVX512DQ void wide_back_f32(const float* V, size_t w, size_t r, float* fx,
                                                   float* fy, float* fz) noexcept;

}  // namespace palpate::spring
