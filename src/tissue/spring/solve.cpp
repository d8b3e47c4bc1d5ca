// solve.cpp — the sparse predictor's per-tick triangular solves: supernodal (the step's) and
// column-by-column (the reference), and the supernode partition of the factor.
#include "tissue/spring/solve.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <iterator>

#include <immintrin.h>

namespace palpate::spring {

namespace {

// Four doubles: one AVX register in the avx2 clone, two SSE2 registers in the default one.
typedef double d4 __attribute__((vector_size(32)));

typedef double d8 __attribute__((vector_size(64)));

// (t0, t1, t2) = Σ_j a[j] (x[j], y[j], z[j]), j < w: one read of a for the three coordinates.
// T is the stored value type (double, or float widened to double: accumulation is in double).
// Wide: eight at a time first (the AVX-512 build), then four, then one by one.
template <typename T, bool Wide = false>
__attribute__((always_inline)) inline void dot3(const T* a, const double* x, const double* y, const double* z, int w,
                                                double& t0, double& t1, double& t2) noexcept {
  // (No d4 crosses a function boundary: that would tie the ABI to AVX.)
  int j = 0;
  double r0 = 0, r1 = 0, r2 = 0;
  if constexpr (Wide) {
    d8 s0 = {0, 0, 0, 0, 0, 0, 0, 0}, s1 = s0, s2 = s0;
    for (; j + 8 <= w; j += 8) {
      d8 v;
      for (int q = 0; q < 8; ++q) v[q] = static_cast<double>(a[j + q]);
      d8 vx, vy, vz;
      std::memcpy(&vx, x + j, sizeof vx);
      std::memcpy(&vy, y + j, sizeof vy);
      std::memcpy(&vz, z + j, sizeof vz);
      s0 += v * vx;
      s1 += v * vy;
      s2 += v * vz;
    }
    r0 = ((s0[0] + s0[1]) + (s0[2] + s0[3])) + ((s0[4] + s0[5]) + (s0[6] + s0[7]));
    r1 = ((s1[0] + s1[1]) + (s1[2] + s1[3])) + ((s1[4] + s1[5]) + (s1[6] + s1[7]));
    r2 = ((s2[0] + s2[1]) + (s2[2] + s2[3])) + ((s2[4] + s2[5]) + (s2[6] + s2[7]));
  }
  d4 s0 = {0, 0, 0, 0}, s1 = s0, s2 = s0;
  for (; j + 4 <= w; j += 4) {
    const d4 v = {static_cast<double>(a[j]), static_cast<double>(a[j + 1]), static_cast<double>(a[j + 2]),
                  static_cast<double>(a[j + 3])};
    d4 vx, vy, vz;
    std::memcpy(&vx, x + j, sizeof vx);
    std::memcpy(&vy, y + j, sizeof vy);
    std::memcpy(&vz, z + j, sizeof vz);
    s0 += v * vx;
    s1 += v * vy;
    s2 += v * vz;
  }
  r0 += (s0[0] + s0[1]) + (s0[2] + s0[3]);
  r1 += (s1[0] + s1[1]) + (s1[2] + s1[3]);
  r2 += (s2[0] + s2[1]) + (s2[2] + s2[3]);
  for (; j < w; ++j) {
    const double v = static_cast<double>(a[j]);
    r0 += v * x[j];
    r1 += v * y[j];
    r2 += v * z[j];
  }
  t0 = r0; t1 = r1; t2 = r2;
}

// Blocks narrower than this are solved in place; wider ones are gathered first.
constexpr size_t kGatherWidth = 4;

// Offset of column i's values inside a block of width w with r rows below: columns are stored one
// after the other, column i holding its w − 1 − i triangle entries and then its r block entries.
inline size_t column_offset(size_t i, size_t w, size_t r) noexcept { return i * (w - 1 + r) - i * (i - 1) / 2; }

// (Macros, not functions: no d4 crosses a function boundary, see dot3.)
#define PALPATE_LOAD4(v, p) \
  d4 v;                     \
  std::memcpy(&v, (p), sizeof v)
#define PALPATE_STORE4(p, v) std::memcpy((p), &(v), sizeof(d4))

// Forward substitution L y = b, then y ← D⁻¹ y, then back substitution Lᵀ x = y, in place on the
// right-hand side z4, (4n): each vertex's x, y, z and a zero, so a narrow block updates the three
// coordinates of a row with one four-wide multiply-add per entry of L, in place. A wider block's
// entries of z (its own columns, then its rows below) are gathered into g (3 arrays of stride
// m = max block height) first, so every column of the block is one contiguous axpy (forward) or
// dot (back) over g, and scattered back.
template <typename T, bool Wide = false>
__attribute__((always_inline)) inline void sweeps(const SpringSupernodes& sn, const T* values, const double* inv_diag,
                                                  double* z4, double* g, size_t m) noexcept {
  const int S = static_cast<int>(sn.first_column.size()) - 1;
  const int* fc = sn.first_column.data();
  const int* rs = sn.row_start.data();
  const int* rows = sn.rows.data();
  const size_t* vs = sn.value_start.data();
  double* __restrict gx = g;
  double* __restrict gy = g + m;
  double* __restrict gz = g + 2 * m;
  auto at = [z4](int vertex) { return z4 + 4 * static_cast<size_t>(vertex); };
  auto gather = [&](int f, size_t w, const int* R, size_t r) {
    for (size_t i = 0; i < w; ++i) {
      const double* z = at(f + static_cast<int>(i));
      gx[i] = z[0]; gy[i] = z[1]; gz[i] = z[2];
    }
    for (size_t q = 0; q < r; ++q) {
      const double* z = at(R[q]);
      gx[w + q] = z[0]; gy[w + q] = z[1]; gz[w + q] = z[2];
    }
  };
  auto scatter = [&](int f, size_t w, const int* R, size_t r) {
    for (size_t i = 0; i < w; ++i) {
      double* z = at(f + static_cast<int>(i));
      z[0] = gx[i]; z[1] = gy[i]; z[2] = gz[i];
    }
    for (size_t q = 0; q < r; ++q) {
      double* z = at(R[q]);
      z[0] = gx[w + q]; z[1] = gy[w + q]; z[2] = gz[w + q];
    }
  };
  for (int k = 0; k < S; ++k) {
    const int f = fc[k];
    const size_t w = static_cast<size_t>(fc[k + 1] - f), r = static_cast<size_t>(rs[k + 1] - rs[k]);
    const int* R = rows + rs[k];
    const T* V = values + vs[k];
    if (w < kGatherWidth) {
      // Narrow block: update z in place, column by column (gathering would not pay off).
      for (size_t i = 0; i < w; ++i) {
        const T* c = V + column_offset(i, w, r);
        const int fi = f + static_cast<int>(i);
        PALPATE_LOAD4(a, at(fi));
        const size_t t = w - 1 - i;
        for (size_t j = 0; j < t; ++j) {
          double* z = at(fi + 1 + static_cast<int>(j));
          const double v = static_cast<double>(c[j]);
          PALPATE_LOAD4(y, z);
          y -= d4{v, v, v, v} * a;
          PALPATE_STORE4(z, y);
        }
        for (size_t q = 0; q < r; ++q) {
          double* z = at(R[q]);
          const double v = static_cast<double>(c[t + q]);
          PALPATE_LOAD4(y, z);
          y -= d4{v, v, v, v} * a;
          PALPATE_STORE4(z, y);
        }
      }
      continue;
    }
    gather(f, w, R, r);
    const size_t h = w + r;
    for (size_t i = 0; i < w; ++i) {
      const T* __restrict c = V + column_offset(i, w, r);
      const double a0 = gx[i], a1 = gy[i], a2 = gz[i];
      const size_t len = h - i - 1;
      double* __restrict tx = gx + i + 1;
      double* __restrict ty = gy + i + 1;
      double* __restrict tz = gz + i + 1;
      for (size_t j = 0; j < len; ++j) {
        tx[j] -= c[j] * a0; ty[j] -= c[j] * a1; tz[j] -= c[j] * a2;
      }
    }
    scatter(f, w, R, r);
  }
  const int n = fc[S];
  for (int i = 0; i < n; ++i) {
    const double d = inv_diag[i];
    PALPATE_LOAD4(y, at(i));
    y *= d4{d, d, d, d};
    PALPATE_STORE4(at(i), y);
  }
  for (int k = S - 1; k >= 0; --k) {
    const int f = fc[k];
    const size_t w = static_cast<size_t>(fc[k + 1] - f), r = static_cast<size_t>(rs[k + 1] - rs[k]);
    const int* R = rows + rs[k];
    const T* V = values + vs[k];
    if (w < kGatherWidth) {
      for (size_t i = w; i-- > 0;) {
        const T* c = V + column_offset(i, w, r);
        const int fi = f + static_cast<int>(i);
        PALPATE_LOAD4(a, at(fi));
        const size_t t = w - 1 - i;
        for (size_t j = 0; j < t; ++j) {
          const double v = static_cast<double>(c[j]);
          PALPATE_LOAD4(y, at(fi + 1 + static_cast<int>(j)));
          a -= d4{v, v, v, v} * y;
        }
        for (size_t q = 0; q < r; ++q) {
          const double v = static_cast<double>(c[t + q]);
          PALPATE_LOAD4(y, at(R[q]));
          a -= d4{v, v, v, v} * y;
        }
        PALPATE_STORE4(at(fi), a);
      }
      continue;
    }
    gather(f, w, R, r);
    const size_t h = w + r;
    for (size_t i = w; i-- > 0;) {
      double t0, t1, t2;
      const size_t len = h - i - 1;
      dot3<T, Wide>(V + column_offset(i, w, r), gx + i + 1, gy + i + 1, gz + i + 1, static_cast<int>(len), t0, t1, t2);
      gx[i] -= t0; gy[i] -= t1; gz[i] -= t2;
    }
    for (size_t i = 0; i < w; ++i) {
      double* z = at(f + static_cast<int>(i));
      z[0] = gx[i]; z[1] = gy[i]; z[2] = gz[i];
    }
  }
}

#undef PALPATE_LOAD4
#undef PALPATE_STORE4

// The sweeps and dense products compiled twice each: for AVX2 + FMA (x86-64-v3) and for any
// x86-64, chosen per call by a CPU check (a load of a global set by libgcc's constructor). Not
// target_clones: its ifunc resolvers run during relocation, before a sanitizer's runtime is up,
// and crash ThreadSanitizer builds at start.
bool has_x86_64_v3() noexcept { return __builtin_cpu_supports("x86-64-v3"); }

#define PALPATE_TWICE(name, params, body)                                   \
  __attribute__((target("arch=x86-64-v3"))) void name##_v3 params noexcept body \
  void name##_base params noexcept body

// The sweeps a third time for AVX-512 (x86-64-v4): the wide blocks' dots eight at a time, their
// axpys vectorised over 512 bits.
#define PALPATE_V4 __attribute__((target("arch=x86-64-v4,prefer-vector-width=512")))
bool has_x86_64_v4() noexcept { return __builtin_cpu_supports("x86-64-v4"); }
PALPATE_V4 void sweeps_double_impl_v4(const SpringSupernodes& sn, const double* inv_diag, double* z4, double* g,
                                      size_t m) noexcept {
  sweeps<double, true>(sn, sn.values.data(), inv_diag, z4, g, m);
}
PALPATE_V4 void sweeps_single_impl_v4(const SpringSupernodes& sn, const double* inv_diag, double* z4, double* g,
                                      size_t m) noexcept {
  sweeps<float, true>(sn, sn.values_single.data(), inv_diag, z4, g, m);
}
#undef PALPATE_V4

PALPATE_TWICE(sweeps_double_impl,
              (const SpringSupernodes& sn, const double* inv_diag, double* z4, double* g, size_t m),
              { sweeps(sn, sn.values.data(), inv_diag, z4, g, m); })
PALPATE_TWICE(sweeps_single_impl,
              (const SpringSupernodes& sn, const double* inv_diag, double* z4, double* g, size_t m),
              { sweeps(sn, sn.values_single.data(), inv_diag, z4, g, m); })

template <typename T>
__attribute__((always_inline)) inline void dense_rows(const T* W, int n, const double* bx, const double* by,
                                                      const double* bz, double* x) noexcept {
  for (int i = 0; i < n; ++i) {
    double t0, t1, t2;
    dot3(W + static_cast<size_t>(i) * static_cast<size_t>(n), bx, by, bz, n, t0, t1, t2);
    x[3 * i] = t0; x[3 * i + 1] = t1; x[3 * i + 2] = t2;
  }
}

PALPATE_TWICE(dense_double_impl,
              (const double* W, int n, const double* bx, const double* by, const double* bz, double* x),
              { dense_rows(W, n, bx, by, bz, x); })
PALPATE_TWICE(dense_single_impl,
              (const float* W, int n, const double* bx, const double* by, const double* bz, double* x),
              { dense_rows(W, n, bx, by, bz, x); })
#undef PALPATE_TWICE

void sweeps_double(const SpringSupernodes& sn, const double* inv_diag, double* z4, double* g, size_t m) noexcept {
  if (has_x86_64_v4())
    sweeps_double_impl_v4(sn, inv_diag, z4, g, m);
  else if (has_x86_64_v3())
    sweeps_double_impl_v3(sn, inv_diag, z4, g, m);
  else
    sweeps_double_impl_base(sn, inv_diag, z4, g, m);
}

void sweeps_single(const SpringSupernodes& sn, const double* inv_diag, double* z4, double* g, size_t m) noexcept {
  if (has_x86_64_v4())
    sweeps_single_impl_v4(sn, inv_diag, z4, g, m);
  else if (has_x86_64_v3())
    sweeps_single_impl_v3(sn, inv_diag, z4, g, m);
  else
    sweeps_single_impl_base(sn, inv_diag, z4, g, m);
}

#pragma GCC diagnostic push  // GCC 12's AVX-512 intrinsics: see step.cpp
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

// One block of eight columns j0 … j0 + 7 of row i of the symmetric product (lanes in m read, lanes
// in mu also update y): acc += W_ij b_j, y_j += W_ij b_i.
template <bool Full>
__attribute__((target("avx512f"), always_inline)) inline void dense_symmetric_block(
    const double* w, const double* bx, const double* by, const double* bz, double* yx, double* yy, double* yz,
    __mmask8 m, __mmask8 mu, __m512d bix, __m512d biy, __m512d biz, __m512d& ax, __m512d& ay, __m512d& az) noexcept {
  const __m512d v = Full ? _mm512_loadu_pd(w) : _mm512_maskz_loadu_pd(m, w);
  ax = _mm512_fmadd_pd(v, Full ? _mm512_load_pd(bx) : _mm512_maskz_load_pd(m, bx), ax);
  ay = _mm512_fmadd_pd(v, Full ? _mm512_load_pd(by) : _mm512_maskz_load_pd(m, by), ay);
  az = _mm512_fmadd_pd(v, Full ? _mm512_load_pd(bz) : _mm512_maskz_load_pd(m, bz), az);
  if (Full) {
    _mm512_store_pd(yx, _mm512_fmadd_pd(v, bix, _mm512_load_pd(yx)));
    _mm512_store_pd(yy, _mm512_fmadd_pd(v, biy, _mm512_load_pd(yy)));
    _mm512_store_pd(yz, _mm512_fmadd_pd(v, biz, _mm512_load_pd(yz)));
  } else {
    _mm512_mask_store_pd(yx, mu, _mm512_fmadd_pd(v, bix, _mm512_maskz_load_pd(mu, yx)));
    _mm512_mask_store_pd(yy, mu, _mm512_fmadd_pd(v, biy, _mm512_maskz_load_pd(mu, yy)));
    _mm512_mask_store_pd(yz, mu, _mm512_fmadd_pd(v, biz, _mm512_maskz_load_pd(mu, yz)));
  }
}

// x = W b for a symmetric W (n x n, row-major) from its upper triangle only, so half of W's bytes
// are read: row i contributes Σ_{j ≥ i} W_ij b_j to x_i and W_ij b_i to x_j for j > i (the
// all-pairs kernel's pattern). b = (bx, by, bz) and y = (yx, yy, yz, the transposed sums) are n
// each, N apart (N a multiple of 8) from a 64-byte boundary, so their accesses are aligned blocks
// of eight; W's rows are read unaligned. x is (n x 3) row-major.
__attribute__((target("avx512f"))) void dense_symmetric_avx512(const double* W, int n, const double* b, double* y,
                                                                size_t N, double* x) noexcept {
  const double *bx = b, *by = b + N, *bz = b + 2 * N;
  double *yx = y, *yy = y + N, *yz = y + 2 * N;
  std::fill(y, y + 3 * N, 0.0);
  for (int i = 0; i < n; ++i) {
    const double* w = W + static_cast<size_t>(i) * static_cast<size_t>(n);
    const __m512d bix = _mm512_set1_pd(bx[i]), biy = _mm512_set1_pd(by[i]), biz = _mm512_set1_pd(bz[i]);
    __m512d ax = _mm512_setzero_pd(), ay = ax, az = ax;
    const int j0 = i & ~7;
    const int lo = i - j0, hi = std::min(8, n - j0);
    const __mmask8 m0 = static_cast<__mmask8>(((1u << hi) - 1) & ~((1u << lo) - 1));
    const __mmask8 u0 = static_cast<__mmask8>(m0 & ~(1u << lo));  // not the diagonal
    dense_symmetric_block<false>(w + j0, bx + j0, by + j0, bz + j0, yx + j0, yy + j0, yz + j0, m0, u0, bix, biy,
                                 biz, ax, ay, az);
    int j = j0 + 8;
    for (; j + 8 <= n; j += 8)
      dense_symmetric_block<true>(w + j, bx + j, by + j, bz + j, yx + j, yy + j, yz + j, 0xFF, 0xFF, bix, biy, biz,
                                  ax, ay, az);
    if (j < n) {
      const __mmask8 m = static_cast<__mmask8>((1u << (n - j)) - 1);
      dense_symmetric_block<false>(w + j, bx + j, by + j, bz + j, yx + j, yy + j, yz + j, m, m, bix, biy, biz, ax,
                                   ay, az);
    }
    // Row i's transposed sums are complete: rows after i only update y_j for j > i.
    x[3 * i] = _mm512_reduce_add_pd(ax) + yx[i];
    x[3 * i + 1] = _mm512_reduce_add_pd(ay) + yy[i];
    x[3 * i + 2] = _mm512_reduce_add_pd(az) + yz[i];
  }
}

#pragma GCC diagnostic pop

bool has_avx512() noexcept { return __builtin_cpu_supports("avx512f") && has_x86_64_v3(); }

void dense_double(const double* W, int n, const double* bx, const double* by, const double* bz, double* x) noexcept {
  if (has_x86_64_v3())
    dense_double_impl_v3(W, n, bx, by, bz, x);
  else
    dense_double_impl_base(W, n, bx, by, bz, x);
}

void dense_single(const float* W, int n, const double* bx, const double* by, const double* bz, double* x) noexcept {
  if (has_x86_64_v3())
    dense_single_impl_v3(W, n, bx, by, bz, x);
  else
    dense_single_impl_base(W, n, bx, by, bz, x);
}

}  // namespace

SpringSupernodes make_supernodes(const SpringPredictor& p, bool single, double max_padding, int max_width) {
  SpringSupernodes sn;
  const int n = p.n;
  if (p.kind != SpringSolver::sparse || n <= 0 || p.col_start.size() != static_cast<size_t>(n) + 1) return sn;
  const int* cs = p.col_start.data();
  const int* rw = p.row.data();
  // Greedy relaxed amalgamation: any run of consecutive columns can be one dense block (entries
  // missing from L are stored as zeros), so grow a block while its stored size stays within
  // (1 + max_padding) of the entries it holds. U is the block's row set below its last column.
  std::vector<int> U, merged;
  sn.first_column.push_back(0);
  int f = 0;
  size_t held = 0;
  auto close_block = [&](int e) {
    sn.first_column.push_back(e);
    sn.rows.insert(sn.rows.end(), U.begin(), U.end());
    sn.row_start.push_back(static_cast<int>(sn.rows.size()));
  };
  sn.row_start.push_back(0);
  for (int c = 0; c < n; ++c) {
    // Rows of column c, sorted (Eigen's are, but do not rely on it).
    std::vector<int> rc(rw + cs[c], rw + cs[c + 1]);
    std::sort(rc.begin(), rc.end());
    const size_t count = rc.size();
    if (c > f) {
      // Try adding column c to the block [f, c): U loses c (it becomes a triangle row), gains rc.
      merged.clear();
      std::set_union(U.begin(), U.end(), rc.begin(), rc.end(), std::back_inserter(merged));
      if (!merged.empty() && merged.front() == c) merged.erase(merged.begin());
      const size_t w = static_cast<size_t>(c - f + 1);
      const size_t stored = w * (w - 1) / 2 + merged.size() * w;
      if (static_cast<int>(w) <= max_width &&
          static_cast<double>(stored) <= (1.0 + max_padding) * static_cast<double>(held + count)) {
        U.swap(merged);
        held += count;
        continue;
      }
      close_block(c);
      f = c;
    }
    U = rc;
    held = count;
  }
  close_block(n);
  const size_t S = sn.first_column.size() - 1;
  sn.value_start.assign(S + 1, 0);
  for (size_t k = 0; k < S; ++k) {
    const size_t w = static_cast<size_t>(sn.first_column[k + 1] - sn.first_column[k]);
    const size_t r = static_cast<size_t>(sn.row_start[k + 1] - sn.row_start[k]);
    sn.max_width = std::max(sn.max_width, static_cast<int>(w));
    sn.max_height = std::max(sn.max_height, static_cast<int>(w + r));
    sn.value_start[k + 1] = sn.value_start[k] + w * (w - 1) / 2 + r * w;
  }
  sn.values.assign(sn.value_start[S], 0.0);
  std::vector<int> position(static_cast<size_t>(n), -1);  // block row of each row index
  for (size_t k = 0; k < S; ++k) {
    const int f0 = sn.first_column[k], e = sn.first_column[k + 1];
    const size_t w = static_cast<size_t>(e - f0);
    for (int q = sn.row_start[k]; q < sn.row_start[k + 1]; ++q) position[static_cast<size_t>(sn.rows[static_cast<size_t>(q)])] = q - sn.row_start[k];
    const size_t rcount = static_cast<size_t>(sn.row_start[k + 1] - sn.row_start[k]);
    for (int c = f0; c < e; ++c) {
      const size_t i = static_cast<size_t>(c - f0);
      // Column i covers block rows i + 1 … w − 1 and then the rows below, in that order; block row
      // `at` (> i: L is strictly lower) is its entry at − (i + 1). Indices, not pointers: a block
      // may hold no values at all (then values.data() may be null).
      const size_t col = sn.value_start[k] + column_offset(i, w, rcount);
      for (int q = cs[c]; q < cs[c + 1]; ++q) {
        const int r = rw[q];
        const size_t at = r < e ? static_cast<size_t>(r - f0) : w + static_cast<size_t>(position[static_cast<size_t>(r)]);
        sn.values[col + at - (i + 1)] = p.value[static_cast<size_t>(q)];
      }
    }
  }
  if (single) {
    sn.values_single.assign(sn.values.begin(), sn.values.end());
    std::vector<double>().swap(sn.values);
  }
  return sn;
}

size_t supernodal_scratch(const SpringPredictor& p, const SpringSupernodes& sn) {
  return 4 * static_cast<size_t>(p.n) + 3 * static_cast<size_t>(sn.max_height);
}

void solve_supernodal(const SpringPredictor& p, const SpringSupernodes& sn, const RowMat3d& b, RowMat3d& x,
                      double* scratch) noexcept {
  const int n = p.n;
  double* z4 = scratch;
  const int* perm = p.perm.data();
  for (int i = 0; i < n; ++i) {
    double* z = z4 + 4 * static_cast<size_t>(perm[i]);
    z[0] = b(i, 0); z[1] = b(i, 1); z[2] = b(i, 2); z[3] = 0;
  }
  double* g = scratch + 4 * static_cast<size_t>(n);
  const size_t m = static_cast<size_t>(sn.max_height);
  if (sn.values_single.empty()) sweeps_double(sn, p.inv_diag.data(), z4, g, m);
  else sweeps_single(sn, p.inv_diag.data(), z4, g, m);
  for (int i = 0; i < n; ++i) {
    const double* z = z4 + 4 * static_cast<size_t>(perm[i]);
    x(i, 0) = z[0]; x(i, 1) = z[1]; x(i, 2) = z[2];
  }
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

namespace palpate::spring {

size_t dense_scratch(int n) { return 6 * static_cast<size_t>((n + 7) / 8 * 8) + 8; }

void solve_dense(const SpringPredictor& p, const std::vector<float>& inverse_single, const RowMat3d& b, RowMat3d& x,
                 double* scratch, bool symmetric) noexcept {
  const int n = p.n;
  const size_t N = static_cast<size_t>((n + 7) / 8 * 8);
  const std::uintptr_t at = reinterpret_cast<std::uintptr_t>(scratch);
  double* bx = scratch + ((64 - at % 64) % 64) / sizeof(double);  // the first 64-byte boundary
  double* by = bx + N;
  double* bz = bx + 2 * N;
  for (int i = 0; i < n; ++i) {
    bx[i] = b(i, 0); by[i] = b(i, 1); bz[i] = b(i, 2);
  }
  if (inverse_single.empty() && symmetric && has_avx512())
    dense_symmetric_avx512(p.inverse.data(), n, bx, bx + 3 * N, N, x.data());
  else if (inverse_single.empty()) dense_double(p.inverse.data(), n, bx, by, bz, x.data());
  else dense_single(inverse_single.data(), n, bx, by, bz, x.data());
}

}  // namespace palpate::spring
