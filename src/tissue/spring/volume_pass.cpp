// volume_pass.cpp — the volume term's forces (docs/models/mass-spring.md, "Volume"): the scalar
// pass on any layout and the four-wide AVX2 pass on the padded one.
#include <palpate/spring.h>

#include "tissue/spring/forces.h"

#include <immintrin.h>

namespace palpate::spring {

namespace {

// One tetrahedron's volume gradients from its corners p0..p3 (x, y, z each): 6 ∇V at corners 1, 2
// and 3 — b × c, c × a, a × b, with a, b, c its edges from corner 0 (corner 0's is minus their sum)
// — and 6V. Shared by the scalar volume pass and the four-wide pass's tail.
struct TetGradients {
  double g[3][3];
  double v6;
};
inline TetGradients tet_gradients(const double* p0, const double* p1, const double* p2, const double* p3) noexcept {
  const double ax = p1[0] - p0[0], ay = p1[1] - p0[1], az = p1[2] - p0[2];
  const double bx = p2[0] - p0[0], by = p2[1] - p0[1], bz = p2[2] - p0[2];
  const double cx = p3[0] - p0[0], cy = p3[1] - p0[1], cz = p3[2] - p0[2];
  TetGradients t{{{by * cz - bz * cy, bz * cx - bx * cz, bx * cy - by * cx},
                  {cy * az - cz * ay, cz * ax - cx * az, cx * ay - cy * ax},
                  {ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx}},
                 0.0};
  t.v6 = ax * t.g[0][0] + ay * t.g[0][1] + az * t.g[0][2];
  return t;
}
// s times the gradients onto the corners' forces (corner 0 gets minus their sum).
inline void add_tet_forces(const TetGradients& t, double s, double* f0, double* f1, double* f2, double* f3) noexcept {
  double* fk[3] = {f1, f2, f3};
  for (int k = 0; k < 3; ++k)
    for (int c = 0; c < 3; ++c) fk[k][c] += s * t.g[k][c];
  for (int c = 0; c < 3; ++c) f0[c] -= s * (t.g[0][c] + t.g[1][c] + t.g[2][c]);
}

}  // namespace

double add_volume_forces(const SpringNetwork& net, const double* x, size_t stride, double* f,
                         size_t fstride) noexcept {
  const double kappa = net.volume_modulus;
  double energy = 0;
  const size_t T = net.tets.size();
  for (size_t t = 0; t < T; ++t) {
    const auto& q = net.tets[t];
    const TetGradients g = tet_gradients(x + stride * static_cast<size_t>(q[0]), x + stride * static_cast<size_t>(q[1]),
                                         x + stride * static_cast<size_t>(q[2]), x + stride * static_cast<size_t>(q[3]));
    const double v0 = net.rest_volume[t];
    const double dv = g.v6 / 6 - v0;
    energy += 0.5 * kappa * dv * dv / v0;
    const double s = -kappa * dv / (6 * v0);  // −p / 6, the 1/6 of ∇V folded in
    add_tet_forces(g, s, f + fstride * static_cast<size_t>(q[0]), f + fstride * static_cast<size_t>(q[1]),
                   f + fstride * static_cast<size_t>(q[2]), f + fstride * static_cast<size_t>(q[3]));
  }
  return energy;
}

namespace {

// 4 x (x, y, z, 0) rows → x, y, z registers (lane l from row l): the edge vectors into the
// structure-of-arrays form.
__attribute__((target("avx2"))) inline void transpose_rows(const __m256d* r, __m256d& x, __m256d& y,
                                                           __m256d& z) noexcept {
  const __m256d t0 = _mm256_unpacklo_pd(r[0], r[1]), t1 = _mm256_unpackhi_pd(r[0], r[1]);  // x0 x1 z0 z1, y0 y1 0 0
  const __m256d t2 = _mm256_unpacklo_pd(r[2], r[3]), t3 = _mm256_unpackhi_pd(r[2], r[3]);
  x = _mm256_permute2f128_pd(t0, t2, 0x20);
  y = _mm256_permute2f128_pd(t1, t3, 0x20);
  z = _mm256_permute2f128_pd(t0, t2, 0x31);
}

// x, y, z registers → 4 x (x, y, z, 0) rows, the inverse: the corner forces back into per-vertex form.
__attribute__((target("avx2"))) inline void transpose_columns(__m256d x, __m256d y, __m256d z, __m256d* r) noexcept {
  const __m256d zero = _mm256_setzero_pd();
  const __m256d t0 = _mm256_unpacklo_pd(x, y), t1 = _mm256_unpackhi_pd(x, y);        // x0 y0 x2 y2, x1 y1 x3 y3
  const __m256d t2 = _mm256_unpacklo_pd(z, zero), t3 = _mm256_unpackhi_pd(z, zero);  // z0 0 z2 0, z1 0 z3 0
  r[0] = _mm256_permute2f128_pd(t0, t2, 0x20);
  r[1] = _mm256_permute2f128_pd(t1, t3, 0x20);
  r[2] = _mm256_permute2f128_pd(t0, t2, 0x31);
  r[3] = _mm256_permute2f128_pd(t1, t3, 0x31);
}

}  // namespace

// The volume term's forces on the padded layout (x at xv[8i …], sums at fr[8i …], x, y, z, 0): the
// same forces as add_volume_forces (round-off level; the sums in another order of tetrahedra),
// four tetrahedra at a time in the order SolverLayouts::volume_corners lays out. Each lane is one
// tetrahedron: its edge vectors a, b, c are taken per vertex (three subtractions of 256-bit rows)
// and transposed, the cross products and 6V are then plain lane-wise FMAs (no lane rotations, no
// horizontal sum), and the four corners' forces are transposed back and added one tetrahedron at
// a time, corners 1, 2, 3, 0 as in the scalar form, each a load-add-store of its own, so a corner
// shared within a group is summed right. On the Zen 3 this was tuned on, twelve vgatherdpd per
// group instead of the loads and transposes took 1.5–2.5× as long; transposing the corners'
// positions (four transposes) instead of the edges measured the same. The last (tets mod 4) go
// one at a time.
__attribute__((target("avx2,fma"))) void volume_pass_avx2(const SpringModel& model, const double* xv,
                                                           double* fr) noexcept {
  const size_t T = model.network.tets.size(), G = T / 4;
  const double kappa = model.network.volume_modulus;
  const int* corners = model.solver->volume_corners.data();
  const double* scale = model.solver->volume_scale.data();
  const __m256d k6 = _mm256_set1_pd(kappa / 6);
  for (size_t g = 0; g < G; ++g) {
    const int* o = corners + 16 * g;  // corner c of lane l at o[4c + l]
    __m256d e[3][4];                  // edge k (a, b, c) of lane l as (x, y, z, 0)
    for (int l = 0; l < 4; ++l) {
      const __m256d p0 = _mm256_load_pd(xv + o[l]);
      for (int k = 0; k < 3; ++k) e[k][l] = _mm256_sub_pd(_mm256_load_pd(xv + o[4 * (k + 1) + l]), p0);
    }
    __m256d ax, ay, az, bx, by, bz, cx, cy, cz;
    transpose_rows(e[0], ax, ay, az);
    transpose_rows(e[1], bx, by, bz);
    transpose_rows(e[2], cx, cy, cz);
    // 6 ∇V at corners 1, 2, 3: b × c, c × a, a × b; lane-wise.
    __m256d gx[4], gy[4], gz[4];
    gx[1] = _mm256_fmsub_pd(by, cz, _mm256_mul_pd(bz, cy));
    gy[1] = _mm256_fmsub_pd(bz, cx, _mm256_mul_pd(bx, cz));
    gz[1] = _mm256_fmsub_pd(bx, cy, _mm256_mul_pd(by, cx));
    gx[2] = _mm256_fmsub_pd(cy, az, _mm256_mul_pd(cz, ay));
    gy[2] = _mm256_fmsub_pd(cz, ax, _mm256_mul_pd(cx, az));
    gz[2] = _mm256_fmsub_pd(cx, ay, _mm256_mul_pd(cy, ax));
    gx[3] = _mm256_fmsub_pd(ay, bz, _mm256_mul_pd(az, by));
    gy[3] = _mm256_fmsub_pd(az, bx, _mm256_mul_pd(ax, bz));
    gz[3] = _mm256_fmsub_pd(ax, by, _mm256_mul_pd(ay, bx));
    const __m256d v6 = _mm256_fmadd_pd(az, gz[1], _mm256_fmadd_pd(ay, gy[1], _mm256_mul_pd(ax, gx[1])));  // 6 V
    // −p / 6 = −κ (V − V0) / (6 V0) = κ/6 − κ/(36 V0) · 6V, the factor precomputed per tetrahedron.
    const __m256d sv = _mm256_fnmadd_pd(_mm256_loadu_pd(scale + 4 * g), v6, k6);
    // Corner 0's force is −(the others'): kept positive here and subtracted below.
    gx[0] = _mm256_mul_pd(sv, _mm256_add_pd(_mm256_add_pd(gx[1], gx[2]), gx[3]));
    gy[0] = _mm256_mul_pd(sv, _mm256_add_pd(_mm256_add_pd(gy[1], gy[2]), gy[3]));
    gz[0] = _mm256_mul_pd(sv, _mm256_add_pd(_mm256_add_pd(gz[1], gz[2]), gz[3]));
    __m256d f[4][4];  // corner c's force on lane l's tetrahedron as (x, y, z, 0)
    transpose_columns(gx[0], gy[0], gz[0], f[0]);
    for (int c = 1; c < 4; ++c)
      transpose_columns(_mm256_mul_pd(sv, gx[c]), _mm256_mul_pd(sv, gy[c]), _mm256_mul_pd(sv, gz[c]), f[c]);
    for (int l = 0; l < 4; ++l) {
      for (int c = 1; c < 4; ++c) {
        double* q = fr + o[4 * c + l];
        _mm256_store_pd(q, _mm256_add_pd(_mm256_load_pd(q), f[c][l]));
      }
      double* q = fr + o[l];
      _mm256_store_pd(q, _mm256_sub_pd(_mm256_load_pd(q), f[0][l]));
    }
  }
  for (size_t t = 4 * G; t < T; ++t) {  // the last ones, scalar
    const int* o = corners + 4 * t;
    const TetGradients g = tet_gradients(xv + o[0], xv + o[1], xv + o[2], xv + o[3]);
    add_tet_forces(g, kappa / 6 - scale[t] * g.v6, fr + o[0], fr + o[1], fr + o[2], fr + o[3]);
  }
}

}  // namespace palpate::spring
