// test_surface_pn.cpp — properties of PN triangles (Vlachos et al. 2001) over triangle meshes.
#include <palpate/mesh.h>
#include <palpate/surface.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <vector>

using palpate::PnTessellator;
using palpate::SurfaceBuffers;
using palpate::Vec3f;

namespace {

using Tri = std::array<int, 3>;

Vec3f point(const SurfaceBuffers& b, size_t i) { return {b.positions[3 * i], b.positions[3 * i + 1], b.positions[3 * i + 2]}; }
Vec3f normal(const SurfaceBuffers& b, size_t i) { return {b.normals[3 * i], b.normals[3 * i + 1], b.normals[3 * i + 2]}; }

// A regular octahedron on the unit sphere, outward counter-clockwise triangles.
void octahedron(std::vector<Vec3f>& v, std::vector<Tri>& f) {
  v = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  f = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
}

// A jittered triangulated grid on a tilted plane.
void planar_mesh(int n, const Vec3f& e1, const Vec3f& e2, std::vector<Vec3f>& v, std::vector<Tri>& f) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> jitter(-0.25f, 0.25f);
  v.clear();
  f.clear();
  for (int r = 0; r <= n; ++r)
    for (int c = 0; c <= n; ++c) v.push_back((c + jitter(rng)) * e1 + (r + jitter(rng)) * e2);
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) {
      const int a = r * (n + 1) + c, b = a + 1, d = a + n + 1, e = d + 1;
      f.push_back({a, b, e});
      f.push_back({a, e, d});
    }
}

PnTessellator make(int nv, const std::vector<Tri>& f, int level) {
  auto t = PnTessellator::build(nv, f, level);
  EXPECT_TRUE(t.ok()) << (t.ok() ? "" : t.error().message);
  return std::move(t).value();
}

}  // namespace

TEST(SurfacePn, FlatInputStaysFlat) {
  const Vec3f e1 = Vec3f(1, 0.3f, 0).normalized() * 0.002f, e2 = Vec3f(0, 0.2f, -1).normalized() * 0.002f;
  const Vec3f plane_normal = e1.cross(e2).normalized();
  std::vector<Vec3f> v;
  std::vector<Tri> f;
  planar_mesh(5, e1, e2, v, f);
  const std::vector<Vec3f> normals(v.size(), plane_normal);
  const auto pn = make(int(v.size()), f, 4);
  SurfaceBuffers out;
  ASSERT_TRUE(pn.tessellate(v, normals, out));
  for (size_t i = 0; i < out.point_count(); ++i) {
    EXPECT_NEAR(plane_normal.dot(point(out, i)), 0.0f, 1e-8f) << i;
    EXPECT_GT(normal(out, i).dot(plane_normal), 1.0f - 1e-6f) << i;
  }
  // Flat triangles are reproduced exactly: the centre sample of a level-3 triangle is its centroid.
  const auto pn3 = make(int(v.size()), f, 3);
  SurfaceBuffers out3;
  ASSERT_TRUE(pn3.tessellate(v, normals, out3));
  const size_t first_interior = v.size() + [&] {
    std::map<std::pair<int, int>, int> edges;
    for (const auto& t : f)
      for (int k = 0; k < 3; ++k) edges[std::minmax(t[k], t[(k + 1) % 3])] = 1;
    return edges.size() * 2;
  }();
  for (size_t t = 0; t < f.size(); ++t) {
    const Vec3f centroid = (v[f[t][0]] + v[f[t][1]] + v[f[t][2]]) / 3;
    EXPECT_LT((point(out3, first_interior + t) - centroid).norm(), 1e-8f) << t;
  }
}

TEST(SurfacePn, InterpolatesVerticesAndTheirNormals) {
  std::vector<Vec3f> v;
  std::vector<Tri> f;
  octahedron(v, f);
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> d(-0.2f, 0.2f);
  for (auto& p : v) p += Vec3f(d(rng), d(rng), d(rng));
  std::vector<Vec3f> normals;
  for (const auto& p : v) normals.push_back(p.normalized());
  const auto pn = make(int(v.size()), f, 5);
  SurfaceBuffers out;
  ASSERT_TRUE(pn.tessellate(v, normals, out));
  for (size_t i = 0; i < v.size(); ++i) {
    EXPECT_LT((point(out, i) - v[i]).norm(), 1e-6f) << i;
    EXPECT_GT(normal(out, i).dot(normals[i]), 1.0f - 1e-6f) << i;
  }
}

TEST(SurfacePn, CurvesTowardsTheSphereTheNormalsDescribe) {
  // Octahedron vertices on the unit sphere with radial normals. By hand from Vlachos et al.'s
  // formulas, face (x, y, z): w_ij = −1, b210 = (1, 1/3, 0) and its permutations, E = (4/9)·1,
  // V = (1/3)·1, b111 = (1/2)·1, so the face centre is (P1+P2+P3 + 3·6E + 6·b111)/27 = (4/9)·1.
  std::vector<Vec3f> v;
  std::vector<Tri> f;
  octahedron(v, f);
  const auto pn = make(int(v.size()), f, 3);  // level 3: each face's one interior point is its centre
  SurfaceBuffers out;
  ASSERT_TRUE(pn.tessellate(v, v, out));
  const size_t first_interior = 6 + 12 * 2;
  for (size_t t = 0; t < f.size(); ++t) {
    const Vec3f sign = v[f[t][0]] + v[f[t][1]] + v[f[t][2]];  // (±1, ±1, ±1)
    EXPECT_LT((point(out, first_interior + t) - sign * (4.0f / 9.0f)).norm(), 1e-6f) << t;
    EXPECT_GT(normal(out, first_interior + t).dot(sign.normalized()), 1.0f - 1e-6f) << t;
  }
  // At a finer level every point bulges outwards from the flat face, towards the sphere.
  const auto fine = make(int(v.size()), f, 8);
  SurfaceBuffers out8;
  ASSERT_TRUE(fine.tessellate(v, v, out8));
  for (size_t i = 0; i < out8.point_count(); ++i) {
    const Vec3f p = point(out8, i);
    EXPECT_GE(std::abs(p.x()) + std::abs(p.y()) + std::abs(p.z()), 1.0f - 1e-6f) << i;  // face: |x|+|y|+|z| = 1
    EXPECT_LE(p.norm(), 1.0f + 1e-6f) << i;
  }
  // Output triangles face the way their vertex normals point.
  for (size_t t = 0; t < out8.triangle_count(); ++t) {
    const auto* tri = &out8.triangles[3 * t];
    const Vec3f n = (point(out8, tri[1]) - point(out8, tri[0])).cross(point(out8, tri[2]) - point(out8, tri[0]));
    EXPECT_GT(n.dot(normal(out8, tri[0]) + normal(out8, tri[1]) + normal(out8, tri[2])), 0.0f) << t;
  }
}

