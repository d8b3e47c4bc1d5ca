// spring_pass.cpp — the spring forces of generic (not all-pairs) networks and the predictor
// right-hand side's −h K_L v term in the same pass: the scalar reference and the AVX2 / AVX-512
// passes on the padded layout (eight doubles per vertex), and the fused step's right-hand side.
#include <palpate/spring.h>

#include "tissue/spring/cpu.h"
#include "tissue/spring/forces.h"
#include "tissue/spring/stages.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <immintrin.h>

namespace palpate::spring {

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

}  // namespace

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

size_t spring_pass_scratch(const SpringModel& model) { return 16 * model.network.size() + 7; }

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
    if (kernel == SpringKernel::scalar || model.solver->volume_scale.size() != net.tets.size() ||
        model.solver->volume_corners.size() != 4 * net.tets.size())
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
