// shapes.cpp — meshes made in code: tetrahedralised block, flat sheet, tet-mesh boundary, balls.
#include "tissue/spring/shapes.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>

namespace palpate::spring {

namespace {

double signed_volume6(const RowMat3d& V, int a, int b, int c, int d) {
  const Vec3 pa = V.row(a).transpose();
  return (V.row(b).transpose() - pa).dot((V.row(c).transpose() - pa).cross(V.row(d).transpose() - pa));
}

}  // namespace

TetMesh make_block(int nx, int ny, int nz, double spacing, const Vec3& origin) {
  std::vector<double> xs(static_cast<size_t>(std::max(nx, 0))), ys(static_cast<size_t>(std::max(ny, 0))),
      zs(static_cast<size_t>(std::max(nz, 0)));
  for (int i = 0; i < nx; ++i) xs[static_cast<size_t>(i)] = origin.x() + spacing * i;
  for (int j = 0; j < ny; ++j) ys[static_cast<size_t>(j)] = origin.y() + spacing * j;
  for (int k = 0; k < nz; ++k) zs[static_cast<size_t>(k)] = origin.z() + spacing * k;
  return make_block(xs, ys, zs);
}

std::vector<double> graded_coordinates(double from, double to, double fine_from, double fine_to, double fine,
                                       double coarse, double ratio) {
  std::vector<double> mid;
  const int cells = std::max(1, static_cast<int>(std::lround((fine_to - fine_from) / fine)));
  for (int i = 0; i <= cells; ++i) mid.push_back(fine_from + (fine_to - fine_from) * i / cells);
  // One graded side: offsets from the fine region's edge out to `length`, stretched to end on it.
  const auto side = [&](double length) {
    std::vector<double> at;
    double p = 0, size = fine;
    while (length > 0 && p < length - 0.5 * std::min(coarse, size * ratio)) {
      size = std::min(coarse, size * ratio);
      p += size;
      at.push_back(p);
    }
    if (at.empty() && length > 0) at.push_back(length);
    for (double& a : at) a *= length / at.back();
    return at;
  };
  std::vector<double> out;
  const auto low = side(fine_from - from);
  for (auto it = low.rbegin(); it != low.rend(); ++it) out.push_back(fine_from - *it);
  out.insert(out.end(), mid.begin(), mid.end());
  for (double a : side(to - fine_to)) out.push_back(fine_to + a);
  return out;
}

TetMesh make_block(const std::vector<double>& xs, const std::vector<double>& ys, const std::vector<double>& zs) {
  const int nx = static_cast<int>(xs.size()), ny = static_cast<int>(ys.size()), nz = static_cast<int>(zs.size());
  TetMesh m;
  m.V.resize(static_cast<Eigen::Index>(nx) * ny * nz, 3);
  auto id = [&](int i, int j, int k) { return i + nx * (j + ny * k); };
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i)
        m.V.row(id(i, j, k)) =
            Vec3(xs[static_cast<size_t>(i)], ys[static_cast<size_t>(j)], zs[static_cast<size_t>(k)]).transpose();
  // Five-tet split of a cube: corners c[b] with b = x + 2y + 4z. Even cubes keep the tet
  // {1,2,4,7} in the middle, odd cubes {0,3,5,6}: shared faces then get the same diagonal.
  static constexpr int kEven[5][4] = {{1, 2, 4, 7}, {0, 1, 2, 4}, {3, 1, 2, 7}, {5, 1, 4, 7}, {6, 2, 4, 7}};
  static constexpr int kOdd[5][4] = {{0, 3, 5, 6}, {1, 0, 3, 5}, {2, 0, 3, 6}, {4, 0, 5, 6}, {7, 3, 5, 6}};
  std::vector<std::array<int, 4>> tets;
  tets.reserve(static_cast<size_t>(std::max(0, (nx - 1) * (ny - 1) * (nz - 1))) * 5);
  for (int k = 0; k + 1 < nz; ++k)
    for (int j = 0; j + 1 < ny; ++j)
      for (int i = 0; i + 1 < nx; ++i) {
        int c[8];
        for (int b = 0; b < 8; ++b) c[b] = id(i + (b & 1), j + ((b >> 1) & 1), k + ((b >> 2) & 1));
        const auto& split = ((i + j + k) % 2 == 0) ? kEven : kOdd;
        for (const auto& t : split) {
          std::array<int, 4> tet{c[t[0]], c[t[1]], c[t[2]], c[t[3]]};
          if (signed_volume6(m.V, tet[0], tet[1], tet[2], tet[3]) < 0) std::swap(tet[2], tet[3]);
          tets.push_back(tet);
        }
      }
  m.T.resize(static_cast<Eigen::Index>(tets.size()), 4);
  for (size_t t = 0; t < tets.size(); ++t)
    for (int c = 0; c < 4; ++c) m.T(static_cast<Eigen::Index>(t), c) = tets[t][static_cast<size_t>(c)];
  return m;
}

