// volume_pass.cpp — the volume term's forces (docs/models/mass-spring.md, "Volume"; the law in
// laws.h): the scalar pass on any layout and the four-wide AVX2 pass on the padded one.
#include <palpate/spring.h>

#include "core/simd.h"
#include "tissue/spring/forces.h"
#include "tissue/spring/laws.h"

namespace palpate::spring {

namespace {

// A tetrahedron's gradients from its corners p0..p3 (x, y, z each).
inline TetGradients<double> tet_gradients(const double* p0, const double* p1, const double* p2,
                                          const double* p3) noexcept {
  return spring::tet_gradients(p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2], p2[0] - p0[0], p2[1] - p0[1],
                               p2[2] - p0[2], p3[0] - p0[0], p3[1] - p0[1], p3[2] - p0[2]);
}
// s times the gradients onto the corners' forces (corner 0 gets minus their sum).
inline void add_tet_forces(const TetGradients<double>& t, double s, double* f0, double* f1, double* f2,
                           double* f3) noexcept {
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
    if (q[0] == q[1]) continue;  // removed by a cut (cut.cpp collapses it onto one corner)
    const TetGradients<double> g =
        tet_gradients(x + stride * static_cast<size_t>(q[0]), x + stride * static_cast<size_t>(q[1]),
                      x + stride * static_cast<size_t>(q[2]), x + stride * static_cast<size_t>(q[3]));
    const double v0 = net.rest_volume[t];
    const double dv = g.v6 / 6 - v0;
    energy += 0.5 * kappa * dv * dv / v0;
    add_tet_forces(g, volume_force_factor(kappa, v0, g.v6), f + fstride * static_cast<size_t>(q[0]),
                   f + fstride * static_cast<size_t>(q[1]), f + fstride * static_cast<size_t>(q[2]),
                   f + fstride * static_cast<size_t>(q[3]));
  }
  return energy;
}

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
PALPATE_AVX2 void volume_pass_avx2(const SpringModel& model, const double* xv, double* fr) noexcept {
  using namespace simd;
  const size_t T = model.network.tets.size(), G = T / 4;
  const double kappa = model.network.volume_modulus;
  const int* corners = model.solver->volume_corners.data();
  const double* scale = model.solver->volume_scale.data();
  const d4 k6 = broadcast<d4>(kappa / 6);
  for (size_t g = 0; g < G; ++g) {
    const int* o = corners + 16 * g;  // corner c of lane l at o[4c + l]
    d4 e[3][4];                       // edge k (a, b, c) of lane l as (x, y, z, 0)
    for (int l = 0; l < 4; ++l) {
      const d4 p0 = load<d4>(xv + o[l]);
      for (int k = 0; k < 3; ++k) e[k][l] = load<d4>(xv + o[4 * (k + 1) + l]) - p0;
    }
    d4 ax, ay, az, bx, by, bz, cx, cy, cz;
    transpose3(e[0], ax, ay, az);
    transpose3(e[1], bx, by, bz);
    transpose3(e[2], cx, cy, cz);
    const TetGradients<d4> t = tet_gradients_avx2(ax, ay, az, bx, by, bz, cx, cy, cz);
    const d4 s = volume_force_factor_avx2(k6, loadu<d4>(scale + 4 * g), t.v6);
    // Corner 0's force is −(the others'): kept positive here and subtracted below.
    d4 f[4][4];  // corner c's force on lane l's tetrahedron as (x, y, z, 0)
    transpose3(s * ((t.g[0][0] + t.g[1][0]) + t.g[2][0]), s * ((t.g[0][1] + t.g[1][1]) + t.g[2][1]),
               s * ((t.g[0][2] + t.g[1][2]) + t.g[2][2]), f[0]);
    for (int c = 1; c < 4; ++c) transpose3(s * t.g[c - 1][0], s * t.g[c - 1][1], s * t.g[c - 1][2], f[c]);
    for (int l = 0; l < 4; ++l) {
      for (int c = 1; c < 4; ++c) {
        double* q = fr + o[4 * c + l];
        store(q, load<d4>(q) + f[c][l]);
      }
      double* q = fr + o[l];
      store(q, load<d4>(q) - f[0][l]);
    }
  }
  for (size_t t = 4 * G; t < T; ++t) {  // the last ones, scalar
    const int* o = corners + 4 * t;
    const TetGradients<double> g = tet_gradients(xv + o[0], xv + o[1], xv + o[2], xv + o[3]);
    add_tet_forces(g, volume_force_factor_precomputed(kappa / 6, scale[t], g.v6), fr + o[0], fr + o[1], fr + o[2],
                   fr + o[3]);
  }
}

}  // namespace palpate::spring
