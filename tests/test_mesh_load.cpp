// test_mesh_load.cpp — loading good files of every format: the shared liver variants and the hand-made cubes.
#include <palpate/mesh.h>
#include <palpate/mesh_load.h>

#include "components.h"
#include "mesh_test_files.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>

namespace {

using palpate::test::data_mesh;
using palpate::test::test_mesh;

constexpr double kLiverVolume = 36.56;  // SOURCES.md: liver.msh, 596 positive tets

// Binary STL: 80-byte header, uint32 count, then per triangle 12 floats (normal, 3 corners) + uint16.
std::string binary_stl(const palpate::SurfaceMesh& m, const std::string& header) {
  std::string out(80, ' ');
  std::memcpy(out.data(), header.data(), std::min<size_t>(header.size(), 80));
  const auto put = [&out](const void* p, size_t n) { out.append(static_cast<const char*>(p), n); };
  const std::uint32_t count = static_cast<std::uint32_t>(m.F.rows());
  put(&count, 4);
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    const float normal[3] = {0, 0, 0};
    put(normal, sizeof normal);
    for (int k = 0; k < 3; ++k)
      for (int d = 0; d < 3; ++d) {
        const float x = static_cast<float>(m.V(m.F(f, k), d));
        put(&x, 4);
      }
    const std::uint16_t attribute = 0;
    put(&attribute, 2);
  }
  return out;
}

// Properties every loaded unit cube surface has, whatever its format.
void expect_unit_cube_surface(const palpate::SurfaceMesh& m, double scale) {
  ASSERT_EQ(m.V.rows(), 8);
  ASSERT_EQ(m.F.rows(), 12);
  const palpate::MeshInfo info = palpate::describe(m);
  EXPECT_TRUE(info.closed);
  EXPECT_TRUE(info.manifold);
  EXPECT_NEAR(info.volume, scale * scale * scale, 1e-12);
  EXPECT_TRUE(info.bbox_min.isApprox(palpate::Vec3::Zero(), 0) || info.bbox_min.norm() < 1e-15);
  EXPECT_TRUE(info.bbox_max.isApprox(palpate::Vec3::Constant(scale), 1e-12));
  // Normals are unit and point out of the cube, away from its centre.
  const palpate::Vec3 centre = palpate::Vec3::Constant(0.5 * scale);
  ASSERT_EQ(m.N.rows(), 8);
  for (Eigen::Index v = 0; v < 8; ++v) {
    EXPECT_NEAR(m.N.row(v).norm(), 1.0, 1e-12);
    EXPECT_GT(m.N.row(v).dot(m.V.row(v) - centre.transpose()), 0.0) << "vertex " << v;
  }
}

void expect_unit_cube_tets(const palpate::TetMesh& m) {
  ASSERT_EQ(m.V.rows(), 8);
  ASSERT_EQ(m.T.rows(), 5);
  EXPECT_NEAR(palpate::describe(m).volume, 1.0, 1e-12);
  // Same vertices and tetrahedra, in the same order, as the in-memory cube.
  const palpate::TetMesh want = palpate::test::cube_tets();
  EXPECT_EQ(m.V, want.V);
  EXPECT_EQ(m.T, want.T);
}

TEST(MeshLoad, SharedLiverTetVariantsAgree) {
  PALPATE_NEEDS(GMSH, "Gmsh");
  const auto msh = palpate::load_tet(data_mesh("liver.msh"));
  ASSERT_TRUE(msh.ok()) << msh.error().message;
  EXPECT_EQ(msh->V.rows(), 181);
  EXPECT_EQ(msh->T.rows(), 596);
  EXPECT_NEAR(palpate::describe(*msh).volume, kLiverVolume, 0.01);
  for (const char* name : {"liver_tet.node", "liver_tet.ele", "liver_tet.vtk"}) {
    const auto other = palpate::load_tet(data_mesh(name));
    ASSERT_TRUE(other.ok()) << other.error().message;
    EXPECT_EQ(other->V.rows(), 181) << name;
    EXPECT_EQ(other->T.rows(), 596) << name;
    EXPECT_NEAR(palpate::describe(*other).volume, kLiverVolume, 0.01) << name;
    // Converted from liver.msh: the same vertices (0-based) and tetrahedra in the same order.
    EXPECT_TRUE(other->V.isApprox(msh->V, 1e-12)) << name;
    EXPECT_EQ(other->T, msh->T) << name;
  }
}

