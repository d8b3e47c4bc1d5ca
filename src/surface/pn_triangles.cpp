// pn_triangles.cpp — curved PN triangles (Vlachos et al. 2001) over a triangle mesh with normals.
#include <palpate/mesh.h>
#include <palpate/surface.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <string>
#include <utility>

namespace palpate {
namespace {

constexpr int kMaxLevel = 64;

// Local index of sample (a, b) of a triangle split `level` times: a steps toward the triangle's
// second vertex, b toward its third; rows of constant b hold level − b + 1 samples.
int sample_of(int level, int a, int b) { return b * (level + 1) - b * (b - 1) / 2 + a; }

Vec3f unit_or(const Vec3f& v, const Vec3f& fallback) {
  const float n2 = v.squaredNorm();
  return n2 > 0.0f && std::isfinite(n2) ? Vec3f(v / std::sqrt(n2)) : fallback;
}

// The cubic Bézier triangle and quadratic normal patch of one triangle (Vlachos et al. 2001, §3):
//   b300 = P1, b030 = P2, b003 = P3,  w_ij = (P_j − P_i)·N_i,
//   b210 = (2P1 + P2 − w12 N1)/3 and the five others alike,
//   E = (b210 + b120 + b021 + b012 + b102 + b201)/6, V = (P1 + P2 + P3)/3, b111 = E + (E − V)/2;
//   n200 = N1, n020 = N2, n002 = N3,  v_ij = 2 (P_j − P_i)·(N_i + N_j) / |P_j − P_i|²,
//   n110 = unit(N1 + N2 − v12 (P2 − P1)) and the two others alike.
// b(w1,w2,w3) = Σ b_ijk 3!/(i!j!k!) w1^i w2^j w3^k; n(w1,w2,w3) = Σ n_ijk w1^i w2^j w3^k (then unit).
struct PnPatch {
  Vec3f b300, b030, b003, b210, b120, b021, b012, b102, b201, b111;
  Vec3f n200, n020, n002, n110, n011, n101;
  Vec3f face_normal;
};

Vec3f edge_normal(const Vec3f& pi, const Vec3f& pj, const Vec3f& ni, const Vec3f& nj) {
  const Vec3f e = pj - pi;
  const float e2 = e.squaredNorm();
  const float v = e2 > 0.0f ? 2.0f * e.dot(ni + nj) / e2 : 0.0f;
  return unit_or(ni + nj - v * e, ni);
}

PnPatch make_patch(const Vec3f& p1, const Vec3f& p2, const Vec3f& p3, const Vec3f& raw1, const Vec3f& raw2,
                   const Vec3f& raw3) {
  PnPatch t;
  t.face_normal = unit_or((p2 - p1).cross(p3 - p1), Vec3f::UnitY());
  const Vec3f n1 = unit_or(raw1, t.face_normal), n2 = unit_or(raw2, t.face_normal),
              n3 = unit_or(raw3, t.face_normal);
  auto w = [](const Vec3f& pi, const Vec3f& pj, const Vec3f& ni) { return (pj - pi).dot(ni); };
  t.b300 = p1, t.b030 = p2, t.b003 = p3;
  t.b210 = (2 * p1 + p2 - w(p1, p2, n1) * n1) / 3;
  t.b120 = (2 * p2 + p1 - w(p2, p1, n2) * n2) / 3;
  t.b021 = (2 * p2 + p3 - w(p2, p3, n2) * n2) / 3;
  t.b012 = (2 * p3 + p2 - w(p3, p2, n3) * n3) / 3;
  t.b102 = (2 * p3 + p1 - w(p3, p1, n3) * n3) / 3;
  t.b201 = (2 * p1 + p3 - w(p1, p3, n1) * n1) / 3;
  const Vec3f e = (t.b210 + t.b120 + t.b021 + t.b012 + t.b102 + t.b201) / 6;
  const Vec3f v = (p1 + p2 + p3) / 3;
  t.b111 = e + (e - v) / 2;
  t.n200 = n1, t.n020 = n2, t.n002 = n3;
  t.n110 = edge_normal(p1, p2, n1, n2);
  t.n011 = edge_normal(p2, p3, n2, n3);
  t.n101 = edge_normal(p3, p1, n3, n1);
  return t;
}

std::string level_text(int level) { return std::to_string(level); }

}  // namespace

Result<PnTessellator> PnTessellator::build(int vertex_count, std::span<const std::array<int, 3>> triangles,
                                           int level) {
  if (level < 1 || level > kMaxLevel)
    return Error{"pn_triangles: level " + level_text(level) + " is out of range; expected 1 to " +
                 std::to_string(kMaxLevel) + " (each triangle becomes level² triangles)"};
  if (vertex_count <= 0 || triangles.empty())
    return Error{"pn_triangles: empty mesh (" + std::to_string(vertex_count) + " vertices, " +
                 std::to_string(triangles.size()) + " triangles); expected at least one triangle"};
  for (size_t f = 0; f < triangles.size(); ++f) {
    const auto& t = triangles[f];
    for (int k = 0; k < 3; ++k)
      if (t[k] < 0 || t[k] >= vertex_count)
        return Error{"pn_triangles: triangle " + std::to_string(f) + " refers to vertex " + std::to_string(t[k]) +
                     "; expected 0 to " + std::to_string(vertex_count - 1)};
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2])
      return Error{"pn_triangles: triangle " + std::to_string(f) + " repeats a vertex (" + std::to_string(t[0]) +
                   ", " + std::to_string(t[1]) + ", " + std::to_string(t[2]) + "); expected 3 distinct vertices"};
  }

  PnTessellator pn;
  pn.vertex_count_ = vertex_count;
  pn.level_ = level;
  pn.mesh_triangles_.assign(triangles.begin(), triangles.end());
  const int L = level;
  const int samples = (L + 1) * (L + 2) / 2;
  const int interior = (L - 1) * (L - 2) / 2;

  // Edge ids, for welding the points along shared edges.
  std::map<std::pair<int, int>, int> edge_id;
  for (const auto& t : triangles)
    for (int k = 0; k < 3; ++k) {
      const int x = t[k], y = t[(k + 1) % 3];
      edge_id.emplace(std::minmax(x, y), int(edge_id.size()));
    }
  const size_t edges = edge_id.size();
  const size_t first_interior = size_t(vertex_count) + edges * size_t(L - 1);
  const size_t points = first_interior + triangles.size() * size_t(interior);
  if (points > std::numeric_limits<uint32_t>::max())
    return Error{"pn_triangles: " + std::to_string(points) + " points at level " + level_text(level) +
                 "; expected at most 4294967295 (32-bit indices)"};
  pn.point_count_ = points;

  pn.bary_.resize(samples);
  for (int b = 0; b <= L; ++b)
    for (int a = 0; a <= L - b; ++a)
      pn.bary_[sample_of(L, a, b)] = {float(L - a - b) / float(L), float(a) / float(L), float(b) / float(L)};

  // Output point of each sample: the mesh vertex at corners, a welded edge point on edges.
  pn.sample_index_.resize(triangles.size() * size_t(samples));
  auto on_edge = [&](int x, int y, int steps_from_x) {
    const int id = edge_id.at(std::minmax(x, y));
    const int pos = x < y ? steps_from_x : L - steps_from_x;
    return uint32_t(size_t(vertex_count) + size_t(id) * size_t(L - 1) + size_t(pos - 1));
  };
  for (size_t f = 0; f < triangles.size(); ++f) {
    const auto& t = triangles[f];
    uint32_t next_interior = uint32_t(first_interior + f * size_t(interior));
    for (int b = 0; b <= L; ++b)
      for (int a = 0; a <= L - b; ++a) {
        const int c = L - a - b;
        uint32_t index;
        if (c == L) index = uint32_t(t[0]);
        else if (a == L) index = uint32_t(t[1]);
        else if (b == L) index = uint32_t(t[2]);
        else if (b == 0) index = on_edge(t[0], t[1], a);
        else if (a == 0) index = on_edge(t[0], t[2], b);
        else if (c == 0) index = on_edge(t[1], t[2], b);
        else index = next_interior++;
        pn.sample_index_[f * samples + sample_of(L, a, b)] = index;
      }
  }

  // level² small triangles per triangle, in the input's winding.
  pn.triangles_.reserve(triangles.size() * size_t(L) * L * 3);
  for (size_t f = 0; f < triangles.size(); ++f) {
    const uint32_t* s = &pn.sample_index_[f * samples];
    for (int b = 0; b < L; ++b)
      for (int a = 0; a < L - b; ++a) {
        pn.triangles_.insert(pn.triangles_.end(),
                             {s[sample_of(L, a, b)], s[sample_of(L, a + 1, b)], s[sample_of(L, a, b + 1)]});
        if (a + 1 < L - b)
          pn.triangles_.insert(pn.triangles_.end(), {s[sample_of(L, a + 1, b)], s[sample_of(L, a + 1, b + 1)],
                                                     s[sample_of(L, a, b + 1)]});
      }
  }
  return pn;
}

