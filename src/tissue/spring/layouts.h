// layouts.h — the solvers' internal layouts of a spring model (SpringModel::solver): the sparse
// factor's supernodal form, the float copies of the predictor and rest lengths, the volume pass's
// lanes (internal; built in model.cpp and supernodes.cpp, read by the step's stages and the tests).
#pragma once

#include <palpate/spring.h>

#include "core/memory.h"

#include <vector>

namespace palpate::spring {

struct PredictorCorrection;  // cut.h

// The per-tick form of a sparse predictor's factor L (unit lower triangular, permuted), derived
// from SpringPredictor when the model is built and never stored in files. Runs of consecutive
// columns with (nearly) the same rows below them form a supernode (Liu, Ng & Peyton 1993; relaxed:
// entries L lacks are stored as zeros, at most a quarter as many as it has), kept as one dense block, so
// the triangular solves stream contiguous values with one row index per block row instead of one
// per entry. S supernodes.
struct SpringSupernodes {
  std::vector<int> first_column;  // (S + 1) supernode k holds columns [first_column[k], first_column[k + 1])
  std::vector<int> row_start;     // (S + 1) its rows below the block: rows[row_start[k] .. row_start[k + 1])
  std::vector<int> rows;          // permuted row indices below each supernode, ascending
  std::vector<size_t> value_start;  // (S + 1) a wide block's values (4 columns or more; zeros where
                                    // L has none): from a multiple of eight, a dense block of its
                                    // own rows and its rows below, in panels of eight rows
                                    // (solve.cpp, WideShape); none for a narrow block
  std::vector<double, CacheLineAllocator<double>> values;  // L's entries in that layout
  std::vector<float, CacheLineAllocator<float>> values_single;  // the same in float instead
                                                                 // (SpringModelOptions::single_precision)
  // The narrow blocks (1 to 3 columns; mostly single columns of a few entries, the nested
  // dissection's leaves) as one program of chunks of four entries, so the sweeps run through them
  // without a loop per block or per column: chunk q holds pivot[q] (a column), four of its rows
  // chunk_rows[4q …] and L's values there chunk_values[4q …] (only L's own entries; a column's last
  // chunk padded with its pivot row and the value 0). A column's chunks follow each other, columns
  // in order. Supernode k's chunks are [chunk_start[k], chunk_start[k + 1]) (none for a wide one);
  // run_end[k] is the first wide supernode after narrow k (S when none), run_begin[k] the first of
  // the narrow run holding k (for a wide k: k + 1 and k).
  std::vector<int> chunk_start;   // (S + 1)
  std::vector<int> run_end;       // (S)
  std::vector<int> run_begin;     // (S)
  std::vector<int> pivot;         // (C) the column of each chunk
  std::vector<int> chunk_rows;    // (4C)
  std::vector<double, CacheLineAllocator<double>> chunk_values;        // (4C), or empty in float
  std::vector<float, CacheLineAllocator<float>> chunk_values_single;   // (4C) with values_single
  int max_width = 0;              // widest supernode
  int max_height = 0;             // tallest supernode, width + rows below, each rounded up to 8 in a
                                  // wide block (sizes the solve's scratch)
  bool empty() const { return first_column.empty(); }
};

// The solvers' own layouts of one model (SpringSolverLayouts, its opaque holder in palpate/spring.h).
struct SolverLayouts {
  SpringSupernodes supernodes;          // sparse: the factor as the step uses it (built from predictor)
  // A cut's low-rank correction of the predictor (cut.h), owned by the model's SpringCutter and
  // installed by it on the stepping thread; null when nothing is cut or the factor is current. A
  // copy of the model does not carry it (its cutter does not follow).
  const PredictorCorrection* correction = nullptr;
  std::vector<float> inverse_single;    // desbrun with single_precision: (n x n) row-major A⁻¹ in float
  std::vector<float> rest_length_single;  // all-pairs with single_precision and uniform springs: (s) m
  // The volume pass's tetrahedra, four at a time (layout_volume_pass): in groups of four that share
  // no corner where a nearby tetrahedron allows it, taken in the mesh's order, then the last
  // (tets mod 4) one at a time. With SpringModel::volume_term:
  std::vector<double> volume_scale;     // (tets) κ / (36 V0) of each tetrahedron, in the pass's order, Pa/m³
  std::vector<int> volume_lane;         // (tets) where each tetrahedron sits in the pass's order
  std::vector<int> volume_corners;      // (4 tets) 8 × its corners' vertex indices (offsets into the padded
                                        // layout): group g's corner c of lane l at [16g + 4c + l]; a
                                        // tetrahedron t of the last ones at [4t + c]
};

}  // namespace palpate::spring