TEST(MeshLoad, ScaleMultipliesEveryCoordinate) {
  const auto one = palpate::load_tet(data_mesh("liver_tet.vtk"));
  const auto cm = palpate::load_tet(data_mesh("liver_tet.vtk"), 0.01);
  ASSERT_TRUE(one.ok() && cm.ok());
  EXPECT_TRUE(cm->V.isApprox(0.01 * one->V, 1e-15));
  EXPECT_NEAR(palpate::describe(*cm).volume, kLiverVolume * 1e-6, 1e-8);
  const auto surf = palpate::load_surface(test_mesh("cube.off"), 2.5);
  ASSERT_TRUE(surf.ok()) << surf.error().message;
  expect_unit_cube_surface(*surf, 2.5);
}

TEST(MeshLoad, LiverObjSharesTheTetVertices) {
  PALPATE_NEEDS(GMSH, "Gmsh");
  const auto obj = palpate::load_surface(data_mesh("liver.obj"));
  ASSERT_TRUE(obj.ok()) << obj.error().message;
  const auto tet = palpate::load_tet(data_mesh("liver.msh"));
  ASSERT_TRUE(tet.ok());
  EXPECT_EQ(obj->F.rows(), 274);
  // Every surface vertex is one of the tet mesh's vertices (same coordinates, float precision).
  for (Eigen::Index v = 0; v < obj->V.rows(); ++v) {
    double nearest = 1e9;
    for (Eigen::Index w = 0; w < tet->V.rows(); ++w) nearest = std::min(nearest, (obj->V.row(v) - tet->V.row(w)).norm());
    EXPECT_LT(nearest, 1e-5) << "vertex " << v;
  }
  const palpate::MeshInfo info = palpate::describe(*obj);
  EXPECT_EQ(info.non_manifold_edges, 0u);
  EXPECT_TRUE(info.bbox_min.isApprox(palpate::describe(*tet).bbox_min, 1e-6));
}

TEST(MeshLoad, LiverSmoothObjMergesCornersByPosition) {
  // Each corner carries its own normal index (f 1//1 2194//2 ...): merged by position it is
  // one connected surface of 2194 vertices.
  const auto m = palpate::load_surface(data_mesh("liver-smooth.obj"));
  ASSERT_TRUE(m.ok()) << m.error().message;
  EXPECT_EQ(m->V.rows(), 2194);
  EXPECT_EQ(m->F.rows(), 4384);
  ASSERT_EQ(m->N.rows(), 2194);
  for (Eigen::Index v = 0; v < m->N.rows(); ++v) ASSERT_NEAR(m->N.row(v).norm(), 1.0, 1e-12) << v;
  const palpate::MeshInfo info = palpate::describe(*m);
  EXPECT_EQ(info.non_manifold_edges, 0u);
  // Each triangle has 3 edge uses; interior edges take 2, boundary edges 1: 3F = 2E - B.
  EXPECT_EQ(2 * info.edges.count, 3u * 4384u + info.boundary_edges);
}

