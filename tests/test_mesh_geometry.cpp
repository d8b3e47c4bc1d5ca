// test_mesh_geometry.cpp — normals, tetrahedral boundary, describe() statistics and validation tolerances.
#include <palpate/mesh.h>
#include <palpate/mesh_load.h>

#include "components.h"
#include "mesh_test_files.h"

#include <gtest/gtest.h>

#include <cmath>

namespace {

using palpate::Vec3;

// The regular octahedron with vertices ±x, ±y, ±z: by symmetry each vertex normal is the vertex itself.
palpate::SurfaceMesh octahedron() {
  palpate::SurfaceMesh m;
  m.V.resize(6, 3);
  m.V << 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1;
  m.F.resize(8, 3);
  m.F << 0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5;
  return m;
}

TEST(MeshGeometry, NormalsOfOctahedronAreItsVertexDirections) {
  palpate::SurfaceMesh m = octahedron();
  palpate::compute_normals(m);
  ASSERT_EQ(m.N.rows(), 6);
  for (int v = 0; v < 6; ++v) EXPECT_TRUE(m.N.row(v).isApprox(m.V.row(v), 1e-14)) << "vertex " << v;
  EXPECT_NEAR(palpate::describe(m).volume, 4.0 / 3.0, 1e-14);  // two pyramids of base 2, height 1
}

TEST(MeshGeometry, NormalsAreAreaWeighted) {
  // Two triangles meeting at vertex 0: one in the xy plane of area 2, one in the xz plane of
  // area 1/2. The normal at vertex 0 leans 4:1 towards the larger one's.
  palpate::SurfaceMesh m;
  m.V.resize(5, 3);
  m.V << 0, 0, 0, 2, 0, 0, 0, 2, 0, 1, 0, 0, 0, 0, -1;
  m.F.resize(2, 3);
  m.F << 0, 1, 2, 0, 3, 4;
  palpate::compute_normals(m);
  const Vec3 expected = Vec3(0, 2 * 0.5, 2.0 * 2.0).normalized();  // (0, 0, 4) + (0, 1, 0)
  EXPECT_TRUE(m.N.row(0).transpose().isApprox(expected, 1e-14)) << m.N.row(0);
  EXPECT_TRUE(m.N.row(1).transpose().isApprox(Vec3::UnitZ(), 1e-14));
  EXPECT_TRUE(m.N.row(4).transpose().isApprox(Vec3::UnitY(), 1e-14));
}

TEST(MeshGeometry, BoundaryOfCubeTetsIsTheOutwardCube) {
  const palpate::TetMesh tets = palpate::test::cube_tets();
  const palpate::SurfaceMesh b = palpate::boundary_surface(tets);
  ASSERT_EQ(b.F.rows(), 12);
  EXPECT_TRUE(palpate::validate(b, "boundary", {.manifold = true, .closed = true}).ok());
  EXPECT_NEAR(palpate::describe(b).volume, 1.0, 1e-14);
  // Each face's normal points away from the centre.
  for (Eigen::Index f = 0; f < b.F.rows(); ++f) {
    const Vec3 a = b.V.row(b.F(f, 0)), p = b.V.row(b.F(f, 1)), c = b.V.row(b.F(f, 2));
    EXPECT_GT((p - a).cross(c - a).dot((a + p + c) / 3 - Vec3::Constant(0.5)), 0) << "face " << f;
  }
  // Inverted input tetrahedra still give outward faces.
  palpate::TetMesh flipped = tets;
  flipped.T.col(2).swap(flipped.T.col(3));
  EXPECT_NEAR(palpate::describe(palpate::boundary_surface(flipped)).volume, 1.0, 1e-14);
}

TEST(MeshGeometry, BoundaryOfLiverEnclosesItsVolume) {
  PALPATE_NEEDS(GMSH, "Gmsh");
  const auto tet = palpate::load_tet(palpate::test::data_mesh("liver.msh"));
  ASSERT_TRUE(tet.ok());
  const palpate::SurfaceMesh b = palpate::boundary_surface(*tet);
  EXPECT_EQ(b.F.rows(), 276);
  EXPECT_TRUE(palpate::validate(b, "liver boundary", {.manifold = true, .closed = true}).ok());
  const palpate::MeshInfo bi = palpate::describe(b), ti = palpate::describe(*tet);
  EXPECT_NEAR(bi.volume, ti.volume, 1e-12 * ti.volume);
  // 3F = 2E for a closed surface; V − E + F = 2 for a sphere-like one, over the vertices it uses (140).
  EXPECT_EQ(2 * bi.edges.count, 3u * 276u);
  EXPECT_EQ(140 - static_cast<long>(bi.edges.count) + 276, 2);
}

TEST(MeshGeometry, DescribeCubeSurface) {
  const palpate::MeshInfo info = palpate::describe(palpate::test::cube_surface());
  EXPECT_EQ(info.kind, "surface");
  EXPECT_EQ(info.vertices, 8u);
  EXPECT_EQ(info.triangles, 12u);
  EXPECT_EQ(info.tetrahedra, 0u);
  EXPECT_EQ(info.bbox_min, Vec3::Zero());
  EXPECT_EQ(info.bbox_max, Vec3::Ones());
  EXPECT_TRUE(info.closed);
  EXPECT_TRUE(info.manifold);
  EXPECT_EQ(info.boundary_edges, 0u);
  EXPECT_EQ(info.non_manifold_edges, 0u);
  EXPECT_NEAR(info.volume, 1.0, 1e-15);
  // 12 cube edges of length 1 and 6 face diagonals of length √2.
  EXPECT_EQ(info.edges.count, 18u);
  EXPECT_DOUBLE_EQ(info.edges.min, 1.0);
  EXPECT_DOUBLE_EQ(info.edges.max, std::sqrt(2.0));
  EXPECT_NEAR(info.edges.mean, (12 + 6 * std::sqrt(2.0)) / 18, 1e-15);
  EXPECT_DOUBLE_EQ(info.edges.median, 1.0);
}

TEST(MeshGeometry, DescribeCubeTets) {
  const palpate::MeshInfo info = palpate::describe(palpate::test::cube_tets());
  EXPECT_EQ(info.kind, "tetrahedral");
  EXPECT_EQ(info.vertices, 8u);
  EXPECT_EQ(info.tetrahedra, 5u);
  EXPECT_EQ(info.triangles, 12u);  // boundary triangles
  EXPECT_TRUE(info.closed);
  EXPECT_TRUE(info.manifold);
  EXPECT_NEAR(info.volume, 1.0, 1e-15);
  // The central tetrahedron's edges are face diagonals: the same 18 unique edges as the surface.
  EXPECT_EQ(info.edges.count, 18u);
  EXPECT_DOUBLE_EQ(info.edges.max, std::sqrt(2.0));
  EXPECT_DOUBLE_EQ(info.edges.median, 1.0);
}

TEST(MeshGeometry, DescribeOpenAndNonManifoldSurfaces) {
  palpate::SurfaceMesh m = palpate::test::cube_surface();
  m.F.conservativeResize(10, 3);  // drop the top's two triangles
  palpate::MeshInfo info = palpate::describe(m);
  EXPECT_FALSE(info.closed);
  EXPECT_TRUE(info.manifold);
  EXPECT_EQ(info.boundary_edges, 4u);
  EXPECT_EQ(info.volume, 0.0);  // not enclosed: no volume
  // A fin on an edge: three triangles on the edge (0, 1).
  m = palpate::test::cube_surface();
  m.V.conservativeResize(9, 3);
  m.V.row(8) << 0.5, -1, -1;
  m.F.conservativeResize(13, 3);
  m.F.row(12) << 0, 1, 8;
  info = palpate::describe(m);
  EXPECT_FALSE(info.closed);
  EXPECT_FALSE(info.manifold);
  EXPECT_EQ(info.non_manifold_edges, 1u);
  EXPECT_EQ(info.boundary_edges, 2u);
  // Median of an even number of edges is the mean of the middle two: a lone triangle 3-4-5 has 3.
  palpate::SurfaceMesh tri;
  tri.V.resize(3, 3);
  tri.V << 0, 0, 0, 3, 0, 0, 0, 4, 0;
  tri.F.resize(1, 3);
  tri.F << 0, 1, 2;
  EXPECT_DOUBLE_EQ(palpate::describe(tri).edges.median, 4.0);
  tri.V.conservativeResize(4, 3);
  tri.V.row(3) << 0, 0, 1;
  tri.F.conservativeResize(2, 3);
  tri.F.row(1) << 0, 2, 3;  // adds edges 2-3 (√17) and 0-3 (1): lengths 1, 3, 4, 5, √17 → median 4
  EXPECT_DOUBLE_EQ(palpate::describe(tri).edges.median, 4.0);
}

TEST(MeshGeometry, VolumeIsTranslationInvariant) {
  palpate::SurfaceMesh m = palpate::test::cube_surface();
  const double at_origin = palpate::describe(m).volume;
  m.V.rowwise() += Eigen::RowVector3d(10, -3, 5);
  EXPECT_NEAR(palpate::describe(m).volume, at_origin, 1e-12);
}

TEST(MeshGeometry, ValidationToleranceIsRelativeToSize) {
  // libigl's habit: the same mesh at 1e-8 and 1e8 scale passes, and a degenerate one fails at both.
  for (double scale : {1e-8, 1.0, 1e8}) {
    palpate::TetMesh t = palpate::test::cube_tets();
    t.V *= scale;
    EXPECT_TRUE(palpate::validate(t, "cube").ok()) << scale;
    palpate::SurfaceMesh s = palpate::test::cube_surface();
    s.V *= scale;
    EXPECT_TRUE(palpate::validate(s, "cube", {.manifold = true, .closed = true}).ok()) << scale;
    t.V.row(7) = 0.5 * (t.V.row(1) + t.V.row(2)) + 1e-14 * scale * Eigen::RowVector3d(0, 0, 1);  // flattens tets
    EXPECT_FALSE(palpate::validate(t, "cube").ok()) << scale;
  }
}

TEST(MeshGeometry, EmptyMeshesAreRefused) {
  EXPECT_EQ(palpate::validate(palpate::SurfaceMesh{}, "a.obj").error().message, "a.obj: empty mesh: no vertices");
  EXPECT_EQ(palpate::validate(palpate::TetMesh{}, "a.msh").error().message, "a.msh: empty mesh: no vertices");
  palpate::TetMesh t;
  t.V = palpate::test::cube_vertices();
  EXPECT_EQ(palpate::validate(t, "a.msh").error().message, "a.msh: empty mesh: no tetrahedra");
  palpate::SurfaceMesh s;
  s.V = palpate::test::cube_vertices();
  EXPECT_EQ(palpate::validate(s, "a.obj").error().message, "a.obj: empty mesh: no triangles");
}

}  // namespace
