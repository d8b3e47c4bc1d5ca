// test_mesh_tetrahedralize.cpp — filling closed surfaces with tetrahedra through Gmsh.
#include <palpate/mesh.h>

#include "mesh_test_files.h"

#include <gtest/gtest.h>

namespace {

void expect_fills(const palpate::SurfaceMesh& surface, const palpate::TetMesh& tets) {
  EXPECT_TRUE(palpate::validate(tets, "tets").ok());
  for (Eigen::Index t = 0; t < tets.T.rows(); ++t) {
    const auto p = [&](int k) -> palpate::Vec3 { return tets.V.row(tets.T(t, k)).transpose(); };
    ASSERT_GT((p(1) - p(0)).dot((p(2) - p(0)).cross(p(3) - p(0))), 0) << "tetrahedron " << t;
  }
  const double enclosed = std::abs(palpate::describe(surface).volume);
  EXPECT_NEAR(palpate::describe(tets).volume, enclosed, 0.01 * enclosed);
  // The surface's triangles are kept: the tet boundary has as many, over the same points.
  const palpate::MeshInfo boundary = palpate::describe(palpate::boundary_surface(tets));
  EXPECT_EQ(boundary.triangles, static_cast<size_t>(surface.F.rows()));
  EXPECT_TRUE(boundary.closed);
  EXPECT_TRUE(boundary.bbox_min.isApprox(palpate::describe(surface).bbox_min, 1e-12));
}

TEST(MeshTetrahedralize, LiverBoundaryFillsTheLiverVolume) {
  const auto surface = palpate::load_surface(palpate::test::data_mesh("liver_tet_boundary.obj"), 1.0,
                                             {.manifold = true, .closed = true});
  ASSERT_TRUE(surface.ok()) << surface.error().message;
  const auto coarse = palpate::tetrahedralize(*surface);
  ASSERT_TRUE(coarse.ok()) << coarse.error().message;
  expect_fills(*surface, *coarse);
  EXPECT_NEAR(palpate::describe(*coarse).volume, 36.56, 0.01);
  // A size bound adds interior points: more, smaller tetrahedra, the same volume.
  const auto fine = palpate::tetrahedralize(*surface, 0.5);
  ASSERT_TRUE(fine.ok()) << fine.error().message;
  expect_fills(*surface, *fine);
  EXPECT_GT(fine->T.rows(), coarse->T.rows());
  EXPECT_GT(fine->V.rows(), coarse->V.rows());
}

TEST(MeshTetrahedralize, InwardFacingCubeStillGivesPositiveTets) {
  palpate::SurfaceMesh cube = palpate::test::cube_surface();
  cube.F.col(1).swap(cube.F.col(2));
  const auto tets = palpate::tetrahedralize(cube, 0.4);
  ASSERT_TRUE(tets.ok()) << tets.error().message;
  expect_fills(cube, *tets);
  EXPECT_NEAR(palpate::describe(*tets).volume, 1.0, 1e-12);
}

TEST(MeshTetrahedralize, UnusedVerticesAreLeftOut) {
  palpate::SurfaceMesh cube = palpate::test::cube_surface();
  cube.V.conservativeResize(9, 3);
  cube.V.row(8) << 5, 5, 5;  // no triangle uses it
  const auto tets = palpate::tetrahedralize(cube);
  ASSERT_TRUE(tets.ok()) << tets.error().message;
  EXPECT_LE(tets->V.col(0).maxCoeff(), 1.0);
  EXPECT_NEAR(palpate::describe(*tets).volume, 1.0, 1e-12);
}

TEST(MeshTetrahedralize, RefusesOpenSurfacesAndBadSizes) {
  palpate::SurfaceMesh open = palpate::test::cube_surface();
  open.F.conservativeResize(10, 3);
  const auto r = palpate::tetrahedralize(open);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message.rfind("tetrahedralize: open surface: 4 boundary edges", 0), 0u) << r.error().message;
  const auto neg = palpate::tetrahedralize(palpate::test::cube_surface(), -1.0);
  ASSERT_FALSE(neg.ok());
  EXPECT_EQ(neg.error().message,
            "tetrahedralize: max_edge is -1, expected 0 (as the surface's edges) or a positive length in m");
  // A self-touching surface: two cubes sharing an edge is not manifold.
  palpate::SurfaceMesh fin = palpate::test::cube_surface();
  fin.V.conservativeResize(9, 3);
  fin.V.row(8) << 0.5, -1, -1;
  fin.F.conservativeResize(13, 3);
  fin.F.row(12) << 0, 1, 8;
  const auto nm = palpate::tetrahedralize(fin);
  ASSERT_FALSE(nm.ok());
  EXPECT_NE(nm.error().message.find("non-manifold edge (0, 1)"), std::string::npos) << nm.error().message;
}

}  // namespace
