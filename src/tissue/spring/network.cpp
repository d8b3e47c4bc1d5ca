// network.cpp — mass-spring networks from meshes: which pairs get springs, lumped masses, and
// stiffness from a Young's modulus (Van Gelder 1998; docs/models/mass-spring.md).
#include <palpate/spring.h>

#include "core/memory.h"
#include "tissue/spring/forces.h"
#include "tissue/spring/shapes.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <unordered_map>
#include <unordered_set>

namespace palpate {

namespace {

std::string fmt_num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

std::uint64_t pair_key(int a, int b) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(a)) << 32) | static_cast<std::uint32_t>(b);
}

// Adds the spring (a, b) once; returns its index.
struct SpringSet {
  std::vector<std::array<int, 2>> springs;
  std::unordered_map<std::uint64_t, int> index;
  int add(int a, int b) {
    if (a > b) std::swap(a, b);
    auto [it, inserted] = index.try_emplace(pair_key(a, b), static_cast<int>(springs.size()));
    if (inserted) springs.push_back({a, b});
    return it->second;
  }
};

Status check_mesh_basics(const RowMat3d& V, Eigen::Index cells, int per_cell, const auto& cell,
                         const std::string& where, const char* what) {
  if (V.rows() < 2) return Error{where + ": a mass-spring network needs at least 2 vertices, got " +
                                 std::to_string(V.rows())};
  if (!V.allFinite()) return Error{where + ": vertex positions must be finite numbers"};
  for (Eigen::Index c = 0; c < cells; ++c)
    for (int k = 0; k < per_cell; ++k) {
      const int v = cell(c, k);
      if (v < 0 || v >= V.rows())
        return Error{where + ": " + what + " " + std::to_string(c) + " has vertex index " + std::to_string(v) +
                     ", expected 0.." + std::to_string(V.rows() - 1)};
    }
  return {};
}

Status finish(SpringNetwork& net, const SpringNetworkOptions& o, const std::vector<double>& carried_volume,
              double total_volume, const std::vector<double>& edge_volume, const std::string& where) {
  const size_t n = static_cast<size_t>(net.rest.rows());
  const size_t s = net.springs.size();
  // Masses: lumped from volume when a density is given, else the total shared equally.
  net.mass.assign(n, o.mass / static_cast<double>(n));
  if (o.density > 0) {
    for (size_t i = 0; i < n; ++i) net.mass[i] = o.density * carried_volume[i];
    for (size_t i = 0; i < n; ++i)
      if (!(net.mass[i] > 0))
        return Error{where + ": vertex " + std::to_string(i) +
                     " carries no volume, so density gives it no mass (is it used by any element?)"};
  }
  net.rest_length.resize(s);
  for (size_t e = 0; e < s; ++e) {
    const auto [a, b] = net.springs[e];
    net.rest_length[e] = (net.rest.row(a) - net.rest.row(b)).norm();
    if (!(net.rest_length[e] > 0))
      return Error{where + ": vertices " + std::to_string(a) + " and " + std::to_string(b) +
                   " coincide: a spring needs a positive rest length"};
  }
  net.stiffness.assign(s, o.stiffness);
  if (o.youngs_modulus > 0) {
    if (!edge_volume.empty()) {
      // Van Gelder (1998), volume form: k_e = α Σ_{T∋e} V_T / |e|². With edge directions spread
      // evenly, this network is an isotropic solid with λ = μ = 2α/5 (Cauchy's relation of
      // central forces), so E = α and ν = 1/4. With a Poisson ratio ν ≥ 1/4 the springs carry
      // the shear modulus μ = E / 2(1 + ν), α = 5μ/2, and the tetrahedra's volume term the
      // rest of λ: κ = λ − μ = μ (4ν − 1) / (1 − 2ν) (docs/models/mass-spring.md, "Volume").
      double alpha = o.youngs_modulus;
      if (o.poisson_ratio > 0) {
        const double mu = o.youngs_modulus / (2 * (1 + o.poisson_ratio));
        alpha = 2.5 * mu;
        net.volume_modulus = mu * (4 * o.poisson_ratio - 1) / (1 - 2 * o.poisson_ratio);
      }
      for (size_t e = 0; e < s; ++e)
        net.stiffness[e] = alpha * edge_volume[e] / (net.rest_length[e] * net.rest_length[e]);
    } else {
      // No elements per spring: one stiffness with the same total Σ k_e |e|² = 6 E V as the
      // tetrahedral rule (each tet has six edges).
      if (!(total_volume > 0))
        return Error{where + ": youngs_modulus needs a closed surface (enclosed volume is " +
                     fmt_num(total_volume) + " m³) or a tetrahedral mesh"};
      double sum = 0;
      for (double l : net.rest_length) sum += l * l;
      net.stiffness.assign(s, 6.0 * o.youngs_modulus * total_volume / sum);
    }
  }
  net.damping.assign(s, o.spring_damping);
  net.anchors = o.anchors;
  std::sort(net.anchors.begin(), net.anchors.end());
  net.anchors.erase(std::unique(net.anchors.begin(), net.anchors.end()), net.anchors.end());
  return validate(net, where);
}