bool PnTessellator::tessellate(std::span<const Vec3f> positions, std::span<const Vec3f> normals,
                               SurfaceBuffers& out) const {
  if (positions.size() != size_t(vertex_count_) || normals.size() != size_t(vertex_count_)) return false;
  if (out.positions.size() != 3 * point_count_) out.positions.resize(3 * point_count_);
  if (out.normals.size() != 3 * point_count_) out.normals.resize(3 * point_count_);
  if (out.triangles.size() != triangles_.size()) out.triangles = triangles_;
  return tessellate(positions, normals, out.positions, out.normals);
}

bool PnTessellator::tessellate(std::span<const Vec3f> positions, std::span<const Vec3f> normals,
                               std::span<float> out_positions, std::span<float> out_normals) const noexcept {
  if (positions.size() != size_t(vertex_count_) || normals.size() != size_t(vertex_count_) ||
      out_positions.size() != 3 * point_count_ || out_normals.size() != 3 * point_count_)
    return false;
  const size_t samples = bary_.size();
  for (size_t f = 0; f < mesh_triangles_.size(); ++f) {
    const auto& t = mesh_triangles_[f];
    const PnPatch p = make_patch(positions[t[0]], positions[t[1]], positions[t[2]], normals[t[0]], normals[t[1]],
                                 normals[t[2]]);
    const uint32_t* index = &sample_index_[f * samples];
    for (size_t s = 0; s < samples; ++s) {
      const float w1 = bary_[s][0], w2 = bary_[s][1], w3 = bary_[s][2];
      const Vec3f x = p.b300 * (w1 * w1 * w1) + p.b030 * (w2 * w2 * w2) + p.b003 * (w3 * w3 * w3) +
                      p.b210 * (3 * w1 * w1 * w2) + p.b120 * (3 * w1 * w2 * w2) + p.b201 * (3 * w1 * w1 * w3) +
                      p.b021 * (3 * w2 * w2 * w3) + p.b102 * (3 * w1 * w3 * w3) + p.b012 * (3 * w2 * w3 * w3) +
                      p.b111 * (6 * w1 * w2 * w3);
      const Vec3f n = p.n200 * (w1 * w1) + p.n020 * (w2 * w2) + p.n002 * (w3 * w3) + p.n110 * (w1 * w2) +
                      p.n011 * (w2 * w3) + p.n101 * (w1 * w3);
      const Vec3f nu = unit_or(n, p.face_normal);
      float* xo = &out_positions[size_t(index[s]) * 3];
      float* no = &out_normals[size_t(index[s]) * 3];
      xo[0] = x.x(), xo[1] = x.y(), xo[2] = x.z();
      no[0] = nu.x(), no[1] = nu.y(), no[2] = nu.z();
    }
  }
  return true;
}