namespace {

// The tets of `block` whose centroid `inside(centroid, context)` accepts, vertices renumbered
// compactly in order of first use.
TetMesh keep_tets(const TetMesh& block, bool (*inside)(const Vec3&, const void*), const void* context) {
  std::vector<int> renumber(static_cast<size_t>(block.V.rows()), -1);
  std::vector<std::array<int, 4>> kept;
  for (Eigen::Index t = 0; t < block.T.rows(); ++t) {
    Vec3 c = Vec3::Zero();
    for (int k = 0; k < 4; ++k) c += block.V.row(block.T(t, k)).transpose();
    if (!inside(c / 4, context)) continue;
    kept.push_back({block.T(t, 0), block.T(t, 1), block.T(t, 2), block.T(t, 3)});
  }
  int count = 0;
  for (auto& t : kept)
    for (int& v : t) {
      int& r = renumber[static_cast<size_t>(v)];
      if (r < 0) r = count++;
      v = r;
    }
  TetMesh m;
  m.V.resize(count, 3);
  for (Eigen::Index v = 0; v < block.V.rows(); ++v)
    if (renumber[static_cast<size_t>(v)] >= 0) m.V.row(renumber[static_cast<size_t>(v)]) = block.V.row(v);
  m.T.resize(static_cast<Eigen::Index>(kept.size()), 4);
  for (size_t t = 0; t < kept.size(); ++t)
    for (int k = 0; k < 4; ++k) m.T(static_cast<Eigen::Index>(t), k) = kept[t][static_cast<size_t>(k)];
  return m;
}

}  // namespace

TetMesh tet_region(const Vec3& lo, const Vec3& hi, double spacing, bool (*inside)(const Vec3&, const void*),
                   const void* context) {
  // Grid lines on the multiples of spacing (a vertex layer on y = 0, and so on), covering [lo, hi].
  const Vec3 first = (lo / spacing).array().floor().matrix() * spacing;
  const int nx = static_cast<int>(std::ceil((hi.x() - first.x()) / spacing - 1e-9)) + 1;
  const int ny = static_cast<int>(std::ceil((hi.y() - first.y()) / spacing - 1e-9)) + 1;
  const int nz = static_cast<int>(std::ceil((hi.z() - first.z()) / spacing - 1e-9)) + 1;
  return keep_tets(make_block(nx, ny, nz, spacing, first), inside, context);
}

TetMesh make_tet_ball(double radius, double spacing) {
  const int n = static_cast<int>(std::ceil(2 * radius / spacing)) + 1;
  const Vec3 origin = Vec3::Constant(-0.5 * spacing * (n - 1));
  return keep_tets(make_block(n, n, n, spacing, origin),
                   [](const Vec3& c, const void* r) { return c.norm() <= *static_cast<const double*>(r); }, &radius);
}

