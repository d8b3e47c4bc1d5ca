// solve.cpp — the predictor's per-tick solves: the sparse factor's triangular sweeps, supernodal
// (the step's) and column by column (the reference), and the dense inverse's products.
#include "tissue/spring/solve.h"

#include "tissue/spring/cpu.h"
#include "tissue/spring/cut.h"
#include "tissue/spring/supernode_layout.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <iterator>
#include <type_traits>

namespace palpate::spring {

namespace {

// GCC vector-extension types for the portable sweeps (compiled twice, PALPATE_TWICE; the AVX-512
// kernels below use core/simd.h). Four doubles: one AVX register in the v3 build, two SSE2 ones in
// the default one.
typedef double vd4 __attribute__((vector_size(32)));

// Eight doubles: one AVX-512 register in the x86-64-v4 build, two AVX ones in the v3 build.
typedef double vd8 __attribute__((vector_size(64)));
typedef float vf8 __attribute__((vector_size(32)));

// (Macros, not functions: no vector type crosses a function boundary, which would tie the ABI to
// AVX.) LOAD8 widens float values to double: every accumulation is in double.
#define PALPATE_LOAD4(v, p) \
  vd4 v;                     \
  std::memcpy(&v, (p), sizeof v)
#define PALPATE_STORE4(p, v) std::memcpy((p), &(v), sizeof(vd4))
#define PALPATE_LOAD8(T, v, p)                 \
  vd8 v;                                        \
  if constexpr (std::is_same_v<T, float>) {    \
    vf8 v##_f;                                  \
    std::memcpy(&v##_f, (p), sizeof v##_f);    \
    v = __builtin_convertvector(v##_f, vd8);    \
  } else {                                     \
    std::memcpy(&v, (p), sizeof v);            \
  }
#define PALPATE_HSUM8(s) (((s)[0] + (s)[1]) + ((s)[2] + (s)[3])) + (((s)[4] + (s)[5]) + ((s)[6] + (s)[7]))



// Forward substitution L y = b, then y ← D⁻¹ y, then back substitution Lᵀ x = y, in place on the
// right-hand side z4, (4n): each vertex's x, y, z and a zero, so a narrow block updates the three
// coordinates of a row with one four-wide multiply-add per entry of L, in place.
// A wide block (layout at WideShape) copies its rows, own and below, into g (structure of arrays:
// x, y, z, each m long, m ≥ the tallest padded block) and works there group of columns by group:
// forward, the diagonal tile is solved, then every later panel's rows get −L_panel t_group, eight
// rows and the group's columns at a time (the rows below start from zero and are added to z
// after); back, each column of the group gets −Σ L_panelᵀ g_panel over its later panels, the
// group's columns summed in registers side by side, then the diagonal tile is solved.
template <typename T, bool Wide = false>
__attribute__((always_inline)) inline void sweeps(const SpringSupernodes& sn, const T* values, const double* inv_diag,
                                                  double* z4, double* g, size_t m,
                                                  const PredictorCorrection* mid) noexcept {
  const int S = static_cast<int>(sn.first_column.size()) - 1;
  const int* fc = sn.first_column.data();
  const int* rs = sn.row_start.data();
  const int* rows = sn.rows.data();
  const size_t* vs = sn.value_start.data();
  double* __restrict gx = g;
  double* __restrict gy = g + m;
  double* __restrict gz = g + 2 * m;
  // Float arithmetic in the wide blocks (float values on AVX-512): their rows in float, same place.
  constexpr bool F32 = Wide && std::is_same_v<T, float>;
  float* __restrict fx = reinterpret_cast<float*>(g);
  float* __restrict fy = fx + m;
  float* __restrict fz = fx + 2 * m;
  auto at = [z4](int vertex) { return z4 + 4 * static_cast<size_t>(vertex); };
  // The narrow blocks' chunk program (SpringSupernodes).
  const int* cst = sn.chunk_start.data();
  const int* piv = sn.pivot.data();
  const int* crow = sn.chunk_rows.data();
  const T* cval;
  if constexpr (std::is_same_v<T, float>) cval = sn.chunk_values_single.data();
  else cval = sn.chunk_values.data();
  // A wide block's rows in (ux, uy, uz) — double, or float in the F32 path — forward: its own rows
  // from z and the others (to H) zero; after, its own rows back to z and the rows below added to theirs.
  auto forward_in = [&](auto* ux, auto* uy, auto* uz, int f, size_t w, size_t H) {
    using U = std::remove_pointer_t<decltype(ux)>;
    for (size_t i = 0; i < w; ++i) {
      const double* z = at(f + static_cast<int>(i));
      ux[i] = static_cast<U>(z[0]); uy[i] = static_cast<U>(z[1]); uz[i] = static_cast<U>(z[2]);
    }
    std::fill(ux + w, ux + H, U{0});
    std::fill(uy + w, uy + H, U{0});
    std::fill(uz + w, uz + H, U{0});
  };
  auto forward_out = [&](const auto* ux, const auto* uy, const auto* uz, int f, size_t w, const int* R, size_t r,
                         size_t W) {
    for (size_t i = 0; i < w; ++i) {
      double* z = at(f + static_cast<int>(i));
      z[0] = ux[i]; z[1] = uy[i]; z[2] = uz[i];
    }
    for (size_t q = 0; q < r; ++q) {
      double* z = at(R[q]);
      const vd4 u = {ux[W + q], uy[W + q], uz[W + q], 0.0};
      PALPATE_LOAD4(y, z);
      y += u;
      PALPATE_STORE4(z, y);
    }
  };
  for (int k = 0; k < S; ++k) {
    const int f = fc[k];
    const size_t w = static_cast<size_t>(fc[k + 1] - f), r = static_cast<size_t>(rs[k + 1] - rs[k]);
    const int* R = rows + rs[k];
    const T* V = values + vs[k];
    if (w < kGatherWidth) {
      // A run of narrow blocks: its chunks in order, z[row] −= L(row, pivot) z[pivot] in place
      // (a padding entry subtracts 0 from the pivot's own row).
      const int K = sn.run_end[static_cast<size_t>(k)];
      for (int q = cst[k], end = cst[K]; q < end; ++q) {
        PALPATE_LOAD4(a, at(piv[q]));
        const int* rr = crow + 4 * static_cast<size_t>(q);
        const T* vv = cval + 4 * static_cast<size_t>(q);
#pragma GCC unroll 4
        for (int l = 0; l < 4; ++l) {
          double* z = at(rr[l]);
          const double v = static_cast<double>(vv[l]);
          PALPATE_LOAD4(y, z);
          y -= vd4{v, v, v, v} * a;
          PALPATE_STORE4(z, y);
        }
      }
      k = K - 1;
      continue;
    }
    const WideShape sh = wide_shape(w, r);
    const size_t W = 8 * sh.own_panels, H = 8 * sh.panels, G = (w + 7) / 8;
    if constexpr (F32) {
      forward_in(fx, fy, fz, f, w, H);
      wide_forward_f32(reinterpret_cast<const float*>(V), w, r, fx, fy, fz);
      forward_out(fx, fy, fz, f, w, R, r, W);
      continue;
    }
    forward_in(gx, gy, gz, f, w, H);
    for (size_t grp = 0; grp < G; ++grp) {
      const size_t c0 = 8 * grp, gw = group_width(grp, w);
      const T* pan = V + sh.group_start(grp);
      tile_forward(pan, gw, gx + c0, gy + c0, gz + c0);
      const T* pp = pan + 8 * gw;
      for (size_t row = c0 + 8; row < H; row += 8, pp += 8 * gw) {
        vd8 ux, uy, uz;
        std::memcpy(&ux, gx + row, sizeof ux);
        std::memcpy(&uy, gy + row, sizeof uy);
        std::memcpy(&uz, gz + row, sizeof uz);
        for (size_t c = 0; c < gw; ++c) {
          PALPATE_LOAD8(T, l, pp + 8 * c);
          ux -= l * gx[c0 + c]; uy -= l * gy[c0 + c]; uz -= l * gz[c0 + c];
        }
        std::memcpy(gx + row, &ux, sizeof ux);
        std::memcpy(gy + row, &uy, sizeof uy);
        std::memcpy(gz + row, &uz, sizeof uz);
      }
    }
    forward_out(gx, gy, gz, f, w, R, r, W);
  }
  const int n = fc[S];
  for (int i = 0; i < n; ++i) {
    const double d = inv_diag[i];
    PALPATE_LOAD4(y, at(i));
    y *= vd4{d, d, d, d};
    PALPATE_STORE4(at(i), y);
  }
  if (mid) apply_middle(*mid, z4);  // a cut's correction, between the sweeps (cut.h)
  for (int k = S - 1; k >= 0; --k) {
    const int f = fc[k];
    const size_t w = static_cast<size_t>(fc[k + 1] - f), r = static_cast<size_t>(rs[k + 1] - rs[k]);
    const int* R = rows + rs[k];
    const T* V = values + vs[k];
    if (w < kGatherWidth) {
      // A run of narrow blocks, its chunks last first: z[pivot] −= Σ L(row, pivot) z[row] (a
      // padding entry reads the pivot's own row times 0), two chains of multiply-adds per chunk.
      const int K0 = sn.run_begin[static_cast<size_t>(k)];
      for (int q = cst[k + 1], begin = cst[K0]; q-- > begin;) {
        const int* rr = crow + 4 * static_cast<size_t>(q);
        const T* vv = cval + 4 * static_cast<size_t>(q);
        const double v0 = static_cast<double>(vv[0]), v1 = static_cast<double>(vv[1]);
        const double v2 = static_cast<double>(vv[2]), v3 = static_cast<double>(vv[3]);
        PALPATE_LOAD4(y0, at(rr[0]));
        PALPATE_LOAD4(y1, at(rr[1]));
        PALPATE_LOAD4(y2, at(rr[2]));
        PALPATE_LOAD4(y3, at(rr[3]));
        const vd4 s01 = vd4{v0, v0, v0, v0} * y0 + vd4{v1, v1, v1, v1} * y1;
        const vd4 s23 = vd4{v2, v2, v2, v2} * y2 + vd4{v3, v3, v3, v3} * y3;
        double* zp = at(piv[q]);
        PALPATE_LOAD4(a, zp);
        a -= s01 + s23;
        PALPATE_STORE4(zp, a);
      }
      k = K0;
      continue;
    }
    const WideShape sh = wide_shape(w, r);
    const size_t W = 8 * sh.own_panels, H = 8 * sh.panels, G = (w + 7) / 8;
    if constexpr (F32) {
      for (size_t i = 0; i < w; ++i) {
        const double* z = at(f + static_cast<int>(i));
        fx[i] = static_cast<float>(z[0]); fy[i] = static_cast<float>(z[1]); fz[i] = static_cast<float>(z[2]);
      }
      for (size_t i = w; i < W; ++i) fx[i] = fy[i] = fz[i] = 0.0f;
      for (size_t q = gather_rows_f32(R, r, z4, fx + W, fy + W, fz + W); q < r; ++q) {
        const double* z = at(R[q]);
        fx[W + q] = static_cast<float>(z[0]); fy[W + q] = static_cast<float>(z[1]); fz[W + q] = static_cast<float>(z[2]);
      }
      for (size_t q = W + r; q < H; ++q) fx[q] = fy[q] = fz[q] = 0.0f;
      wide_back_f32(reinterpret_cast<const float*>(V), w, r, fx, fy, fz);
      for (size_t c = 0; c < w; ++c) {
        double* z = at(f + static_cast<int>(c));
        z[0] = fx[c]; z[1] = fy[c]; z[2] = fz[c];
      }
      continue;
    }
    for (size_t i = 0; i < w; ++i) {
      const double* z = at(f + static_cast<int>(i));
      gx[i] = z[0]; gy[i] = z[1]; gz[i] = z[2];
    }
    for (size_t i = w; i < W; ++i) gx[i] = gy[i] = gz[i] = 0.0;
    size_t q0 = 0;
    if constexpr (Wide) q0 = gather_rows_avx512(R, r, z4, gx + W, gy + W, gz + W);
    for (size_t q = q0; q < r; ++q) {
      const double* z = at(R[q]);
      gx[W + q] = z[0]; gy[W + q] = z[1]; gz[W + q] = z[2];
    }
    for (size_t q = W + r; q < H; ++q) gx[q] = gy[q] = gz[q] = 0.0;  // the last panel's padding rows
    for (size_t grp = G; grp-- > 0;) {
      const size_t c0 = 8 * grp, gw = group_width(grp, w);
      const T* pan = V + sh.group_start(grp);
      // Columns [c0 + h, c0 + h + A) of the group at a time, their sums side by side in registers.
      auto columns = [&]<size_t A>(size_t h) {
        vd8 sx[A], sy[A], sz[A];
        for (size_t c = 0; c < A; ++c) sx[c] = sy[c] = sz[c] = vd8{0, 0, 0, 0, 0, 0, 0, 0};
        const T* pp = pan + 8 * gw + 8 * h;
        for (size_t row = c0 + 8; row < H; row += 8, pp += 8 * gw) {
          vd8 xb, yb, zb;
          std::memcpy(&xb, gx + row, sizeof xb);
          std::memcpy(&yb, gy + row, sizeof yb);
          std::memcpy(&zb, gz + row, sizeof zb);
          for (size_t c = 0; c < A; ++c) {
            PALPATE_LOAD8(T, l, pp + 8 * c);
            sx[c] += l * xb; sy[c] += l * yb; sz[c] += l * zb;
          }
        }
        for (size_t c = 0; c < A; ++c) {
          gx[c0 + h + c] -= PALPATE_HSUM8(sx[c]);
          gy[c0 + h + c] -= PALPATE_HSUM8(sy[c]);
          gz[c0 + h + c] -= PALPATE_HSUM8(sz[c]);
        }
      };
      if constexpr (Wide) {
        switch (gw) {
          case 8: columns.template operator()<8>(0); break;
          case 7: columns.template operator()<7>(0); break;
          case 6: columns.template operator()<6>(0); break;
          case 5: columns.template operator()<5>(0); break;
          case 4: columns.template operator()<4>(0); break;
          case 3: columns.template operator()<3>(0); break;
          case 2: columns.template operator()<2>(0); break;
          default: columns.template operator()<1>(0); break;
        }
      } else {
        for (size_t h = 0; h < gw; ++h) columns.template operator()<1>(h);
      }
      // The diagonal tile, last column first.
      for (size_t c = gw; c-- > 0;) {
        const T* l = pan + 8 * c;
        double t0 = 0, t1 = 0, t2 = 0;
        for (size_t j = c + 1; j < 8; ++j) {
          const double v = static_cast<double>(l[j]);
          t0 += v * gx[c0 + j]; t1 += v * gy[c0 + j]; t2 += v * gz[c0 + j];
        }
        gx[c0 + c] -= t0; gy[c0 + c] -= t1; gz[c0 + c] -= t2;
      }
    }
    for (size_t c = 0; c < w; ++c) {
      double* z = at(f + static_cast<int>(c));
      z[0] = gx[c]; z[1] = gy[c]; z[2] = gz[c];
    }
  }
}

#undef PALPATE_LOAD4
#undef PALPATE_STORE4
#undef PALPATE_LOAD8
#undef PALPATE_HSUM8

// The sweeps compiled twice (PALPATE_TWICE, cpu.h): for x86-64-v3 and any x86-64.

// The sweeps a third time for AVX-512 (x86-64-v4): the wide blocks' dots eight at a time, their
// axpys vectorised over 512 bits.
// (clang (14) knows no prefer-vector-width in a target attribute.)
#if defined(__clang__)
#define PALPATE_V4 __attribute__((target("arch=x86-64-v4")))
#else
#define PALPATE_V4 __attribute__((target("arch=x86-64-v4,prefer-vector-width=512")))
#endif
PALPATE_V4 void sweeps_double_impl_v4(const SpringSupernodes& sn, const double* inv_diag, double* z4, double* g,
                                      size_t m, const PredictorCorrection* mid) noexcept {
  sweeps<double, true>(sn, sn.values.data(), inv_diag, z4, g, m, mid);
}
PALPATE_V4 void sweeps_single_impl_v4(const SpringSupernodes& sn, const double* inv_diag, double* z4, double* g,
                                      size_t m, const PredictorCorrection* mid) noexcept {
  sweeps<float, true>(sn, sn.values_single.data(), inv_diag, z4, g, m, mid);
}
#undef PALPATE_V4

PALPATE_TWICE(sweeps_double_impl,
              (const SpringSupernodes& sn, const double* inv_diag, double* z4, double* g, size_t m,
               const PredictorCorrection* mid),
              { sweeps(sn, sn.values.data(), inv_diag, z4, g, m, mid); })
PALPATE_TWICE(sweeps_single_impl,
              (const SpringSupernodes& sn, const double* inv_diag, double* z4, double* g, size_t m,
               const PredictorCorrection* mid),
              { sweeps(sn, sn.values_single.data(), inv_diag, z4, g, m, mid); })

// x's rows (n x 3) from rows perm[i] of z4: whole four-double rows stored three doubles apart,
// each overwriting the last one's padding (the last row by itself, x ends there).
PALPATE_TWICE(unpermute_impl, (int n, const int* perm, const double* z4, double* x), {
  for (int i = 0; i + 1 < n; ++i)
    std::memcpy(x + 3 * static_cast<size_t>(i), z4 + 4 * static_cast<size_t>(perm[i]), 4 * sizeof(double));
  if (n > 0)
    std::memcpy(x + 3 * static_cast<size_t>(n - 1), z4 + 4 * static_cast<size_t>(perm[n - 1]), 3 * sizeof(double));
})

// The best of the builds this CPU runs, capped at `most`.
SolveIsa choose(SolveIsa most) noexcept {
  if (most >= SolveIsa::x86_64_v4 && has_x86_64_v4()) return SolveIsa::x86_64_v4;
  if (most >= SolveIsa::x86_64_v3 && has_x86_64_v3()) return SolveIsa::x86_64_v3;
  return SolveIsa::x86_64;
}

void sweeps_double(const SpringSupernodes& sn, const double* inv_diag, double* z4, double* g, size_t m,
                   SolveIsa isa, const PredictorCorrection* mid) noexcept {
  switch (choose(isa)) {
    case SolveIsa::x86_64_v4: sweeps_double_impl_v4(sn, inv_diag, z4, g, m, mid); break;
    case SolveIsa::x86_64_v3: sweeps_double_impl_v3(sn, inv_diag, z4, g, m, mid); break;
    default: sweeps_double_impl_base(sn, inv_diag, z4, g, m, mid); break;
  }
}

void sweeps_single(const SpringSupernodes& sn, const double* inv_diag, double* z4, double* g, size_t m,
                   SolveIsa isa, const PredictorCorrection* mid) noexcept {
  switch (choose(isa)) {
    case SolveIsa::x86_64_v4: sweeps_single_impl_v4(sn, inv_diag, z4, g, m, mid); break;
    case SolveIsa::x86_64_v3: sweeps_single_impl_v3(sn, inv_diag, z4, g, m, mid); break;
    default: sweeps_single_impl_base(sn, inv_diag, z4, g, m, mid); break;
  }
}

}  // namespace

void solve_supernodal_permuted(const SpringPredictor& p, const SpringSupernodes& sn, double* z4, double* g,
                               SolveIsa isa, const PredictorCorrection* correction) noexcept {
  const size_t m = round8(static_cast<size_t>(sn.max_height));
  const PredictorCorrection* mid = correction && !correction->empty() ? correction : nullptr;
  if (sn.values_single.empty()) sweeps_double(sn, p.inv_diag.data(), z4, g, m, isa, mid);
  else sweeps_single(sn, p.inv_diag.data(), z4, g, m, isa, mid);
}

void solve_supernodal(const SpringPredictor& p, const SpringSupernodes& sn, const RowMat3d& b, RowMat3d& x,
                      double* scratch, SolveIsa isa, const PredictorCorrection* correction) noexcept {
  const int n = p.n;
  double* z4 = scratch;
  const int* perm = p.perm.data();
  for (int i = 0; i < n; ++i) {
    double* z = z4 + 4 * static_cast<size_t>(perm[i]);
    z[0] = b(i, 0); z[1] = b(i, 1); z[2] = b(i, 2); z[3] = 0;
  }
  solve_supernodal_permuted(p, sn, z4, scratch + 4 * static_cast<size_t>(n), isa, correction);
  unpermute_rows(p, z4, x.data());
}

void unpermute_rows(const SpringPredictor& p, const double* z4, double* x) noexcept {
  if (has_x86_64_v3()) unpermute_impl_v3(p.n, p.perm.data(), z4, x);
  else unpermute_impl_base(p.n, p.perm.data(), z4, x);
}

void solve_columns(const SpringPredictor& p, const RowMat3d& b, RowMat3d& dv, RowMat3d& z) noexcept {
  const int n = p.n;
  for (int i = 0; i < n; ++i) z.row(p.perm[static_cast<size_t>(i)]) = b.row(i);
  double* zd = z.data();
  const int* cs = p.col_start.data();
  const int* rw = p.row.data();
  const double* lv = p.value.data();
  for (int c = 0; c < n; ++c) {
    const double z0 = zd[3 * c], z1 = zd[3 * c + 1], z2 = zd[3 * c + 2];
    for (int q = cs[c]; q < cs[c + 1]; ++q) {
      double* t = zd + 3 * rw[q];
      const double l = lv[q];
      t[0] -= l * z0; t[1] -= l * z1; t[2] -= l * z2;
    }
  }
  for (int c = 0; c < n; ++c) {
    const double d = p.inv_diag[static_cast<size_t>(c)];
    zd[3 * c] *= d; zd[3 * c + 1] *= d; zd[3 * c + 2] *= d;
  }
  for (int c = n - 1; c >= 0; --c) {
    double a0 = zd[3 * c], a1 = zd[3 * c + 1], a2 = zd[3 * c + 2];
    for (int q = cs[c]; q < cs[c + 1]; ++q) {
      const double* t = zd + 3 * rw[q];
      const double l = lv[q];
      a0 -= l * t[0]; a1 -= l * t[1]; a2 -= l * t[2];
    }
    zd[3 * c] = a0; zd[3 * c + 1] = a1; zd[3 * c + 2] = a2;
  }
  for (int i = 0; i < n; ++i) dv.row(i) = z.row(p.perm[static_cast<size_t>(i)]);
}

}  // namespace palpate::spring
