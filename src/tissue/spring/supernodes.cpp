// supernodes.cpp — the build-time partition of the sparse predictor's factor into supernodes
// (relaxed amalgamation) and its layout for the per-tick sweeps (solve.cpp).
#include "tissue/spring/solve.h"

#include "tissue/spring/supernode_layout.h"

#include <algorithm>
#include <iterator>
#include <utility>
#include <vector>

namespace palpate::spring {

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
    if (w < kGatherWidth) {
      sn.value_start[k + 1] = sn.value_start[k];  // in the chunk program instead
    } else {
      sn.value_start[k] = round8(sn.value_start[k]);  // zeros after the block before
      sn.value_start[k + 1] = sn.value_start[k] + wide_block_size(w, r);
      sn.max_height = std::max(sn.max_height, static_cast<int>(round8(w) + round8(r)));
    }
  }
  sn.values.assign(sn.value_start[S], 0.0);
  std::vector<int> position(static_cast<size_t>(n), -1);  // block row of each row index
  std::vector<std::pair<int, double>> entries;
  sn.chunk_start.assign(S + 1, 0);
  for (size_t k = 0; k < S; ++k) {
    const int f0 = sn.first_column[k], e = sn.first_column[k + 1];
    const size_t w = static_cast<size_t>(e - f0);
    sn.chunk_start[k + 1] = sn.chunk_start[k];
    if (w < kGatherWidth) {
      // Narrow: each column's entries of L (its rows ascending) in chunks of four, the last padded.
      for (int c = f0; c < e; ++c) {
        entries.clear();
        for (int q = cs[c]; q < cs[c + 1]; ++q) entries.emplace_back(rw[q], p.value[static_cast<size_t>(q)]);
        std::sort(entries.begin(), entries.end());
        for (size_t q = 0; q < entries.size(); q += 4) {
          sn.pivot.push_back(c);
          for (size_t l = q; l < q + 4; ++l) {
            sn.chunk_rows.push_back(l < entries.size() ? entries[l].first : c);
            sn.chunk_values.push_back(l < entries.size() ? entries[l].second : 0.0);
          }
          ++sn.chunk_start[k + 1];
        }
      }
      continue;
    }
    for (int q = sn.row_start[k]; q < sn.row_start[k + 1]; ++q) position[static_cast<size_t>(sn.rows[static_cast<size_t>(q)])] = q - sn.row_start[k];
    const size_t rcount = static_cast<size_t>(sn.row_start[k + 1] - sn.row_start[k]);
    for (int c = f0; c < e; ++c) {
      const size_t i = static_cast<size_t>(c - f0);
      for (int q = cs[c]; q < cs[c + 1]; ++q) {
        const int r = rw[q];
        const size_t row = r < e ? static_cast<size_t>(r - f0) : w + static_cast<size_t>(position[static_cast<size_t>(r)]);
        sn.values[sn.value_start[k] + wide_entry(w, rcount, row, i)] = p.value[static_cast<size_t>(q)];
      }
    }
  }
  // The narrow runs' ends, for the sweeps to go through a run's chunks in one loop.
  sn.run_end.assign(S, 0);
  sn.run_begin.assign(S, 0);
  const auto narrow = [&](size_t k) { return sn.first_column[k + 1] - sn.first_column[k] < static_cast<int>(kGatherWidth); };
  for (size_t k = 0; k < S; ++k)
    sn.run_begin[k] = narrow(k) && k > 0 && narrow(k - 1) ? sn.run_begin[k - 1] : static_cast<int>(k);
  for (size_t k = S; k-- > 0;)
    sn.run_end[k] = !narrow(k) ? static_cast<int>(k) + 1 : k + 1 < S && narrow(k + 1) ? sn.run_end[k + 1] : static_cast<int>(k) + 1;
  if (single) {
    sn.values_single.assign(sn.values.begin(), sn.values.end());
    decltype(sn.values)().swap(sn.values);
    sn.chunk_values_single.assign(sn.chunk_values.begin(), sn.chunk_values.end());
    decltype(sn.chunk_values)().swap(sn.chunk_values);
  }
  return sn;
}

size_t supernodal_scratch(const SpringPredictor& p, const SpringSupernodes& sn) {
  return 4 * static_cast<size_t>(p.n) + 3 * round8(static_cast<size_t>(sn.max_height));
}

}  // namespace palpate::spring