namespace {

// The gallbladder's figures (docs/models/cutting.md, "The gallbladder scene").
constexpr double kGbLength = 0.080;    // m, neck to fundus (fasting: 7–10 cm)
constexpr double kGbBreadth = 0.030;   // m, at the fundus (3–4 cm; the neck narrower)
constexpr double kGbDepth = 0.027;     // m (2.4–3.1 cm)
constexpr double kGbSunk = 0.00675;    // m of its depth in the fossa (a quarter)
constexpr double kNeckRatio = 0.6;     // the neck's breadth and depth over the fundus's (pear)
constexpr double kLiverThickness = 0.020;
constexpr double kLiverEdge = 0.028;   // m, x of the liver's inferior border (the fundus passes it)
constexpr double kLiverBack = -0.060;  // m, x where the slab ends behind the neck
constexpr double kLiverHalfWidth = 0.035;

constexpr double kGbAxisY = kGbSunk - 0.5 * kGbDepth;  // its axis: a quarter of its depth above y = 0

bool in_liver(const Vec3& p) {
  return p.y() >= 0 && p.y() <= kLiverThickness && p.x() >= kLiverBack && p.x() <= kLiverEdge &&
         std::abs(p.z()) <= kLiverHalfWidth;
}

// The pear: an ellipsoid along x whose cross-section narrows linearly from the fundus to the neck.
// 1 on its surface, less inside.
double pear(const Vec3& p) {
  const double a = 0.5 * kGbLength;
  const double u = std::clamp((p.x() + a) / kGbLength, 0.0, 1.0);  // 0 at the neck, 1 at the fundus
  const double scale = kNeckRatio + (1 - kNeckRatio) * u;
  const double b = 0.5 * kGbDepth * scale, c = 0.5 * kGbBreadth * scale;
  const double gx = p.x() / a, gy = (p.y() - kGbAxisY) / b, gz = p.z() / c;
  return gx * gx + gy * gy + gz * gz;
}

bool in_gallbladder_bed(const Vec3& p, const void*) { return in_liver(p) || pear(p) <= 1.0; }

double tet_volume6(const RowMat3d& V, const std::array<int, 4>& t) {
  const Vec3 a = V.row(t[0]).transpose();
  return (V.row(t[1]).transpose() - a).dot((V.row(t[2]).transpose() - a).cross(V.row(t[3]).transpose() - a));
}

// The grid's staircase where the gallbladder's own surface is (not the liver's faces nor the bed)
// moved onto the pear, by at most half a cell, so it is drawn as the organ and not as voxels; a
// move that would flatten a tetrahedron below a fifth of its volume is undone.
void snap_to_pear(TetMesh& m, double spacing) {
  const Eigen::Index n = m.V.rows();
  std::vector<char> outside(static_cast<size_t>(n), 0);
  for (const auto& f : boundary_triangles(m))
    for (int v : f) outside[static_cast<size_t>(v)] = 1;
  const RowMat3d before = m.V;
  const Vec3 centre(0, kGbAxisY, 0);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Vec3 p = m.V.row(i).transpose();
    if (!outside[static_cast<size_t>(i)] || in_liver(p) || std::abs(p.y()) < 1e-9) continue;
    Vec3 q = p;
    for (int k = 0; k < 4; ++k) q = centre + (q - centre) / std::sqrt(std::max(pear(q), 1e-12));  // radial scaling
    const Vec3 d = q - p;
    const double cap = 0.5 * spacing;
    m.V.row(i) = (p + (d.norm() > cap ? Vec3(d * (cap / d.norm())) : d)).transpose();
  }
  std::vector<std::array<int, 4>> tets(static_cast<size_t>(m.T.rows()));
  for (Eigen::Index t = 0; t < m.T.rows(); ++t) tets[static_cast<size_t>(t)] = {m.T(t, 0), m.T(t, 1), m.T(t, 2), m.T(t, 3)};
  for (bool undone = true; undone;) {
    undone = false;
    for (const auto& t : tets) {
      const double v0 = tet_volume6(before, t), v1 = tet_volume6(m.V, t);
      if (v1 / v0 >= 0.2) continue;
      for (int v : t)
        if (m.V.row(v) != before.row(v)) m.V.row(v) = before.row(v), undone = true;
    }
  }
}

}  // namespace

GallbladderBed make_gallbladder_bed(double spacing, const Vec3& offset) {
  const Vec3 lo(kLiverBack, -kGbDepth, -kLiverHalfWidth), hi(0.5 * kGbLength, kLiverThickness, kLiverHalfWidth);
  GallbladderBed bed;
  bed.mesh = tet_region(lo, hi, spacing, in_gallbladder_bed, nullptr);
  snap_to_pear(bed.mesh, spacing);
  const double top = bed.mesh.V.rows() > 0 ? bed.mesh.V.col(1).maxCoeff() : 0.0;
  for (Eigen::Index i = 0; i < bed.mesh.V.rows(); ++i)
    if (bed.mesh.V(i, 1) > top - 1e-9) bed.held.push_back(static_cast<int>(i));
  bed.mesh.V.rowwise() += offset.transpose();
  return bed;
}

