// test_charged_mesh.cpp — charged-particle patches laid on surface meshes (CGAL isotropic remeshing).
#include <palpate/charged.h>
#include <palpate/mesh_load.h>
#include <palpate/tissue_files.h>

#include "components.h"
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <set>

using namespace palpate;

namespace {

// Closest point on triangle abc to p (Ericson, Real-Time Collision Detection §5.1.5).
Vec3 closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + ab * (d1 / (d1 - d3));
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const double denom = 1 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

double distance_to_surface(const SurfaceMesh& m, const Vec3& p) {
  double best = 1e300;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    const Vec3 q = closest_on_triangle(p, m.V.row(m.F(f, 0)), m.V.row(m.F(f, 1)), m.V.row(m.F(f, 2)));
    best = std::min(best, (q - p).squaredNorm());
  }
  return std::sqrt(best);
}

// Subdivided icosahedron projected on a sphere: closed, counter-clockwise from outside.
SurfaceMesh icosphere(double radius, int levels) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  std::vector<Vec3> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                         {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  std::vector<std::array<int, 3>> f = {{0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11}, {1, 5, 9},
                                       {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8}, {3, 9, 4}, {3, 4, 2},
                                       {3, 2, 6}, {3, 6, 8}, {3, 8, 9}, {4, 9, 5}, {2, 4, 11}, {6, 2, 10},
                                       {8, 6, 7}, {9, 8, 1}};
  for (auto& p : v) p = p.normalized();
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      v.push_back((v[size_t(a)] + v[size_t(b)]).normalized());
      return mid[key] = int(v.size()) - 1;
    };
    std::vector<std::array<int, 3>> g;
    for (auto [a, b, c] : f) {
      const int ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
      g.insert(g.end(), {{a, ab, ca}, {b, bc, ab}, {c, ca, bc}, {ab, bc, ca}});
    }
    f = g;
  }
  SurfaceMesh m;
  m.V.resize(Eigen::Index(v.size()), 3);
  for (size_t i = 0; i < v.size(); ++i) m.V.row(Eigen::Index(i)) = radius * v[i];
  m.F.resize(Eigen::Index(f.size()), 3);
  for (size_t i = 0; i < f.size(); ++i) m.F.row(Eigen::Index(i)) << f[i][0], f[i][1], f[i][2];
  return m;
}

// A square sheet 4 cm across with a bump, open: its boundary is the square.
SurfaceMesh bumpy_sheet(int n) {
  SurfaceMesh m;
  m.V.resize((n + 1) * (n + 1), 3);
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) {
      const double x = -0.02 + 0.04 * i / n, z = -0.02 + 0.04 * j / n;
      m.V.row(i * (n + 1) + j) << x, 0.006 * std::exp(-(x * x + z * z) / 1e-4), z;
    }
  m.F.resize(2 * n * n, 3);
  int k = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const int a = i * (n + 1) + j, b = a + n + 1;
      m.F.row(k++) << a, a + 1, b;  // counter-clockwise seen from +y
      m.F.row(k++) << a + 1, b + 1, b;
    }
  return m;
}

// Undirected edges of the model's triangles with how many triangles hold each.
std::map<std::pair<int, int>, int> edge_use(const ChargedModel& m) {
  std::map<std::pair<int, int>, int> use;
  for (auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) ++use[std::minmax(t[size_t(k)], t[size_t((k + 1) % 3)])];
  return use;
}

void expect_at_most_six_symmetric_neighbours(const ChargedModel& m) {
  std::array<int, 6> nb{}, back{};
  for (int i = 0; i < int(m.size()); ++i) {
    const int k = m.neighbours_of(i, nb);
    ASSERT_LE(k, 6);
    EXPECT_GE(k, 2) << "particle " << i;
    for (int a = 0; a < k; ++a) {
      const int kb = m.neighbours_of(nb[size_t(a)], back);
      ASSERT_NE(std::find(back.begin(), back.begin() + kb, i), back.begin() + kb) << i << " " << nb[size_t(a)];
      EXPECT_LT((m.origin(size_t(i)) - m.origin(size_t(nb[size_t(a)]))).norm(), m.material.max_separation);
    }
  }
}

}  // namespace

