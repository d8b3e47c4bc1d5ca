// forces.h — the spring and volume passes for generic (not all-pairs) networks and the all-pairs
// kernels, in their scalar reference and AVX2 / AVX-512 forms (internal; implemented in
// spring_pass.cpp, volume_pass.cpp and all_pairs.cpp, used by the step and the tests).
#pragma once

#include <palpate/spring.h>

#include "tissue/spring/cpu.h"
#include "tissue/spring/layouts.h"

#include <cstdint>
#include <vector>

namespace palpate::spring {

// ∇V of a tetrahedron's volume V = (x1 − x0)·((x2 − x0) × (x3 − x0)) / 6 at each corner:
// g1 = (x2 − x0) × (x3 − x0) / 6, g2 = (x3 − x0) × (x1 − x0) / 6, g3 = (x1 − x0) × (x2 − x0) / 6,
// g0 = −(g1 + g2 + g3). m²
inline std::array<Vec3, 4> tet_volume_gradients(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Vec3& x3) {
  const Vec3 a = x1 - x0, b = x2 - x0, c = x3 - x0;
  const Vec3 g1 = b.cross(c) / 6, g2 = c.cross(a) / 6, g3 = a.cross(b) / 6;
  return {-(g1 + g2 + g3), g1, g2, g3};
}

// The volume term's forces (SpringNetwork::tets): on each tetrahedron the pressure
// p = κ (V − V0) / V0 pushes its corners along −p ∇V, i.e. toward its rest volume, also from
// inverted (V < 0) configurations. x: vertex i's position at x[stride i …]; forces added at
// f[fstride i …]. Returns the volume term's elastic energy Σ ½ κ (V − V0)² / V0 (J).
double add_volume_forces(const SpringNetwork& net, const double* x, size_t stride, double* f, size_t fstride) noexcept;

// The volume term's forces on the padded layout (x at xv[8i …], sums added at fr[8i …]), four
// tetrahedra at a time in the order of SolverLayouts::volume_corners (layout_volume_pass), with AVX2 + FMA.
void volume_pass_avx2(const SpringModel& model, const double* xv, double* fr) noexcept;

// Lays out the vectorised volume pass (SolverLayouts::volume_scale, volume_corners) for model.network's
// tetrahedra: with `order` empty, greedily in the mesh's order, each tetrahedron joining the first of
// up to 32 open groups with which it shares no corner (so that a group's four read-modify-writes
// per corner do not wait on each other, and nearby tetrahedra stay close for the cache); otherwise
// in `order` as given (a permutation of the tetrahedra; the tests use it to put shared corners in a
// group). Clears both when the model has no volume term.
void layout_volume_pass(SpringModel& model, const std::vector<int>& order = {});

// Hooke-plus-damper spring forces added to f, and in the same pass over the springs the predictor
// right-hand side's −h K_L v term added to r (DS99 §4.2):
//   f_i += [k_e (l − L_e) + c_e (v_j − v_i)·u] u,  f_j −= the same,  u = (x_j − x_i)/l (none when l = 0),
//   r_i += h k_e (v_j − v_i),  r_j −= the same.
// x, v, f, r are (n x 3). vectorised: four springs at a time with AVX2 or AVX-512 on padded
// copies of x, v (scratch: spring_pass_scratch() doubles); the scalar loop otherwise or without
// AVX2 + FMA. The AVX2 pass takes the same square root and division as the scalar one; the AVX-512
// one 1/l from rsqrt14 and two Newton steps. All agree to round-off.
// kernel: avx2 forces the AVX2 pass where AVX-512 would be chosen (best); scalar the scalar loop.
enum class SpringKernel;
void add_spring_forces_and_stiffness_term(const SpringModel& model, const RowMat3d& x, const RowMat3d& v,
                                          RowMat3d& f, RowMat3d& r, double* scratch, bool vectorised,
                                          SpringKernel kernel) noexcept;

// The vectorised pass on the padded layout, without copying its sums out: x, v are copied into xv
// (eight doubles per vertex, one cache line: x, y, z, 0, vx, vy, vz, 0), and the pass adds the
// springs' forces and the −h K_L v term into fr (the same: fx, fy, fz, 0, rx, ry, rz, 0), from
// zero. Returns xv (at the first 64-byte boundary in scratch); fr follows it 8n doubles on
// (scratch: spring_pass_scratch() doubles). Needs has_avx2_fma() and at least one spring (the
// caller checks: spring_pass_padded_available).
double* spring_pass_padded(const SpringModel& model, const RowMat3d& x, const RowMat3d& v, double* scratch,
                           SpringKernel kernel) noexcept;
bool spring_pass_padded_available(const SpringModel& model) noexcept;

// Doubles of scratch the vectorised pass needs: (16n + 7), xv and fr with eight doubles per vertex
// from the first 64-byte boundary on (scratch is only 8-byte aligned).
size_t spring_pass_scratch(const SpringModel& model);

// Which kernel a call takes: best, the fastest this processor runs (the step's choice); the others
// force one (the tests compare them). One this processor lacks falls back to the next narrower.
enum class SpringKernel { best, scalar, avx2, avx512 };

inline void add_spring_forces_and_stiffness_term(const SpringModel& model, const RowMat3d& x, const RowMat3d& v,
                                                 RowMat3d& f, RowMat3d& r, double* scratch, bool vectorised) noexcept {
  add_spring_forces_and_stiffness_term(model, x, v, f, r, scratch, vectorised, SpringKernel::best);
}

// The all-pairs forces (the springs in is_all_pairs order, uniform: one stiffness and damping)
// added to the force arrays of the structure-of-arrays block p: x, y, z, vx, vy, vz, fx, fy, fz,
// n each, stride ≥ n apart; coincident vertices (l² below 1e-30 m²) get no force. The AVX-512
// kernel needs p 64-byte aligned and stride a multiple of 8 (all_pairs_stride); otherwise the
// AVX2 one runs.
void add_all_pair_forces_soa(const SpringNetwork& net, bool uniform, double* p, size_t stride,
                             SpringKernel kernel) noexcept;

// The all-pairs block's stride for n vertices (n rounded up to a multiple of 8), and the doubles of
// scratch it takes from any 8-byte aligned start: 9 strides and up to 7 doubles to the first
// 64-byte boundary.
size_t all_pairs_stride(size_t n) noexcept;
size_t all_pairs_scratch(size_t n) noexcept;

// The first 64-byte boundary at or after p.
inline double* align64(double* p) noexcept {
  const std::uintptr_t at = reinterpret_cast<std::uintptr_t>(p);
  return p + ((64 - at % 64) % 64) / sizeof(double);
}

}  // namespace palpate::spring
