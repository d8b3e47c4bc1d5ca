// cut.h — the predictor's low-rank correction for springs and tetrahedra removed by a cut (internal;
// built off the haptic thread in cut.cpp, applied inside the step's solve; docs/models/cutting.md).
#pragma once

#include <palpate/spring.h>

#include <array>
#include <vector>

namespace palpate::spring {

// A cut removes weight from the predictor's matrix: A' = A − U W Uᵀ, U's column e the edge vector
// b_e = e_i − e_j of a spring whose weight w_e = h c_e + h² k_e (its damping and its predictor
// stiffness, the volume term's share included) fell (anchored components zero, as A's anchored rows
// and columns are the identity). Woodbury's identity keeps the step exact to the cut network with
// the factor of A:
//   A'⁻¹ = A⁻¹ + A⁻¹ U (I − W Uᵀ A⁻¹ U)⁻¹ W Uᵀ A⁻¹,
// M = (I − W Uᵀ A⁻¹ U)⁻¹ W (r x r) precomputed. The sparse factor A = Pᵀ L D Lᵀ P applies it between
// its sweeps, where the middle vector is t = D⁻¹ L⁻¹ P b: with V = L⁻¹ P U (sparse: column e lives on
// the elimination-tree paths from its two vertices to the root),
//   (D − V W Vᵀ)⁻¹ y = t + D⁻¹ V M Vᵀ t,
// an O(nnz(V)) update instead of a dense n x r product. The dense inverse applies x += Z M Uᵀ x with
// Z = A⁻¹ U (n x r).
struct PredictorCorrection {
  int rank = 0;                           // r, edges corrected
  double rcond = 1;                       // reciprocal condition estimate of I − W Uᵀ A⁻¹ U (its LU's)
  std::vector<std::array<int, 2>> edge;   // (r) the vertices of each edge, −1 where anchored
  std::vector<double> m;                  // (r x r) row-major M
  // Sparse: V's columns on permuted rows, and D⁻¹ V's values on the same rows.
  std::vector<int> col_start;             // (r + 1)
  std::vector<int> row;                   // permuted row of each entry
  std::vector<double> v, dv;
  // Dense: Z = A⁻¹ U, (n x r) row-major.
  std::vector<double> z;
  // Scratch of the apply (3r each), sized when built: the haptic thread allocates nothing.
  mutable std::vector<double> q, s;
  bool empty() const noexcept { return rank == 0; }
};

// The correction between the sweeps: z4 (4n, the permuted vertex rows x, y, z, 0) holds D⁻¹ L⁻¹ P b on
// entry and (D − V W Vᵀ)⁻¹ L⁻¹ P b on return.
void apply_middle(const PredictorCorrection& c, double* z4) noexcept;
// The dense correction after the product: x (n x 3, row-major) += Z M Uᵀ x.
void apply_dense(const PredictorCorrection& c, int n, double* x) noexcept;

// A weight change of the predictor's matrix: edge (i, j) (vertex indices) lost weight w (N·s/m
// times s, the units of A). Its anchored ends are dropped when the correction is built.
struct EdgeWeight {
  int i = 0, j = 0;
  double w = 0;
};

// The correction of `predictor` (sparse or dense, of a network whose anchored flags are `anchored`)
// for the removed weights. Allocates; not for the haptic thread.
PredictorCorrection build_correction(const SpringPredictor& predictor, const std::vector<std::uint8_t>& anchored,
                                     const std::vector<EdgeWeight>& removed);

// A new predictor for `network` (the cut network: removed springs with zero stiffness and damping,
// removed tetrahedra gone): dense, a new inverse; sparse, a numeric factorisation in the ordering
// and onto the pattern of `pattern` (a cut network's factor fills a subset of it), so the solve's
// supernodes and scratch do not change. model.cpp.
Result<SpringPredictor> refactor_predictor(const SpringNetwork& network, const SpringModelOptions& options,
                                           const SpringPredictor& pattern);

}  // namespace palpate::spring