TEST(ChargedMesh, ClosedSphereStaysClosedWithParticlesOnItAndOutwardNormals) {
  PALPATE_NEEDS(CGAL, "CGAL");
  const SurfaceMesh sphere = icosphere(0.03, 3);
  ChargedMaterialDef mat;
  mat.mesh_spacing = 0.004;
  mat.max_separation = 0.0064;
  auto m = build_charged_on_mesh(sphere, mat, "icosphere");
  ASSERT_TRUE(m.ok()) << m.error().message;
  EXPECT_GT(m->size(), 500u);
  EXPECT_EQ(m->layout, ChargedLayout::mesh);
  for (size_t i = 0; i < m->size(); ++i) {
    EXPECT_LT(distance_to_surface(sphere, m->origin(i)), 1e-6) << "particle " << i;
    EXPECT_GT(m->particle_normal(i).dot(m->origin(i).normalized()), 0.95) << "particle " << i;
  }
  for (auto& [edge, count] : edge_use(*m)) ASSERT_EQ(count, 2) << edge.first << "-" << edge.second;  // closed
  expect_at_most_six_symmetric_neighbours(*m);
  // Euler characteristic of a sphere: V - E + F = 2.
  EXPECT_EQ(long(m->size()) - long(edge_use(*m).size()) + long(m->triangles.size()), 2);
}

TEST(ChargedMesh, OpenSheetKeepsItsBoundaryExactly) {
  PALPATE_NEEDS(CGAL, "CGAL");
  const SurfaceMesh sheet = bumpy_sheet(12);
  ChargedMaterialDef mat;
  mat.mesh_spacing = 0.0015;
  mat.max_separation = 0.0024;
  auto m = build_charged_on_mesh(sheet, mat, "sheet");
  ASSERT_TRUE(m.ok()) << m.error().message;
  double boundary_length = 0;
  std::set<int> boundary_vertices;
  for (auto& [edge, count] : edge_use(*m)) {
    ASSERT_LE(count, 2);
    if (count == 1) {
      boundary_length += (m->origin(size_t(edge.first)) - m->origin(size_t(edge.second))).norm();
      boundary_vertices.insert(edge.first), boundary_vertices.insert(edge.second);
    }
  }
  // The input's boundary: the square's four sides, bent slightly by the bump's tail.
  std::map<std::pair<int, int>, int> input_use;
  for (Eigen::Index f = 0; f < sheet.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) ++input_use[std::minmax(sheet.F(f, k), sheet.F(f, (k + 1) % 3))];
  double input_length = 0;
  for (auto& [edge, count] : input_use)
    if (count == 1) input_length += (sheet.V.row(edge.first) - sheet.V.row(edge.second)).norm();
  EXPECT_GT(input_length, 0.16);
  EXPECT_NEAR(boundary_length, input_length, 1e-6);  // open in, the same boundary out
  for (int i : boundary_vertices) {
    const Vec3 o = m->origin(size_t(i));
    EXPECT_NEAR(std::max(std::abs(o.x()), std::abs(o.z())), 0.02, 1e-6) << "boundary particle " << i;
  }
  for (size_t i = 0; i < m->size(); ++i) {
    EXPECT_LT(distance_to_surface(sheet, m->origin(i)), 1e-6);
    EXPECT_GT(m->particle_normal(i).y(), 0.5);
  }
  expect_at_most_six_symmetric_neighbours(*m);
}