TEST(MeshLoad, LiverTetBoundaryIsClosedAndEnclosesTheTetVolume) {
  PALPATE_NEEDS(GMSH, "Gmsh");
  const auto surf = palpate::load_surface(data_mesh("liver_tet_boundary.obj"), 1.0, {.manifold = true, .closed = true});
  ASSERT_TRUE(surf.ok()) << surf.error().message;
  EXPECT_EQ(surf->V.rows(), 140);
  EXPECT_EQ(surf->F.rows(), 276);
  const auto tet = palpate::load_tet(data_mesh("liver.msh"));
  ASSERT_TRUE(tet.ok());
  const palpate::MeshInfo s = palpate::describe(*surf), t = palpate::describe(*tet);
  EXPECT_TRUE(s.closed);
  EXPECT_TRUE(s.manifold);
  EXPECT_NEAR(s.volume, t.volume, 1e-5 * t.volume);  // the OBJ goes through assimp's floats
  // And the tet mesh's own boundary is that surface: same count, same volume.
  EXPECT_EQ(t.triangles, 276u);
  EXPECT_TRUE(t.closed);
  EXPECT_NEAR(palpate::describe(palpate::boundary_surface(*tet)).volume, t.volume, 1e-9 * t.volume);
}

TEST(MeshLoad, CubeInEverySurfaceFormat) {
  palpate::test::ScratchDir dir;
  const auto binary = dir.write("cube_binary.stl", binary_stl(palpate::test::cube_surface(), "binary cube"));
  // The PLY variants as other tools write them (binary both ways with normals, colours and face
  // texture coordinates; CRLF ASCII with doubles): palpate's walk of the PLY file accepts them.
  for (const auto& file : {test_mesh("cube_ascii.stl"), binary, test_mesh("cube.ply"), test_mesh("cube.off"),
                           test_mesh("cube_binary_little.ply"), test_mesh("cube_binary_big.ply"),
                           test_mesh("cube_crlf.ply")}) {
    SCOPED_TRACE(file.string());
    const auto m = palpate::load_surface(file, 1.0, {.manifold = true, .closed = true});
    ASSERT_TRUE(m.ok()) << m.error().message;
    expect_unit_cube_surface(*m, 1.0);
  }
}

TEST(MeshLoad, InwardFacingClosedSurfaceIsTurnedOutward) {
  palpate::test::ScratchDir dir;
  palpate::SurfaceMesh inward = palpate::test::cube_surface();
  inward.F.col(1).swap(inward.F.col(2));
  ASSERT_LT(palpate::describe(inward).volume, 0);
  const auto m = palpate::load_surface(dir.write("inward.stl", binary_stl(inward, "inward")));
  ASSERT_TRUE(m.ok()) << m.error().message;
  expect_unit_cube_surface(*m, 1.0);
}

TEST(MeshLoad, CubeInEveryTetFormat) {
  PALPATE_NEEDS(GMSH, "Gmsh");
  for (const char* name : {"cube_v2.msh", "cube_v4.msh", "cube_v4_binary.msh", "cube_1based.node", "cube_1based.ele"}) {
    SCOPED_TRACE(name);
    const auto m = palpate::load_tet(test_mesh(name));
    ASSERT_TRUE(m.ok()) << m.error().message;
    expect_unit_cube_tets(*m);
  }
}

// Files as Gmsh 4.8 writes them with every entity saved and partitioned (tests/data/meshes/
// make_gmsh41.cpp): empty node blocks, physical points, $PartitionedEntities — none refused by the
// checks made against damaged files, and each the same unit box.
TEST(MeshLoad, GmshFilesAsGmshWritesThem) {
  PALPATE_NEEDS(GMSH, "Gmsh");
  // Named physical groups ($PhysicalNames) in every file; format 2.2 as well, ASCII and binary.
  for (const char* name : {"box_gmsh41_saveall.msh", "box_gmsh41_saveall_binary.msh", "box_gmsh41_partitioned.msh",
                           "box_gmsh41_partitioned_binary.msh", "box_gmsh22_named.msh", "box_gmsh22_named_binary.msh"}) {
    SCOPED_TRACE(name);
    const auto m = palpate::load_tet(test_mesh(name));
    ASSERT_TRUE(m.ok()) << m.error().message;
    EXPECT_EQ(m->V.rows(), 14);
    EXPECT_NEAR(palpate::describe(*m).volume, 1.0, 1e-9);
    EXPECT_NEAR(m->V.minCoeff(), 0.0, 1e-12);
    EXPECT_NEAR(m->V.maxCoeff(), 1.0, 1e-12);
  }
}

