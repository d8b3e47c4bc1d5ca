// test_mesh_tetrahedralize.cpp — filling closed surfaces with tetrahedra through Gmsh.
#include <palpate/mesh.h>
#include <palpate/mesh_load.h>
#include <palpate/meshing.h>

#include "components.h"
#include "mesh_test_files.h"
#include "tissue/spring/shapes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

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
  PALPATE_NEEDS(GMSH, "Gmsh");
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
  PALPATE_NEEDS(GMSH, "Gmsh");
  palpate::SurfaceMesh cube = palpate::test::cube_surface();
  cube.F.col(1).swap(cube.F.col(2));
  const auto tets = palpate::tetrahedralize(cube, 0.4);
  ASSERT_TRUE(tets.ok()) << tets.error().message;
  expect_fills(cube, *tets);
  EXPECT_NEAR(palpate::describe(*tets).volume, 1.0, 1e-12);
}

TEST(MeshTetrahedralize, UnusedVerticesAreLeftOut) {
  PALPATE_NEEDS(GMSH, "Gmsh");
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

namespace {

// Mean edge length of the tetrahedra whose centroid lies within `radius` of `at` (or beyond it).
double mean_edge_near(const palpate::TetMesh& m, const palpate::Vec3& at, double radius, bool inside) {
  static constexpr int kEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  double sum = 0;
  int count = 0;
  for (Eigen::Index t = 0; t < m.T.rows(); ++t) {
    palpate::Vec3 c = palpate::Vec3::Zero();
    for (int k = 0; k < 4; ++k) c += m.V.row(m.T(t, k)).transpose() / 4;
    if (((c - at).norm() < radius) != inside) continue;
    for (const auto& e : kEdges) {
      sum += (m.V.row(m.T(t, e[0])) - m.V.row(m.T(t, e[1]))).norm();
      ++count;
    }
  }
  return count ? sum / count : 0.0;
}

// A graded fill (FillOptions::refine): a unit cube (its surface in squares of 0.25) filled with
// edges of 0.25 except near its centre, where they are 0.05. More vertices than the uniform fill,
// tetrahedra several times smaller near the point than away from it, the same volume and boundary.
TEST(MeshTetrahedralize, RefinementGradesTheFill) {
  PALPATE_NEEDS(GMSH, "Gmsh");
  const palpate::SurfaceMesh cube = palpate::boundary_surface(palpate::spring::make_block(5, 5, 5, 0.25));
  const auto uniform = palpate::tetrahedralize(cube, 0.25);
  ASSERT_TRUE(uniform.ok()) << uniform.error().message;
  palpate::FillOptions o;
  o.max_edge = 0.25;
  const palpate::Vec3 at(0.5, 0.5, 0.5);
  o.refine.push_back({.center = at, .radius = 0.1, .size = 0.05, .growth = 0.5});
  const auto graded = palpate::tetrahedralize(cube, o);
  ASSERT_TRUE(graded.ok()) << graded.error().message;
  expect_fills(cube, *graded);
  EXPECT_NEAR(palpate::describe(*graded).volume, 1.0, 1e-12);
  EXPECT_GT(graded->V.rows(), uniform->V.rows());
  const double near = mean_edge_near(*graded, at, 0.1, true), far = mean_edge_near(*graded, at, 0.35, false);
  std::printf("graded fill: %ld vertices (uniform %ld); mean edge near the point %.3f, away %.3f\n",
              static_cast<long>(graded->V.rows()), static_cast<long>(uniform->V.rows()), near, far);
  EXPECT_GT(near, 0.0);
  EXPECT_LT(near, 0.1);            // about the refinement's 0.05
  EXPECT_GT(far, 2.0 * near);      // coarser away from it
}

TEST(MeshTetrahedralize, RefusesBadRefinements) {
  const palpate::SurfaceMesh cube = palpate::test::cube_surface();
  const auto error = [&](const palpate::FillRefinement& r, double max_edge = 0.0) {
    palpate::FillOptions o;
    o.max_edge = max_edge;
    o.refine = {palpate::FillRefinement{}, r};  // the second one is checked (and named refine[1])
    o.refine[0].size = 0.1;
    const auto t = palpate::tetrahedralize(cube, o);
    return t.ok() ? std::string("accepted") : t.error().message;
  };
  EXPECT_EQ(error({.center = palpate::Vec3::Zero(), .radius = 0.1, .size = 0.0}),
            "tetrahedralize: refine[1].size is 0, expected a length > 0 in m");
  EXPECT_EQ(error({.center = palpate::Vec3::Zero(), .radius = 0.1, .size = 0.5}, 0.25),
            "tetrahedralize: refine[1].size is 0.5, expected a length > 0 in m, at most max_edge (0.25)");
  EXPECT_EQ(error({.center = palpate::Vec3::Zero(), .radius = -1, .size = 0.1}),
            "tetrahedralize: refine[1].radius is -1, expected a length ≥ 0 in m");
  EXPECT_EQ(error({.center = palpate::Vec3(std::nan(""), 0, 0), .radius = 0.1, .size = 0.1}),
            "tetrahedralize: refine[1].center is (nan, 0, 0), expected a finite point in m");
  EXPECT_EQ(error({.center = palpate::Vec3::Zero(), .radius = 0.1, .size = 0.1, .growth = 0}),
            "tetrahedralize: refine[1].growth is 0, expected a size gain per metre in (0, 10]");
}

}  // namespace