// all_pairs puts n(n-1)/2 springs on n vertices: refused when they cannot fit (about 64 bytes a
// spring in the network and the model built from it), naming the key and the numbers.
Status check_all_pairs_fit(size_t n, const std::string& where) {
  const double springs = double(n) * double(n > 0 ? n - 1 : 0) / 2, need = springs * 64.0;
  const double memory = usable_memory_bytes();
  if (springs > 2e9 || (memory > 0 && need > memory))
    return Error{where + ": material.topology 'all_pairs' on " + std::to_string(n) + " vertices is " +
                 fmt::format("{:.3g}", springs) + " springs, about " + memory_text(need) + ", more than this machine's " +
                 memory_text(memory) + " of memory; expected topology edges or tet_edges"};
  return {};
}

void all_pairs(SpringNetwork& net) {
  const int n = static_cast<int>(net.rest.rows());
  net.springs.clear();
  net.springs.reserve(static_cast<size_t>(n) * static_cast<size_t>(n - 1) / 2);
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) net.springs.push_back({i, j});
}

}  // namespace

Result<SpringSolver> parse_solver(const std::string& name, const std::string& where) {
  if (name == "desbrun") return SpringSolver::desbrun;
  if (name == "sparse") return SpringSolver::sparse;
  if (name == "exact") return SpringSolver::exact;
  return Error{where + ": solver '" + name + "' is not one of desbrun|sparse|exact"};
}

Result<SpringNetworkOptions> network_options(const SpringMaterialDef& m, std::vector<int> anchors,
                                             const std::string& where) {
  SpringNetworkOptions o;
  if (m.topology == "all_pairs") o.topology = SpringTopology::all_pairs;
  else if (m.topology == "edges") o.topology = SpringTopology::edges;
  else if (m.topology == "tet_edges") o.topology = SpringTopology::tet_edges;
  else return Error{where + ": topology '" + m.topology + "' is not one of all_pairs|edges|tet_edges"};
  o.stiffness = m.stiffness;
  o.youngs_modulus = m.youngs_modulus;
  o.spring_damping = m.spring_damping;
  o.mass = m.mass;
  o.density = m.density;
  o.poisson_ratio = m.poisson_ratio;
  if (m.poisson_ratio > 0 && !(m.poisson_ratio >= 0.25 && m.poisson_ratio < 0.5))
    return Error{where + ": poisson_ratio " + fmt_num(m.poisson_ratio) +
                 " is outside [0.25, 0.5): a spring network alone is 0.25, the volume term only adds to it"};
  if (m.poisson_ratio > 0 && !(m.youngs_modulus > 0))
    return Error{where + ": poisson_ratio needs youngs_modulus (the volume term's modulus is derived from both)"};
  if (m.poisson_ratio > 0 && o.topology == SpringTopology::all_pairs)
    return Error{where + ": poisson_ratio needs tet_edges or edges on a tetrahedral mesh, not all_pairs"};
  o.fill.max_edge = m.fill_max_edge;
  if (m.fill_refine_size > 0) {
    if (m.fill_max_edge > 0 && m.fill_refine_size > m.fill_max_edge)
      return Error{where + ": fill_refine_size " + fmt_num(m.fill_refine_size) + " is larger than fill_max_edge " +
                   fmt_num(m.fill_max_edge) + ": the refined region must be finer than the rest"};
    if (o.topology != SpringTopology::tet_edges)
      return Error{where + ": fill_refine_size grades the tetrahedral fill of a surface: it needs topology tet_edges"};
    o.fill.refine.push_back(FillRefinement{.center = m.fill_refine_center, .radius = m.fill_refine_radius,
                                           .size = m.fill_refine_size, .growth = m.fill_refine_growth});
  }
  o.anchors = std::move(anchors);
  return o;
}