Result<SurfaceBuffers> pn_triangles(const SurfaceMesh& mesh, int level) {
  const int nv = int(mesh.V.rows());
  std::vector<Vec3f> positions(nv), normals(nv, Vec3f::Zero());
  for (int i = 0; i < nv; ++i) positions[i] = mesh.V.row(i).transpose().cast<float>();
  std::vector<std::array<int, 3>> triangles(mesh.F.rows());
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) triangles[f] = {mesh.F(f, 0), mesh.F(f, 1), mesh.F(f, 2)};
  auto pn = PnTessellator::build(nv, triangles, level);
  if (!pn) return pn.error();
  if (mesh.N.rows() != 0 && mesh.N.rows() != nv)
    return Error{"pn_triangles: mesh has " + std::to_string(mesh.N.rows()) + " normals for " + std::to_string(nv) +
                 " vertices; expected one normal per vertex (or none, to compute them)"};
  if (mesh.N.rows() == nv) {
    for (int i = 0; i < nv; ++i) normals[i] = mesh.N.row(i).transpose().cast<float>();
  } else {  // no normals given: area-weighted face normals (the cross product's length is 2·area)
    for (const auto& t : triangles) {
      const Vec3f n = (positions[t[1]] - positions[t[0]]).cross(positions[t[2]] - positions[t[0]]);
      for (int k = 0; k < 3; ++k) normals[t[k]] += n;
    }
  }
  SurfaceBuffers out;
  if (!pn->tessellate(positions, normals, out)) return Error{"pn_triangles: tessellation failed"};
  return out;
}

}  // namespace palpate
