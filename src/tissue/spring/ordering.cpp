// ordering.cpp — METIS nested dissection for the sparse predictor (the only file that includes metis.h).
#include "tissue/spring/ordering.h"

#include <metis.h>

#include <algorithm>

namespace palpate::spring {

std::vector<int> nested_dissection(int n, const std::vector<std::array<int, 2>>& edges, int separators,
                                   int imbalance) {
  if (n <= 0) return {};
  // METIS wants the adjacency in CSR without self-loops, each edge in both directions.
  std::vector<idx_t> degree(static_cast<size_t>(n) + 1, 0);
  for (const auto& e : edges)
    if (e[0] != e[1]) {
      ++degree[static_cast<size_t>(e[0]) + 1];
      ++degree[static_cast<size_t>(e[1]) + 1];
    }
  std::vector<idx_t> xadj(degree);
  for (int i = 0; i < n; ++i) xadj[static_cast<size_t>(i) + 1] += xadj[static_cast<size_t>(i)];
  std::vector<idx_t> adjncy(static_cast<size_t>(xadj.back()));
  std::vector<idx_t> fill(xadj.begin(), xadj.end() - 1);
  for (const auto& e : edges)
    if (e[0] != e[1]) {
      adjncy[static_cast<size_t>(fill[static_cast<size_t>(e[0])]++)] = e[1];
      adjncy[static_cast<size_t>(fill[static_cast<size_t>(e[1])]++)] = e[0];
    }
  // Remove duplicate neighbours (METIS expects a simple graph).
  std::vector<idx_t> xs(static_cast<size_t>(n) + 1, 0), adj;
  adj.reserve(adjncy.size());
  for (int i = 0; i < n; ++i) {
    auto b = adjncy.begin() + xadj[static_cast<size_t>(i)], e = adjncy.begin() + xadj[static_cast<size_t>(i) + 1];
    std::sort(b, e);
    e = std::unique(b, e);
    adj.insert(adj.end(), b, e);
    xs[static_cast<size_t>(i) + 1] = static_cast<idx_t>(adj.size());
  }
  idx_t nv = n;
  idx_t options[METIS_NOPTIONS];
  METIS_SetDefaultOptions(options);
  options[METIS_OPTION_NUMBERING] = 0;
  options[METIS_OPTION_NSEPS] = std::max(separators, 1);
  if (imbalance > 0) options[METIS_OPTION_UFACTOR] = imbalance;
  std::vector<idx_t> perm(static_cast<size_t>(n)), iperm(static_cast<size_t>(n));
  if (adj.empty()) adj.push_back(0);  // METIS reads adjncy[0] even for an edgeless graph
  if (METIS_NodeND(&nv, xs.data(), adj.data(), nullptr, options, perm.data(), iperm.data()) != METIS_OK) return {};
  // METIS: perm[k] is the old vertex placed at position k, iperm[i] the position of vertex i.
  return std::vector<int>(iperm.begin(), iperm.end());
}

}  // namespace palpate::spring