TEST(MeshLoad, VtkMixedCellsAndFileVersion51) {
  palpate::test::ScratchDir dir;
  // Legacy 3.0 with float points, several per line, a triangle and a vertex cell that are skipped.
  const std::string points = "0 0 0 1 0 0 0 1 0 1 1 0\n0 0 1 1 0 1 0 1 1 1 1 1\n";
  const auto legacy = dir.write("mixed.vtk",
                                "# vtk DataFile Version 3.0\ncube\nASCII\nDATASET UNSTRUCTURED_GRID\n"
                                "POINTS 8 float\n" + points +
                                "CELLS 7 31\n3 0 2 3\n4 1 2 4 7\n4 0 1 2 4\n4 3 2 1 7\n4 5 1 4 7\n4 6 2 7 4\n1 5\n"
                                "CELL_TYPES 7\n5 10 10 10 10 10 1\n"
                                "CELL_DATA 7\nSCALARS region int 1\nLOOKUP_TABLE default\n0 1 1 1 1 1 0\n");
  const auto v51 = dir.write("v51.vtk",
                             "# vtk DataFile Version 5.1\ncube\nASCII\nDATASET UNSTRUCTURED_GRID\n"
                             "POINTS 8 double\n" + points + "METADATA\nINFORMATION 0\n\n"
                             "CELLS 7 23\nOFFSETS vtktypeint64\n0 3 7 11 15 19 23\n"
                             "CONNECTIVITY vtktypeint64\n0 2 3 1 2 4 7 0 1 2 4 3 2 1 7 5 1 4 7 6 2 7 4\n"
                             "CELL_TYPES 6\n5 10 10 10 10 10\n");
  for (const auto& file : {legacy, v51}) {
    SCOPED_TRACE(file.string());
    const auto m = palpate::load_tet(file);
    ASSERT_TRUE(m.ok()) << m.error().message;
    expect_unit_cube_tets(*m);
  }
}

TEST(MeshLoad, TetGenZeroBasedQuadraticKeepsCorners) {
  palpate::test::ScratchDir dir;
  std::string node = "8 3 0 0\n";
  for (int i = 0; i < 8; ++i)
    node += std::to_string(i) + " " + std::to_string(i & 1) + " " + std::to_string((i >> 1) & 1) + " " +
            std::to_string((i >> 2) & 1) + "\n";
  dir.write("quad.node", node);
  // 10 nodes per tetrahedron: the 4 corners, then 6 mid-edge nodes (here reusing corners: only
  // the corners are read).
  const auto ele = dir.write("quad.ele",
                             "5 10 0\n0 1 2 4 7 0 0 0 0 0 0\n1 0 1 2 4 0 0 0 0 0 0\n2 3 2 1 7 0 0 0 0 0 0\n"
                             "3 5 1 4 7 0 0 0 0 0 0\n4 6 2 7 4 0 0 0 0 0 0\n");
  const auto m = palpate::load_tet(ele);
  ASSERT_TRUE(m.ok()) << m.error().message;
  expect_unit_cube_tets(*m);
}

TEST(MeshLoad, IsTetFileByExtension) {
  for (const char* yes : {"a.msh", "b.MSH", "dir/c.node", "d.ele", "e.vtk"}) EXPECT_TRUE(palpate::is_tet_file(yes)) << yes;
  for (const char* no : {"a.obj", "b.stl", "c.ply", "d.off", "e", "msh", "f.msh.obj"})
    EXPECT_FALSE(palpate::is_tet_file(no)) << no;
}

}  // namespace