Result<SpringNetwork> make_spring_network(const TetMesh& mesh, const SpringNetworkOptions& o,
                                          const std::string& where) {
  if (Status st = check_mesh_basics(mesh.V, mesh.T.rows(), 4, mesh.T, where, "tetrahedron"); !st) return st.error();
  if (mesh.T.rows() == 0) return Error{where + ": the tetrahedral mesh has no tetrahedra"};
  SpringNetwork net;
  net.rest = mesh.V;
  const size_t n = static_cast<size_t>(mesh.V.rows());
  std::vector<double> carried(n, 0.0);
  double total = 0;
  SpringSet set;
  std::vector<double> edge_volume;
  static constexpr int kEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  for (Eigen::Index t = 0; t < mesh.T.rows(); ++t) {
    const Vec3 p0 = mesh.V.row(mesh.T(t, 0)).transpose();
    const double vol = (mesh.V.row(mesh.T(t, 1)).transpose() - p0)
                           .dot((mesh.V.row(mesh.T(t, 2)).transpose() - p0).cross(mesh.V.row(mesh.T(t, 3)).transpose() - p0)) /
                       6.0;
    if (!(vol > 0))
      return Error{where + ": tetrahedron " + std::to_string(t) + " has volume " + fmt_num(vol) +
                   " m³, expected > 0 (degenerate or inverted)"};
    total += vol;
    for (int k = 0; k < 4; ++k) carried[static_cast<size_t>(mesh.T(t, k))] += vol / 4;
    if (o.poisson_ratio > 0 && o.topology != SpringTopology::all_pairs) {
      net.tets.push_back({mesh.T(t, 0), mesh.T(t, 1), mesh.T(t, 2), mesh.T(t, 3)});
      net.rest_volume.push_back(vol);
    }
    if (o.topology != SpringTopology::all_pairs)
      for (const auto& e : kEdges) {
        const size_t idx = static_cast<size_t>(set.add(mesh.T(t, e[0]), mesh.T(t, e[1])));
        if (idx >= edge_volume.size()) edge_volume.resize(idx + 1, 0.0);
        edge_volume[idx] += vol;
      }
  }
  if (o.poisson_ratio > 0 && !(o.youngs_modulus > 0))
    return Error{where + ": poisson_ratio needs youngs_modulus"};
  if (o.topology == SpringTopology::all_pairs) {
    if (o.poisson_ratio > 0) return Error{where + ": poisson_ratio needs tet_edges or edges, not all_pairs"};
    if (Status st = check_all_pairs_fit(static_cast<size_t>(net.rest.rows()), where); !st) return st.error();
    all_pairs(net);
    edge_volume.clear();
  } else {
    net.springs = std::move(set.springs);
  }
  for (const auto& tri : spring::boundary_triangles(mesh)) net.triangles.push_back(tri);
  if (Status st = finish(net, o, carried, total, edge_volume, where); !st) return st.error();
  return net;
}

