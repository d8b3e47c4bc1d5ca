// mesh.cpp — geometry of meshes held in memory: normals, tetrahedral boundary, statistics, format test.
#include <palpate/mesh.h>

#include "core/mesh_topology.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <tuple>

namespace palpate {

namespace {

template <class Elements>
bool indices_in_range(const Elements& E, Eigen::Index num_vertices) {
  return E.size() == 0 || (E.minCoeff() >= 0 && E.maxCoeff() < num_vertices);
}

// Statistics of the unique edges among `pairs` (each (lo, hi), lo < hi, duplicates allowed).
EdgeStats edge_stats(const RowMat3d& V, std::vector<std::pair<int, int>>& pairs) {
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  EdgeStats s;
  s.count = pairs.size();
  if (pairs.empty()) return s;
  std::vector<double> len(pairs.size());
  double sum = 0;
  for (size_t i = 0; i < pairs.size(); ++i) {
    len[i] = (V.row(pairs[i].first) - V.row(pairs[i].second)).norm();
    sum += len[i];
  }
  const auto [lo, hi] = std::minmax_element(len.begin(), len.end());
  s.min = *lo;
  s.max = *hi;
  s.mean = sum / static_cast<double>(len.size());
  const size_t mid = len.size() / 2;
  std::nth_element(len.begin(), len.begin() + static_cast<std::ptrdiff_t>(mid), len.end());
  s.median = len[mid];
  if (len.size() % 2 == 0)  // even count: mean of the two middle values
    s.median = 0.5 * (s.median + *std::max_element(len.begin(), len.begin() + static_cast<std::ptrdiff_t>(mid)));
  return s;
}

void fill_bbox(const RowMat3d& V, MeshInfo& info) {
  if (V.rows() == 0) return;
  info.bbox_min = V.colwise().minCoeff().transpose();
  info.bbox_max = V.colwise().maxCoeff().transpose();
}

void fill_surface_topology(const SurfaceMesh& m, MeshInfo& info) {
  const topology::EdgeCounts c = topology::count_edges(topology::sorted_half_edges(m.F));
  info.boundary_edges = c.boundary;
  info.non_manifold_edges = c.non_manifold;
  info.manifold = m.F.rows() > 0 && c.non_manifold == 0;
  info.closed = m.F.rows() > 0 && c.boundary == 0 && c.over_two == 0;
}

}  // namespace

void compute_normals(SurfaceMesh& m) {
  m.N = RowMat3d::Zero(m.V.rows(), 3);
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    const Eigen::RowVector3i t = m.F.row(f);
    if (t.minCoeff() < 0 || t.maxCoeff() >= m.V.rows()) continue;  // validate() reports these
    // The cross product's length is twice the triangle's area: summing it weights by area.
    const Vec3 a = m.V.row(t(0)), b = m.V.row(t(1)), c = m.V.row(t(2));
    const Vec3 n = (b - a).cross(c - a);
    for (int k = 0; k < 3; ++k) m.N.row(t(k)) += n.transpose();
  }
  for (Eigen::Index v = 0; v < m.N.rows(); ++v) {
    const double len = m.N.row(v).norm();
    if (len > 0) m.N.row(v) /= len;  // a vertex no triangle uses keeps a zero normal
  }
}

SurfaceMesh boundary_surface(const TetMesh& m) {
  SurfaceMesh s;
  s.V = m.V;
  if (!indices_in_range(m.T, m.V.rows())) {
    s.N = RowMat3d::Zero(s.V.rows(), 3);
    return s;
  }
  // The faces of a positively oriented tetrahedron (0, 1, 2, 3), each counter-clockwise seen
  // from outside: the face opposite vertex k, as an odd permutation of (0, 1, 2, 3) with k last.
  static constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  struct Face {
    std::array<int, 3> key;  // sorted vertex indices
    std::array<int, 3> v;    // outward-oriented vertices
    size_t order;            // tetrahedron * 4 + face, to keep the output in mesh order
  };
  std::vector<Face> faces;
  faces.reserve(static_cast<size_t>(m.T.rows()) * 4);
  for (Eigen::Index t = 0; t < m.T.rows(); ++t) {
    const bool inverted = topology::tet_volume(m, t) < 0;
    for (int k = 0; k < 4; ++k) {
      Face f;
      for (int j = 0; j < 3; ++j) f.v[j] = m.T(t, kFace[k][j]);
      if (inverted) std::swap(f.v[1], f.v[2]);
      f.key = f.v;
      std::sort(f.key.begin(), f.key.end());
      f.order = static_cast<size_t>(t) * 4 + static_cast<size_t>(k);
      faces.push_back(f);
    }
  }
  std::sort(faces.begin(), faces.end(),
            [](const Face& a, const Face& b) { return std::tie(a.key, a.order) < std::tie(b.key, b.order); });
  std::vector<const Face*> once;
  for (size_t i = 0; i < faces.size();) {
    size_t j = i + 1;
    while (j < faces.size() && faces[j].key == faces[i].key) ++j;
    if (j - i == 1) once.push_back(&faces[i]);
    i = j;
  }
  std::sort(once.begin(), once.end(), [](const Face* a, const Face* b) { return a->order < b->order; });
  s.F.resize(static_cast<Eigen::Index>(once.size()), 3);
  for (size_t i = 0; i < once.size(); ++i)
    for (int j = 0; j < 3; ++j) s.F(static_cast<Eigen::Index>(i), j) = once[i]->v[j];
  compute_normals(s);
  return s;
}

MeshInfo describe(const SurfaceMesh& m) {
  MeshInfo info;
  info.kind = "surface";
  info.vertices = static_cast<size_t>(m.V.rows());
  info.triangles = static_cast<size_t>(m.F.rows());
  fill_bbox(m.V, info);
  if (!indices_in_range(m.F, m.V.rows())) return info;  // validate() names the bad element
  fill_surface_topology(m, info);
  if (info.closed) info.volume = topology::enclosed_volume(m);
  std::vector<std::pair<int, int>> pairs;
  pairs.reserve(static_cast<size_t>(m.F.rows()) * 3);
  for (Eigen::Index f = 0; f < m.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = m.F(f, k), b = m.F(f, (k + 1) % 3);
      pairs.emplace_back(std::min(a, b), std::max(a, b));
    }
  info.edges = edge_stats(m.V, pairs);
  return info;
}

MeshInfo describe(const TetMesh& m) {
  MeshInfo info;
  info.kind = "tetrahedral";
  info.vertices = static_cast<size_t>(m.V.rows());
  info.tetrahedra = static_cast<size_t>(m.T.rows());
  fill_bbox(m.V, info);
  if (!indices_in_range(m.T, m.V.rows())) return info;
  const SurfaceMesh boundary = boundary_surface(m);
  info.triangles = static_cast<size_t>(boundary.F.rows());
  fill_surface_topology(boundary, info);
  std::vector<std::pair<int, int>> pairs;
  pairs.reserve(static_cast<size_t>(m.T.rows()) * 6);
  for (Eigen::Index t = 0; t < m.T.rows(); ++t) {
    info.volume += topology::tet_volume(m, t);
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j)
        pairs.emplace_back(std::min(m.T(t, i), m.T(t, j)), std::max(m.T(t, i), m.T(t, j)));
  }
  info.edges = edge_stats(m.V, pairs);
  return info;
}

bool is_tet_file(const std::filesystem::path& file) {
  std::string ext = file.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".msh" || ext == ".node" || ext == ".ele" || ext == ".vtk";
}

}  // namespace palpate
