// spring_pass.cpp — the spring forces of generic (not all-pairs) networks and the predictor
// right-hand side's −h K_L v term in the same pass: the scalar reference and the AVX2 / AVX-512
// passes on the padded layout (eight doubles per vertex), and the fused step's right-hand side.
#include <palpate/spring.h>

#include "core/simd.h"
#include "tissue/spring/cpu.h"
#include "tissue/spring/forces.h"
#include "tissue/spring/laws.h"
#include "tissue/spring/stages.h"

#include <cmath>
#include <cstdint>

namespace palpate::spring {

// Internal spring forces (Hooke about the rest length plus a damper along the spring; laws.h's
// spring_factor): f_i += g d, f_j −= g d. x, v, f are (n x 3); f is added to.
void add_spring_forces(const SpringNetwork& net, const RowMat3d& x, const RowMat3d& v, RowMat3d& f) noexcept {
  const size_t s = net.springs.size();
  for (size_t e = 0; e < s; ++e) {
    const int i = net.springs[e][0], j = net.springs[e][1];
    const double dx = x(j, 0) - x(i, 0), dy = x(j, 1) - x(i, 1), dz = x(j, 2) - x(i, 2);
    const double l = std::sqrt(dx * dx + dy * dy + dz * dz);
    if (!(l > 0)) continue;
    const double inv_l = 1.0 / l;
    const double dvu = ((v(j, 0) - v(i, 0)) * dx + (v(j, 1) - v(i, 1)) * dy + (v(j, 2) - v(i, 2)) * dz) * inv_l;
    const double g = spring_factor(net.stiffness[e], net.damping[e], net.rest_length[e], l, inv_l, dvu);
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
// exact stiffness (laws.h's directional_mu, directional_nu) instead of k I (the volume term's share
// of KP stays isotropic).
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
        const double mu = directional_mu(h, net.stiffness[e], net.rest_length[e], l);
        const double nu = directional_nu(mu, wx * dx + wy * dy + wz * dz, l);
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
    const double g = spring_factor(net.stiffness[e], net.damping[e], net.rest_length[e], l, inv_l, dvu);
    fd[i] += g * dx; fd[i + 1] += g * dy; fd[i + 2] += g * dz;
    fd[j] -= g * dx; fd[j + 1] -= g * dy; fd[j + 2] -= g * dz;
  }
}
template <bool Directional = false>
void spring_pass_tail(const SpringNetwork& net, const double* KP, double h, size_t e, const double* xv,
                      double* fr) noexcept {
  spring_loop<Directional>(net, KP, h, e, 8, xv, xv + 4, fr, fr + 4);
}

// The AVX2 pass, four springs at a time. xv is (8n): a vertex's x, y, z, 0, vx, vy, vz, 0 (one
// 64-byte line, so each vertex is one cache line, its position and velocity aligned 256-bit loads
// and no lane is masked); fr the same for the springs' sums, f then r. The sums go to fr one vertex
// at a time in spring order, so springs sharing a vertex in a group of four are summed like the
// scalar loop's. Directional: the −h K v term with each spring's exact stiffness (spring_loop).
// Lane q of l, g, … is spring e + q; d[q], w[q] are its d and Δv as (x, y, z, 0).
template <bool Directional = false>
PALPATE_AVX2 void spring_pass_avx2(const SpringNetwork& net, const double* KP, double h, const double* xv,
                                   double* fr) noexcept {
  using namespace simd;
  const size_t s = net.springs.size();
  const double *K = net.stiffness.data(), *C = net.damping.data(), *L = net.rest_length.data();
  const d4 hv = broadcast<d4>(h), zero_v = zero<d4>(), one = broadcast<d4>(1.0);
  size_t e = 0;
  for (; e + 4 <= s; e += 4) {
    size_t a[4], b[4];
    d4 d[4], w[4];
    for (int q = 0; q < 4; ++q) {
      a[q] = 8 * static_cast<size_t>(net.springs[e + q][0]);
      b[q] = 8 * static_cast<size_t>(net.springs[e + q][1]);
      d[q] = load<d4>(xv + b[q]) - load<d4>(xv + a[q]);
      w[q] = load<d4>(xv + b[q] + 4) - load<d4>(xv + a[q] + 4);
    }
    const d4 l2 = sums(d[0] * d[0], d[1] * d[1], d[2] * d[2], d[3] * d[3]);
    const d4 dw = sums(d[0] * w[0], d[1] * w[1], d[2] * w[2], d[3] * w[3]);
    const d4 l = sqrt(l2);
    const d4 ok = greater(l, zero_v);  // l > 0 (false for NaN), as the scalar loop
    const d4 inv_l = one / l;
    const d4 k = loadu<d4>(K + e);
    const d4 g = select_or_zero(ok, spring_factor_avx2(k, loadu<d4>(C + e), loadu<d4>(L + e), l, inv_l, dw * inv_l));
    d4 kh = hv * loadu<d4>(KP + e);
    d4 nu = zero_v;
    if constexpr (Directional) {
      // r += (h KP − μ) w + ν d (zero correction where l = 0).
      const d4 mu = select_or_zero(ok, directional_mu_avx2(hv * k, loadu<d4>(L + e), inv_l));
      nu = select_or_zero(ok, directional_nu_avx2(mu, dw, inv_l));
      kh = kh - mu;
    }
    const d4 gq[4] = {splat<0>(g), splat<1>(g), splat<2>(g), splat<3>(g)};
    const d4 kq[4] = {splat<0>(kh), splat<1>(kh), splat<2>(kh), splat<3>(kh)};
    [[maybe_unused]] const d4 nq[4] = {splat<0>(nu), splat<1>(nu), splat<2>(nu), splat<3>(nu)};
    for (int q = 0; q < 4; ++q) {
      const d4 fd = gq[q] * d[q];
      d4 rw = kq[q] * w[q];
      if constexpr (Directional) rw = fma(nq[q], d[q], rw);
      store(fr + a[q] + 4, load<d4>(fr + a[q] + 4) + rw);
      store(fr + b[q] + 4, load<d4>(fr + b[q] + 4) - rw);
      store(fr + a[q], load<d4>(fr + a[q]) + fd);
      store(fr + b[q], load<d4>(fr + b[q]) - fd);
    }
  }
  spring_pass_tail<Directional>(net, KP, h, e, xv, fr);
}

// The same with AVX-512, on whole vertices: a spring's end is one 512-bit load of its position
// and velocity and one 512-bit read-modify-write of its force and −h K_L v sums (half the memory
// operations of the AVX2 pass). 1/l without the divider: rsqrt14 and two Newton steps (to
// round-off, see all_pairs_avx512), and g in the all-pairs form k (1 − L r) + c (d·w) r² (laws.h).
// Uniform: every spring has stiffness k0 and damping c0, so the pass reads no per-spring K and C
// (16 of each spring's 32 bytes; the same values, so the same results bit for bit).
template <bool Uniform>
PALPATE_AVX512VL void spring_pass_avx512(const SpringNetwork& net, const double* KP, double h, const double* xv,
                                         double* fr, double k0 = 0, double c0 = 0) noexcept {
  using namespace simd;
  const size_t s = net.springs.size();
  const double *K = net.stiffness.data(), *C = net.damping.data(), *L = net.rest_length.data();
  const d4 k0v = broadcast<d4>(k0), c0v = broadcast<d4>(c0);
  const d4 hv = broadcast<d4>(h), zero_v = zero<d4>();
  size_t e = 0;
  for (; e + 4 <= s; e += 4) {
    size_t a[4], b[4];
    d8 dw[4], p[4];
    for (int q = 0; q < 4; ++q) {
      a[q] = 8 * static_cast<size_t>(net.springs[e + q][0]);
      b[q] = 8 * static_cast<size_t>(net.springs[e + q][1]);
      dw[q] = load<d8>(xv + b[q]) - load<d8>(xv + a[q]);  // (d, w)
      p[q] = dw[q] * low_twice(dw[q]);                      // (d d, w d)
    }
    // (d·d of the four springs, d·w of the four), each ((x + y) + (z + 0)) as in the AVX2 pass.
    const d8 dots = sums_halves(p[0], p[1], p[2], p[3]);
    const d4 l2 = low(dots), dwv = high(dots);
    const d4 ok = greater(l2, zero_v);  // l > 0 (false for NaN), as the scalar loop
    d4 r = rsqrt14(l2);
    for (int it = 0; it < 2; ++it) r = rsqrt_newton_step_avx2(l2, r);
    const d4 k = Uniform ? k0v : loadu<d4>(K + e);
    const d4 damp = Uniform ? c0v : loadu<d4>(C + e);
    const d4 g = select_or_zero(ok, all_pairs_spring_factor_avx2(k, damp, loadu<d4>(L + e), r, dwv));
    const d4 kp = Uniform ? k : loadu<d4>(KP + e);  // the predictor's weight (= k without a volume term)
    const d8 gk = concat(g, hv * kp);
    const d8 pick[4] = {splat_halves<0>(gk), splat_halves<1>(gk), splat_halves<2>(gk), splat_halves<3>(gk)};
    for (int q = 0; q < 4; ++q) {
      const d8 c = pick[q] * dw[q];  // (g d, kh w)
      store(fr + a[q], load<d8>(fr + a[q]) + c);
      store(fr + b[q], load<d8>(fr + b[q]) - c);
    }
  }
  spring_pass_tail(net, KP, h, e, xv, fr);
}

// x, v (n x 3) into xv's lines (x, y, z, 0, vx, vy, vz, 0) and fr's lines zeroed, a vertex at a
// time: two masked 256-bit loads and four aligned stores.
PALPATE_AVX2_NO_FMA void pack_padded(size_t n, const double* xd, const double* vd, double* xv, double* fr) noexcept {
  using namespace simd;
  const d4 zero_v = zero<d4>();
  for (size_t i = 0; i < n; ++i) {
    store(xv + 8 * i, load3(xd + 3 * i));
    store(xv + 8 * i + 4, load3(vd + 3 * i));
    store(fr + 8 * i, zero_v);
    store(fr + 8 * i + 4, zero_v);
  }
}

}  // namespace