SurfaceMesh make_sheet(const PatchDef& patch) {
  const int nu = std::max(2, static_cast<int>(std::lround(patch.width / patch.spacing)) + 1);
  const int nv = std::max(2, static_cast<int>(std::lround(patch.height / patch.spacing)) + 1);
  Vec3 normal = patch.normal.norm() > 0 ? patch.normal.normalized() : Vec3(0, 1, 0);
  // u along x projected onto the plane (or z when the normal is along x).
  Vec3 u = Vec3::UnitX() - normal * normal.x();
  if (u.norm() < 1e-6) u = Vec3::UnitZ() - normal * normal.z();
  u.normalize();
  const Vec3 v = normal.cross(u);
  SurfaceMesh m;
  m.V.resize(static_cast<Eigen::Index>(nu) * nv, 3);
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const double a = -0.5 * patch.width + patch.width * i / (nu - 1);
      const double b = -0.5 * patch.height + patch.height * j / (nv - 1);
      m.V.row(i + nu * j) = (patch.center + a * u + b * v).transpose();
    }
  m.F.resize(2 * static_cast<Eigen::Index>(nu - 1) * (nv - 1), 3);
  Eigen::Index f = 0;
  for (int j = 0; j + 1 < nv; ++j)
    for (int i = 0; i + 1 < nu; ++i) {
      const int a = i + nu * j, b = a + 1, c = a + nu, d = c + 1;
      // (u, v, normal) is right-handed: counter-clockwise in (u, v) faces along the normal.
      m.F.row(f++) << a, b, d;
      m.F.row(f++) << a, d, c;
    }
  m.N = RowMat3d::Zero(m.V.rows(), 3);
  for (Eigen::Index r = 0; r < m.N.rows(); ++r) m.N.row(r) = normal.transpose();
  return m;
}

std::vector<std::array<int, 3>> boundary_triangles(const TetMesh& mesh) {
  // A face of one tet only is on the boundary. Faces listed outward for a positive tet.
  std::map<std::array<int, 3>, std::pair<std::array<int, 3>, int>> faces;
  static constexpr int kFaces[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  for (Eigen::Index t = 0; t < mesh.T.rows(); ++t)
    for (const auto& f : kFaces) {
      std::array<int, 3> tri{mesh.T(t, f[0]), mesh.T(t, f[1]), mesh.T(t, f[2])};
      std::array<int, 3> key = tri;
      std::sort(key.begin(), key.end());
      auto [it, inserted] = faces.try_emplace(key, tri, 0);
      ++it->second.second;
      (void)inserted;
    }
  std::vector<std::array<int, 3>> out;
  for (const auto& [key, face] : faces)
    if (face.second == 1) out.push_back(face.first);
  return out;
}

SurfaceMesh make_ball_surface(int vertices, double radius) {
  const int rings = std::max(2, static_cast<int>(std::lround(std::sqrt(vertices / 2.0))));
  const int segs = std::max(3, (vertices - 2) / rings);
  SurfaceMesh m;
  m.V.resize(static_cast<Eigen::Index>(rings) * segs + 2, 3);
  m.V.row(0) << 0, radius, 0;
  for (int r = 0; r < rings; ++r) {
    const double theta = std::numbers::pi * (r + 1) / (rings + 1);
    for (int s = 0; s < segs; ++s) {
      const double phi = 2 * std::numbers::pi * s / segs;
      m.V.row(1 + r * segs + s) << radius * std::sin(theta) * std::cos(phi), radius * std::cos(theta),
          radius * std::sin(theta) * std::sin(phi);
    }
  }
  const int south = rings * segs + 1;
  m.V.row(south) << 0, -radius, 0;
  std::vector<std::array<int, 3>> tris;
  auto at = [&](int r, int s) { return 1 + r * segs + (s % segs); };
  for (int s = 0; s < segs; ++s) tris.push_back({0, at(0, s + 1), at(0, s)});
  for (int r = 0; r + 1 < rings; ++r)
    for (int s = 0; s < segs; ++s) {
      tris.push_back({at(r, s), at(r, s + 1), at(r + 1, s + 1)});
      tris.push_back({at(r, s), at(r + 1, s + 1), at(r + 1, s)});
    }
  for (int s = 0; s < segs; ++s) tris.push_back({south, at(rings - 1, s), at(rings - 1, s + 1)});
  m.F.resize(static_cast<Eigen::Index>(tris.size()), 3);
  for (size_t f = 0; f < tris.size(); ++f)
    m.F.row(static_cast<Eigen::Index>(f)) << tris[f][0], tris[f][1], tris[f][2];
  m.N = m.V / radius;
  return m;
}

}  // namespace palpate::spring