Result<SpringNetwork> make_spring_network(const SurfaceMesh& mesh, const SpringNetworkOptions& o,
                                          const std::string& where) {
  if (o.poisson_ratio > 0)
    return Error{where + ": poisson_ratio needs a tetrahedral mesh (topology tet_edges fills a surface)"};
  if (o.topology == SpringTopology::tet_edges)
    return Error{where + ": topology tet_edges needs a tetrahedral mesh; fill the surface with "
                         "tetrahedralize() first, or use edges or all_pairs"};
  if (Status st = check_mesh_basics(mesh.V, mesh.F.rows(), 3, mesh.F, where, "triangle"); !st) return st.error();
  SpringNetwork net;
  net.rest = mesh.V;
  const size_t n = static_cast<size_t>(mesh.V.rows());
  // The volume a closed surface encloses, by the divergence theorem: each triangle's cone to the
  // centroid, shared among its three vertices.
  Vec3 centroid = mesh.V.colwise().mean().transpose();
  std::vector<double> carried(n, 0.0);
  double total = 0;
  SpringSet set;
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    const int a = mesh.F(f, 0), b = mesh.F(f, 1), c = mesh.F(f, 2);
    const Vec3 pa = mesh.V.row(a).transpose() - centroid, pb = mesh.V.row(b).transpose() - centroid,
               pc = mesh.V.row(c).transpose() - centroid;
    const double vol = pa.dot(pb.cross(pc)) / 6.0;
    total += vol;
    for (int v : {a, b, c}) carried[static_cast<size_t>(v)] += vol / 3;
    if (a == b || b == c || a == c) return Error{where + ": triangle " + std::to_string(f) + " repeats a vertex"};
    set.add(a, b);
    set.add(b, c);
    set.add(c, a);
    net.triangles.push_back({a, b, c});
  }
  if (o.density > 0 && !(total > 0))
    return Error{where + ": density needs a closed, outward-oriented surface (enclosed volume is " +
                 fmt_num(total) + " m³)"};
  if (o.topology == SpringTopology::all_pairs) {
    if (Status st = check_all_pairs_fit(n, where); !st) return st.error();
    all_pairs(net);
  } else {
    net.springs = std::move(set.springs);
  }
  if (net.springs.empty()) return Error{where + ": the surface has no edges to put springs on"};
  if (Status st = finish(net, o, carried, total, {}, where); !st) return st.error();
  return net;
}

