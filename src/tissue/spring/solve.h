// solve.h — the sparse predictor's per-tick solve: the supernodal form of its LDLᵀ factor and the
// permuted triangular solves over it (internal; used by model.cpp, step.cpp and the tests).
#pragma once

#include "tissue/spring/layouts.h"

namespace palpate::spring {

struct PredictorCorrection;  // cut.h

// The builds of the sweeps: any x86-64 (SSE2), x86-64-v3 (AVX2 + FMA), x86-64-v4 (AVX-512).
enum class SolveIsa { x86_64 = 1, x86_64_v3 = 3, x86_64_v4 = 4, best = 4 };

// Which fill-reducing ordering the sparse predictor's factor uses.
enum class SparseOrdering {
  fewest_nonzeros,    // both below, keep the sparser factor (what build_predictor does)
  amd,                // Eigen's approximate minimum degree only (palpate's first ordering)
  nested_dissection,  // METIS only
};

// build_predictor with a chosen ordering (for benchmarks and tests; desbrun and exact ignore it).
Result<SpringPredictor> build_predictor(const SpringNetwork& network, const SpringModelOptions& options,
                                        SparseOrdering ordering, const Progress& progress = {});

// Group the columns of the predictor's factor (kind sparse) into supernodes: runs of consecutive
// columns stored as one dense block (a strictly lower triangle and the rows below), grown greedily
// while the block stores at most (1 + max_padding) times the entries of L it holds (the rest are
// explicit zeros: relaxed amalgamation, Ashcraft & Grimes 1989) and is at most max_width wide.
// max_padding = 0 gives exact (fundamental-like) supernodes.
// single: keep the values in float (values_single) instead of double.
SpringSupernodes make_supernodes(const SpringPredictor& predictor, bool single = false, double max_padding = 0.25,
                                 int max_width = 128);

// Doubles of scratch solve_supernodal needs: 4n + 3·max_height rounded up to 8.
size_t supernodal_scratch(const SpringPredictor& predictor, const SpringSupernodes& supernodes);

// x = A⁻¹ b for b, x (n x 3) with A = Pᵀ L D Lᵀ P: permute into four doubles per vertex (x, y, z,
// 0), forward substitution block by block (a run of narrow blocks as one loop over its chunks of
// four entries, in place, one four-wide multiply-add per entry; a wide block's triangle solved on
// a structure-of-arrays copy of its columns and its rows below updated by a product over its
// panels of eight rows), scale by D⁻¹, back substitution (the same, transposed), permute back.
// The three coordinates share every value of L read. Float values are widened and accumulated in
// double, except in the wide blocks of the x86-64-v4 build: there they are multiplied and summed
// in float, sixteen lanes (two panel columns) at a time, with the block's rows rounded to float on
// the way in (the error bound is in tests/test_spring_solve.cpp). scratch holds
// supernodal_scratch() doubles. b and x may not alias.
// isa caps the instruction set of the sweeps (the tests run every build; the step takes the best).
// correction (optional): a cut's low-rank correction (cut.h), applied between the sweeps.
void solve_supernodal(const SpringPredictor& predictor, const SpringSupernodes& supernodes, const RowMat3d& b,
                      RowMat3d& x, double* scratch, SolveIsa isa = SolveIsa::best,
                      const PredictorCorrection* correction = nullptr) noexcept;

// The same solve on a right-hand side already permuted into z4 (4n: row perm[i] holds b's row i as
// x, y, z, 0), in place: on return z4 holds the solution in the same order. g holds
// 3·max_height rounded up to 8 doubles (the block being solved). For callers that build the
// permuted right-hand side in the same pass as something else (the step).
void solve_supernodal_permuted(const SpringPredictor& predictor, const SpringSupernodes& supernodes, double* z4,
                               double* g, SolveIsa isa = SolveIsa::best,
                               const PredictorCorrection* correction = nullptr) noexcept;

// x (n x 3, row-major) from z4 in the solve's permuted layout: x's row i is z4's row perm[i].
void unpermute_rows(const SpringPredictor& predictor, const double* z4, double* x) noexcept;

// The reference: the same solve column by column over the CSC factor (one index per entry).
void solve_columns(const SpringPredictor& predictor, const RowMat3d& b, RowMat3d& x, RowMat3d& scratch) noexcept;

// x = A⁻¹ b with the dense inverse (desbrun): one pass over A⁻¹'s rows for the three coordinates,
// from inverse_single (float, widened) when it is not empty. With symmetric (the step's choice)
// and AVX-512, the double inverse is read from its upper triangle only (A⁻¹ is symmetric, and
// build_spring_model makes the stored one exactly so): half the bytes, the same sums in another
// order. scratch holds dense_scratch(n) doubles.
void solve_dense(const SpringPredictor& predictor, const std::vector<float>& inverse_single, const RowMat3d& b,
                 RowMat3d& x, double* scratch, bool symmetric = true) noexcept;

// How far `predictor` is from being the inverse of the network's matrix A (for these options): with
// b = A x for a fixed spread of values x (three columns), x̂ the predictor's solve of b, the backward
// error ‖A x̂ − b‖∞ / (‖A‖∞ ‖x̂‖∞ + ‖b‖∞). Round-off (1e-16 to 1e-12) for the network's own
// factor or inverse; order 1 for one of another matrix. NaN when the solve is not finite. A file's
// checksum proves only that nobody damaged it by accident (load_predictor checks this as well).
double predictor_residual(const SpringNetwork& network, const SpringModelOptions& options,
                          const SpringPredictor& predictor);

// Doubles of scratch solve_dense needs: six arrays of n rounded up to 8, from a 64-byte boundary.
size_t dense_scratch(int n);

}  // namespace palpate::spring