TEST(ChargedMesh, LiverSurfacePatchIsOnTheSurfaceClosedAndAtMostSixNeighbours) {
  PALPATE_NEEDS(CGAL, "CGAL");
  auto loaded = load_surface(std::string(PALPATE_DATA_DIR) + "/meshes/liver-smooth.obj", 0.01);
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  const SurfaceMesh& liver = *loaded;
  ASSERT_GT(liver.F.rows(), 4000);
  ChargedMaterialDef mat;
  mat.mesh_spacing = 0.003;
  mat.max_separation = 0.0048;
  auto m = build_charged_on_mesh(liver, mat, "liver-smooth.obj");
  ASSERT_TRUE(m.ok()) << m.error().message;
  EXPECT_GT(m->size(), 500u);
  for (size_t i = 0; i < m->size(); ++i)
    ASSERT_LT(distance_to_surface(liver, m->origin(i)), 0.01 * mat.mesh_spacing) << "particle " << i;
  for (auto& [edge, count] : edge_use(*m)) ASSERT_EQ(count, 2);  // closed in, closed out: no holes
  expect_at_most_six_symmetric_neighbours(*m);
  // A probe pressed onto the liver's top obeys the same bounds as on a generated patch.
  ChargedState s = make_charged_state(*m);
  size_t top = 0;
  for (size_t i = 0; i < m->size(); ++i) if (m->origin(i).y() > m->origin(top).y()) top = i;
  const Vec3 n = m->particle_normal(top).normalized();
  double peak = 0;
  for (int t = 0; t < 1500; ++t) {
    ChargedHip hip;
    hip.position = m->origin(top) + n * (mat.particle_radius - t * 5e-6);
    hip.sharp = false;  // a blunt probe: pressed on past max_displacement without puncturing
    peak = std::max(peak, step(*m, s, hip, 0.001).dot(n));
    std::array<int, 6> nb{};
    for (size_t a = 0; a < s.active_count; ++a) {
      const int i = s.active[a];
      ASSERT_LE((s.position(size_t(i)) - m->origin(size_t(i))).norm(), mat.max_displacement * (1 + 1e-5));
      for (int b = 0, k = m->neighbours_of(i, nb); b < k; ++b)
        ASSERT_LE((s.position(size_t(i)) - s.position(size_t(nb[size_t(b)]))).norm(), mat.max_separation * (1 + 2e-5));
    }
  }
  EXPECT_GT(peak, 0.1);
}

TEST(ChargedMesh, NonManifoldAndBadIndicesAreClearErrors) {
  PALPATE_NEEDS(CGAL, "CGAL");
  SurfaceMesh bad = icosphere(0.03, 0);
  bad.F(3, 1) = 99;
  auto r = build_charged_on_mesh(bad, ChargedMaterialDef{}, "organ.obj");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, "organ.obj: triangle 3 refers to vertex 99; expected an index in [0, 12)");
  SurfaceMesh fin = icosphere(0.03, 0);
  fin.F.conservativeResize(fin.F.rows() + 1, 3);
  fin.F.row(fin.F.rows() - 1) << 0, 11, 1;  // a third triangle on edge 0-11
  auto nm = build_charged_on_mesh(fin, ChargedMaterialDef{}, "organ.obj");
  ASSERT_FALSE(nm.ok());
  EXPECT_EQ(nm.error().message.rfind("organ.obj: the surface is not an oriented manifold", 0), 0u) << nm.error().message;
}

// A needle pressed into a patch laid on a curved mesh: the force–depth curve is the same at
// particle spacings of 1 and 2 mm (the indentation is measured against the surface the particles
// sample, not counted in particles), and the puncture comes at the material's force.
TEST(ChargedMesh, ForceDepthOnACurvedMeshIsTheSameAtEverySpacing) {
  PALPATE_NEEDS(CGAL, "CGAL");
  const SurfaceMesh sphere = icosphere(0.02, 4);
  const Vec3 dir = Vec3(0.31, 1.0, 0.17).normalized();  // between vertices
  std::vector<std::vector<double>> curves;
  for (double spacing : {0.001, 0.002}) {
    ChargedMaterialDef mat;
    mat.mesh_spacing = spacing, mat.puncture_force = 0.8, mat.max_displacement = 0.004;
    auto m = build_charged_on_mesh(sphere, mat, "icosphere");
    ASSERT_TRUE(m.ok()) << m.error().message;
    ChargedState s = make_charged_state(*m);
    ChargedHip needle;
    needle.axis = -dir, needle.radius = 0.0004, needle.shaft_length = 0.03;
    std::vector<double> f;
    double puncture = -1;
    for (int t = 0; t < 4000 && puncture < 0; ++t) {
      needle.position = dir * (0.02 + 0.003 - t * 2e-6);
      f.push_back(step(*m, s, needle, 0.001).dot(dir));
      TissueEvent ev[4];
      if (drain_events(s, ev) > 0) puncture = ev[0].force;
    }
    EXPECT_NEAR(puncture, mat.puncture_force, 0.05 * mat.puncture_force) << "spacing " << spacing;
    curves.push_back(f);
  }
  const size_t n = std::min(curves[0].size(), curves[1].size());
  EXPECT_GT(n, 0.95 * std::max(curves[0].size(), curves[1].size()));
  for (size_t k = 0; k + 1 < n; ++k)  // up to the puncture
    ASSERT_NEAR(curves[1][k], curves[0][k], 0.1 * curves[0][k] + 1e-3) << "tick " << k;
}