// The fused step's right-hand side, row perm[i] of z4 = h (r + ((f_ext + f) − γ v)), zero when i
// is anchored; a vertex's three values in one 256-bit register (masked loads from the (n x 3)
// arrays). AVX2 without FMA (so nothing is contracted): each value is the scalar expression's,
// operation for operation, so the fused and general steps stay equal bit for bit. (Masked stores into v and x were tried for
// the update and were slower: a masked load after a masked store to the same 32 bytes waits.)
PALPATE_AVX2_NO_FMA void fused_rhs(size_t n, double h, double gamma, const int* perm, const std::uint8_t* anchored,
                            const double* fr, const double* work, const double* v, double* z4) noexcept {
  using namespace simd;
  const d4 hv = broadcast<d4>(h), gv = broadcast<d4>(gamma), zero_v = zero<d4>();
  for (size_t i = 0; i < n; ++i) {
    double* z = z4 + 4 * static_cast<size_t>(perm[i]);
    if (anchored[i]) {
      storeu(z, zero_v);
      continue;
    }
    const d4 f = load3(work + 3 * i) + load<d4>(fr + 8 * i);
    const d4 t = f - gv * load3(v + 3 * i);
    storeu(z, (load<d4>(fr + 8 * i + 4) + t) * hv);  // lane 3: 0
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