TEST(SurfacePn, OutputOfAClosedMeshIsClosedAndWelded) {
  std::vector<Vec3f> v;
  std::vector<Tri> f;
  octahedron(v, f);
  const int level = 6;
  const auto pn = make(int(v.size()), f, level);
  // Points: one per vertex, level-1 per edge (12 edges), (level-1)(level-2)/2 per face.
  EXPECT_EQ(pn.point_count(), 6u + 12u * 5u + 8u * 10u);
  EXPECT_EQ(pn.triangle_count(), 8u * level * level);
  // Every directed edge appears once and its reverse once: closed, consistently oriented.
  std::map<std::pair<uint32_t, uint32_t>, int> directed;
  const auto tris = pn.triangles();
  for (size_t t = 0; t < pn.triangle_count(); ++t)
    for (int k = 0; k < 3; ++k) ++directed[{tris[3 * t + k], tris[3 * t + (k + 1) % 3]}];
  for (const auto& [e, count] : directed) {
    EXPECT_EQ(count, 1);
    EXPECT_EQ(directed.count({e.second, e.first}), 1u) << e.first << "-" << e.second;
  }
  // Every point is used.
  std::vector<int> used(pn.point_count(), 0);
  for (uint32_t i : tris) used.at(i) = 1;
  EXPECT_EQ(std::count(used.begin(), used.end(), 1), long(pn.point_count()));
}

TEST(SurfacePn, LevelOneReproducesTheInputMesh) {
  std::vector<Vec3f> v;
  std::vector<Tri> f;
  octahedron(v, f);
  const auto pn = make(int(v.size()), f, 1);
  ASSERT_EQ(pn.point_count(), v.size());
  SurfaceBuffers out;
  ASSERT_TRUE(pn.tessellate(v, v, out));
  for (size_t t = 0; t < f.size(); ++t)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(out.triangles[3 * t + k], uint32_t(f[t][k]));
  for (size_t i = 0; i < v.size(); ++i) EXPECT_EQ(point(out, i), v[i]);
}

TEST(SurfacePn, FromASurfaceMeshComputesMissingNormals) {
  palpate::SurfaceMesh m;
  m.V.resize(4, 3);
  m.V << 0, 0, 0, 1, 0, 0, 1, 0, -1, 0, 0, -1;  // a flat square in the y = 0 plane
  m.F.resize(2, 3);
  m.F << 0, 1, 2, 0, 2, 3;  // counter-clockwise seen from +y
  auto out = palpate::pn_triangles(m, 3);
  ASSERT_TRUE(out.ok()) << out.error().message;
  for (size_t i = 0; i < out->point_count(); ++i) {
    EXPECT_NEAR(point(*out, i).y(), 0.0f, 1e-7f);
    EXPECT_GT(normal(*out, i).y(), 1.0f - 1e-6f);
  }
  m.N.resize(3, 3);
  auto bad = palpate::pn_triangles(m, 3);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().message,
            "pn_triangles: mesh has 3 normals for 4 vertices; expected one normal per vertex (or none, to compute them)");
}

TEST(SurfacePn, RejectsBadMeshesWithClearErrors) {
  const std::vector<Tri> f = {{0, 1, 2}, {0, 2, 7}};
  auto a = PnTessellator::build(4, f, 3);
  ASSERT_FALSE(a.ok());
  EXPECT_EQ(a.error().message, "pn_triangles: triangle 1 refers to vertex 7; expected 0 to 3");
  auto b = PnTessellator::build(4, std::vector<Tri>{{0, 1, 1}}, 3);
  ASSERT_FALSE(b.ok());
  EXPECT_EQ(b.error().message, "pn_triangles: triangle 0 repeats a vertex (0, 1, 1); expected 3 distinct vertices");
  auto c = PnTessellator::build(4, std::vector<Tri>{{0, 1, 2}}, 0);
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.error().message,
            "pn_triangles: level 0 is out of range; expected 1 to 64 (each triangle becomes level² triangles)");
  auto d = PnTessellator::build(0, {}, 2);
  ASSERT_FALSE(d.ok());
  EXPECT_EQ(d.error().message, "pn_triangles: empty mesh (0 vertices, 0 triangles); expected at least one triangle");
  // Mismatched inputs per frame are refused, not read out of bounds.
  const auto pn = make(4, {{0, 1, 2}}, 2);
  std::vector<Vec3f> v(3, Vec3f::Zero());
  SurfaceBuffers out;
  EXPECT_FALSE(pn.tessellate(v, v, out));
}