Status validate(const SpringNetwork& net, const std::string& where) {
  const size_t n = static_cast<size_t>(net.rest.rows());
  const size_t s = net.springs.size();
  if (n < 1) return Error{where + ": the network has no vertices"};
  if (net.mass.size() != n)
    return Error{where + ": " + std::to_string(net.mass.size()) + " masses for " + std::to_string(n) + " vertices"};
  if (net.rest_length.size() != s || net.stiffness.size() != s || net.damping.size() != s)
    return Error{where + ": rest_length, stiffness and damping need one value per spring (" + std::to_string(s) + ")"};
  if (!net.rest.allFinite()) return Error{where + ": rest positions must be finite"};
  for (size_t i = 0; i < n; ++i)
    if (!(net.mass[i] > 0) || !std::isfinite(net.mass[i]))
      return Error{where + ": vertex " + std::to_string(i) + " has mass " + fmt_num(net.mass[i]) + " kg, expected > 0"};
  std::unordered_set<std::uint64_t> seen;
  for (size_t e = 0; e < s; ++e) {
    const auto [a, b] = net.springs[e];
    if (a < 0 || b < 0 || static_cast<size_t>(a) >= n || static_cast<size_t>(b) >= n || a == b)
      return Error{where + ": spring " + std::to_string(e) + " joins " + std::to_string(a) + " and " +
                   std::to_string(b) + ", expected two different vertices in 0.." + std::to_string(n - 1)};
    if (!seen.insert(pair_key(std::min(a, b), std::max(a, b))).second)
      return Error{where + ": spring " + std::to_string(e) + " repeats the pair " + std::to_string(a) + "-" +
                   std::to_string(b)};
    if (!(net.rest_length[e] >= 0) || !std::isfinite(net.rest_length[e]))
      return Error{where + ": spring " + std::to_string(e) + " has rest length " + fmt_num(net.rest_length[e])};
    if (!(net.stiffness[e] >= 0) || !std::isfinite(net.stiffness[e]) || !(net.damping[e] >= 0) ||
        !std::isfinite(net.damping[e]))
      return Error{where + ": spring " + std::to_string(e) + " needs finite stiffness and damping >= 0"};
  }
  for (int a : net.anchors)
    if (a < 0 || static_cast<size_t>(a) >= n)
      return Error{where + ": anchor " + std::to_string(a) + " is not a vertex (expected 0.." + std::to_string(n - 1) + ")"};
  if (net.rest_volume.size() != net.tets.size())
    return Error{where + ": " + std::to_string(net.rest_volume.size()) + " rest volumes for " +
                 std::to_string(net.tets.size()) + " tetrahedra"};
  if (!(net.volume_modulus >= 0) || !std::isfinite(net.volume_modulus))
    return Error{where + ": the volume modulus must be finite and >= 0"};
  for (size_t t = 0; t < net.tets.size(); ++t) {
    for (int v : net.tets[t])
      if (v < 0 || static_cast<size_t>(v) >= n)
        return Error{where + ": tetrahedron " + std::to_string(t) + " uses vertex " + std::to_string(v)};
    if (!(net.rest_volume[t] > 0) || !std::isfinite(net.rest_volume[t]))
      return Error{where + ": tetrahedron " + std::to_string(t) + " has rest volume " + fmt_num(net.rest_volume[t])};
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) {
        const int i = net.tets[t][static_cast<size_t>(a)], j = net.tets[t][static_cast<size_t>(b)];
        if (i == j || !seen.count(pair_key(std::min(i, j), std::max(i, j))))
          return Error{where + ": tetrahedron " + std::to_string(t) + "'s edge " + std::to_string(i) + "-" +
                       std::to_string(j) + " is not a spring (the volume term's predictor needs it)"};
      }
  }
  for (const auto& t : net.triangles)
    for (int v : t)
      if (v < 0 || static_cast<size_t>(v) >= n)
        return Error{where + ": a drawn triangle uses vertex " + std::to_string(v) + ", expected 0.." + std::to_string(n - 1)};
  return {};
}

std::vector<double> predictor_stiffness(const SpringNetwork& net) {
  std::vector<double> k = net.stiffness;
  if (net.tets.empty() || !(net.volume_modulus > 0)) return k;
  std::unordered_map<std::uint64_t, size_t> index;
  index.reserve(net.springs.size());
  for (size_t e = 0; e < net.springs.size(); ++e) {
    const auto [a, b] = net.springs[e];
    index.emplace(pair_key(std::min(a, b), std::max(a, b)), e);
  }
  for (size_t t = 0; t < net.tets.size(); ++t) {
    const auto& T = net.tets[t];
    const auto g = spring::tet_volume_gradients(net.rest.row(T[0]).transpose(), net.rest.row(T[1]).transpose(),
                                                net.rest.row(T[2]).transpose(), net.rest.row(T[3]).transpose());
    const double w = kVolumePredictorScale * net.volume_modulus / net.rest_volume[t];
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) {
        const int i = T[static_cast<size_t>(a)], j = T[static_cast<size_t>(b)];
        const auto it = index.find(pair_key(std::min(i, j), std::max(i, j)));
        if (it != index.end()) k[it->second] -= w * g[static_cast<size_t>(a)].dot(g[static_cast<size_t>(b)]);
      }
  }
  return k;
}

}  // namespace palpate
