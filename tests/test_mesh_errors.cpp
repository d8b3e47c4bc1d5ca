// test_mesh_errors.cpp — bad mesh files: each is refused with an error naming the file and the line or element.
#include <palpate/mesh.h>
#include <palpate/mesh_load.h>

#include "components.h"
#include "mesh_test_files.h"

#include <gtest/gtest.h>

#include <cstring>
#include <initializer_list>
#include <limits>
#include <random>
#include <sys/stat.h>

namespace {

using palpate::test::ScratchDir;
using palpate::test::data_mesh;

// `text` with its first `from` replaced by `to`, written as `name` in `dir`.
std::filesystem::path write_replaced(ScratchDir& dir, std::string text, const std::string& name,
                                     const std::string& from, const std::string& to) {
  text.replace(text.find(from), from.size(), to);
  return dir.write(name, text);
}

// The message starts with the file's path (for TetGen, the .node or .ele of the same name: the
// error names whichever of the pair is wrong).
bool names_file(const std::string& msg, const std::filesystem::path& file) {
  const std::string ext = file.extension().string();
  if (ext == ".node" || ext == ".ele") {
    std::filesystem::path stem = file;
    stem.replace_extension("");
    return msg.rfind(stem.string() + ".node", 0) == 0 || msg.rfind(stem.string() + ".ele", 0) == 0;
  }
  return msg.rfind(file.string(), 0) == 0;
}

// The message starts with the file's path and contains every one of `parts`.
template <class T>
void expect_error(const palpate::Result<T>& r, const std::filesystem::path& file,
                  std::initializer_list<const char*> parts) {
  ASSERT_FALSE(r.ok()) << file << " loaded but should not";
  const std::string& msg = r.error().message;
  EXPECT_TRUE(names_file(msg, file)) << "message does not start with the file: " << msg;
  for (const char* p : parts) EXPECT_NE(msg.find(p), std::string::npos) << "'" << p << "' not in: " << msg;
}

std::string fmt_row(const Eigen::RowVector3d& r) {
  return std::to_string(r(0)) + " " + std::to_string(r(1)) + " " + std::to_string(r(2)) + "\n";
}

const char* const kSurfaceExts[] = {".obj", ".stl", ".ply", ".off"};
const char* const kTetExts[] = {".msh", ".node", ".ele", ".vtk"};

TEST(MeshErrors, NonexistentFile) {
  ScratchDir dir;
  for (const char* ext : kSurfaceExts) {
    const auto f = dir.path(std::string("missing") + ext);
    expect_error(palpate::load_surface(f), f, {"no such file"});
  }
  for (const char* ext : kTetExts) {
    const auto f = dir.path(std::string("missing") + ext);
    expect_error(palpate::load_tet(f), f, {"no such file"});
  }
}

TEST(MeshErrors, EmptyFile) {
  ScratchDir dir;
  for (const char* ext : kSurfaceExts) {
    const auto f = dir.write(std::string("empty") + ext, "");
    EXPECT_EQ(palpate::load_surface(f).error().message, f.string() + ": empty file");
  }
  for (const char* ext : {".msh", ".vtk"}) {
    const auto f = dir.write(std::string("empty") + ext, "");
    EXPECT_EQ(palpate::load_tet(f).error().message, f.string() + ": empty file");
  }
  const auto node = dir.write("empty.node", ""), ele = dir.write("empty.ele", "");
  EXPECT_EQ(palpate::load_tet(ele).error().message, node.string() + ": empty file");
}

TEST(MeshErrors, UnknownExtensionAndBadScale) {
  ScratchDir dir;
  const auto f = dir.write("cube.xyz123", "hello\n");
  expect_error(palpate::load_surface(f), f, {"unknown surface mesh format '.xyz123'"});
  expect_error(palpate::load_tet(f), f, {"unknown tetrahedral mesh format '.xyz123'"});
  // Formats assimp reads but palpate neither documents nor fuzzes are refused too, readable or not:
  // a Wavefront cube saved under COLLADA's, glTF's and 3DS's extensions never reaches assimp.
  const std::string obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  for (const char* ext : {".dae", ".gltf", ".3ds", ".fbx"}) {
    const auto g = dir.write(std::string("tri") + ext, obj);
    const std::string unknown = std::string("unknown surface mesh format '") + ext + "'";
    expect_error(palpate::load_surface(g), g, {unknown.c_str(), "expected .obj, .stl, .ply or .off"});
  }
  const auto cube = palpate::test::test_mesh("cube.off");
  expect_error(palpate::load_surface(cube, -1.0), cube, {"scale is -1, expected a positive finite factor"});
  expect_error(palpate::load_tet(data_mesh("liver.msh"), 0.0), data_mesh("liver.msh"), {"scale is 0"});
}

TEST(MeshErrors, NanCoordinateNamesTheVertex) {
  ScratchDir dir;
  const auto vtk = dir.write("nan.vtk",
                             "# vtk DataFile Version 3.0\nnan\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 double\n"
                             "0 0 0\n1 0 0\n0 1 0\n0 0 nan\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\n");
  EXPECT_EQ(palpate::load_tet(vtk).error().message, vtk.string() + ": vertex 3 has a non-finite coordinate (0, 0, nan)");
  dir.write("inf.node", "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 inf 0\n3 0 0 1\n");
  const auto ele = dir.write("inf.ele", "1 4 0\n0 0 1 2 3\n");
  // The error names the path the caller gave.
  EXPECT_EQ(palpate::load_tet(ele).error().message, ele.string() + ": vertex 2 has a non-finite coordinate (0, inf, 0)");
  palpate::SurfaceMesh m = palpate::test::cube_surface();
  m.V(5, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(palpate::validate(m, "cube.obj").error().message, "cube.obj: vertex 5 has a non-finite coordinate (1, nan, 1)");
}

TEST(MeshErrors, IndexOutOfRangeNamesElementIndexAndRange) {
  // In memory: the message of the design brief, word for word.
  palpate::SurfaceMesh m;
  m.V = palpate::RowMat3d::Random(181, 3);
  m.F = palpate::RowMat3i::Zero(20, 3);
  for (int f = 0; f < 20; ++f) m.F.row(f) << f, f + 1, f + 2;
  m.F(17, 1) = 999;
  EXPECT_EQ(palpate::validate(m, "liver.obj").error().message,
            "liver.obj: triangle 17 has vertex index 999 out of range [0, 181)");
  palpate::TetMesh t = palpate::test::cube_tets();
  t.T(3, 2) = -1;
  EXPECT_EQ(palpate::validate(t, "cube.msh").error().message,
            "cube.msh: tetrahedron 3 has vertex index -1 out of range [0, 8)");

  // In files: the reader names the line.
  ScratchDir dir;
  const auto vtk = dir.write("range.vtk",
                             "# vtk DataFile Version 3.0\nrange\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 double\n"
                             "0 0 0\n1 0 0\n0 1 0\n0 0 1\nCELLS 2 10\n4 0 1 2 3\n4 0 1 2 4\nCELL_TYPES 2\n10 10\n");
  EXPECT_EQ(palpate::load_tet(vtk).error().message, vtk.string() + ":12: cell 1 has point index 4 out of range [0, 4)");
  dir.write("range.node", "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n");
  const auto ele = dir.write("range.ele", "2 4 0\n1 1 2 3 4\n# a comment line\n2 1 2 3 9\n");
  EXPECT_EQ(palpate::load_tet(ele).error().message,
            ele.string() + ":4: tetrahedron 2 has node 9, expected a node number in [1, 5)");
  const auto msh = dir.write("range.msh",
                             "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n"
                             "$EndNodes\n$Elements\n1\n1 4 2 1 1 1 2 3 9\n$EndElements\n");
  EXPECT_EQ(palpate::load_tet(msh).error().message,
            msh.string() + ":13: $Elements: element 1 names node 9, which $Nodes does not define");
  const auto obj = dir.write("range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 7\n");
  expect_error(palpate::load_surface(obj), obj, {});
  const auto off = dir.write("range.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n");
  EXPECT_EQ(palpate::load_surface(off).error().message, off.string() + ":6: face 0 has vertex index 5 out of range [0, 3)");
}

TEST(MeshErrors, DegenerateAndInvertedTetrahedra) {
  ScratchDir dir;
  // Tetrahedron 1 is flat: its fourth vertex lies in the plane of the other three.
  const auto flat = dir.write("flat.vtk",
                              "# vtk DataFile Version 3.0\nflat\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 5 double\n"
                              "0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 1 0\nCELLS 2 10\n4 0 1 2 3\n4 0 1 2 4\nCELL_TYPES 2\n10 10\n");
  expect_error(palpate::load_tet(flat), flat, {": tetrahedron 1 (vertices 0, 1, 2, 4) is degenerate: volume 0"});
  // Tetrahedron 1 has two corners swapped.
  dir.write("inv.node", "5 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n4 1 1 1\n");
  const auto inv = dir.write("inv.ele", "2 4 0\n0 0 1 2 3\n1 1 2 4 3\n");
  EXPECT_EQ(palpate::load_tet(inv).error().message,
            inv.string() + ": tetrahedron 1 (vertices 1, 2, 4, 3) is inverted: volume -0.333333 < 0, expected "
                           "(v1-v0)·((v2-v0)×(v3-v0)) > 0");
  // Repeated vertex: zero volume however the tolerance is chosen.
  palpate::TetMesh t = palpate::test::cube_tets();
  t.T(4, 3) = t.T(4, 0);
  expect_error(palpate::Result<int>(palpate::validate(t, "cube").error()), "cube", {"tetrahedron 4", "degenerate"});
}

TEST(MeshErrors, DegenerateTriangle) {
  ScratchDir dir;
  const auto obj = dir.write("sliver.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\n");
  expect_error(palpate::load_surface(obj), obj, {": triangle 1 (vertices 0, 1, 3) is degenerate: area 0"});
}

TEST(MeshErrors, NonManifoldEdgeWhenManifoldIsRequired) {
  ScratchDir dir;
  // Three triangles hinge on the edge (0, 1).
  const auto fan = dir.write("fan.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n");
  EXPECT_TRUE(palpate::load_surface(fan).ok());  // readable when nothing more is asked
  EXPECT_EQ(palpate::load_surface(fan, 1.0, {.manifold = true}).error().message,
            fan.string() + ": non-manifold edge (0, 1): shared by 3 triangles (0, 1, 2), expected at most 2");
  // Two triangles traverse the edge (0, 1) the same way: one is flipped.
  const auto flip = dir.write("flip.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nf 1 2 3\nf 1 2 4\n");
  EXPECT_EQ(palpate::load_surface(flip, 1.0, {.manifold = true}).error().message,
            flip.string() + ": non-manifold edge (0, 1): triangles 0 and 1 traverse it in the same direction "
                            "(inconsistent orientation)");
}

TEST(MeshErrors, OpenSurfaceWhenClosedIsRequired) {
  ScratchDir dir;
  // The cube without its top (two triangles): 4 boundary edges.
  std::string off = "OFF\n8 10 0\n";
  const palpate::SurfaceMesh cube = palpate::test::cube_surface();
  for (int v = 0; v < 8; ++v) off += fmt_row(cube.V.row(v));
  for (int f = 0; f < 12; ++f)
    if (f != 2 && f != 3) off += "3 " + std::to_string(cube.F(f, 0)) + " " + std::to_string(cube.F(f, 1)) + " " +
                                 std::to_string(cube.F(f, 2)) + "\n";
  const auto f = dir.write("open.off", off);
  EXPECT_TRUE(palpate::load_surface(f, 1.0, {.manifold = true}).ok());
  expect_error(palpate::load_surface(f, 1.0, {.closed = true}), f,
               {": open surface: 4 boundary edges, e.g. edge (", "expected a closed surface"});
}

TEST(MeshErrors, TruncatedFiles) {
  ScratchDir dir;
  const auto cut = [&](const std::filesystem::path& from, const std::string& name, double fraction) {
    const std::string text = palpate::test::read_text(from);
    const size_t at = static_cast<size_t>(fraction * static_cast<double>(text.size()));
    return dir.write(name, text.substr(0, text.rfind('\n', at) + 1));  // cut after a whole line
  };
  const auto vtk = cut(data_mesh("liver_tet.vtk"), "liver.vtk", 0.5);
  expect_error(palpate::load_tet(vtk), vtk, {"unexpected end of file, expected a cell's point"});
  const auto vtk_points = cut(data_mesh("liver_tet.vtk"), "points.vtk", 0.2);
  expect_error(palpate::load_tet(vtk_points), vtk_points, {"unexpected end of file, expected a point coordinate"});
  // So short that the promised count cannot fit: refused before any memory is sized by it.
  const auto vtk_short = cut(data_mesh("liver_tet.vtk"), "short.vtk", 0.05);
  EXPECT_EQ(palpate::load_tet(vtk_short).error().message,
            vtk_short.string() + ":5: the number of points is 181, more than the file can hold");
  const auto msh = cut(data_mesh("liver.msh"), "liver.msh", 0.5);
  EXPECT_EQ(palpate::load_tet(msh).error().message,
            msh.string() + ":383: $ELM: expected element 197 of 596 (number, type, regions, node count, nodes)");
  dir.write("liver.node", palpate::test::read_text(data_mesh("liver_tet.node")));
  const auto ele = cut(data_mesh("liver_tet.ele"), "liver.ele", 0.9);
  expect_error(palpate::load_tet(ele), ele, {"unexpected end of file, expected tetrahedron"});
  const auto ply = cut(palpate::test::test_mesh("cube.ply"), "cube.ply", 0.8);
  expect_error(palpate::load_surface(ply), ply, {});
  const auto off = cut(palpate::test::test_mesh("cube.off"), "cube.off", 0.8);
  expect_error(palpate::load_surface(off, 1.0, {.closed = true}), off, {});
  // Binary STL of 12 triangles cut inside the 5th.
  std::string stl(80, ' ');
  stl += std::string("\x0c\x00\x00\x00", 4) + std::string(4 * 50 + 20, '\0');
  const auto bin = dir.write("cut.stl", stl);
  expect_error(palpate::load_surface(bin), bin, {});
}

TEST(MeshErrors, WrongHeader) {
  PALPATE_NEEDS(GMSH, "Gmsh");
  ScratchDir dir;
  const auto vtk = dir.write("wrong.vtk", "# vtk DataFile\nx\nASCII\nDATASET UNSTRUCTURED_GRID\n");
  EXPECT_EQ(palpate::load_tet(vtk).error().message,
            vtk.string() + ":1: expected the legacy VTK header '# vtk DataFile Version', found '# vtk DataFile'");
  const auto poly = dir.write("poly.vtk", "# vtk DataFile Version 2.0\nx\nASCII\nDATASET POLYDATA\nPOINTS 0 float\n");
  EXPECT_EQ(palpate::load_tet(poly).error().message,
            poly.string() + ":4: expected DATASET UNSTRUCTURED_GRID, found DATASET POLYDATA (only tetrahedral grids "
                            "are read)");
  const auto bin = dir.write("bin.vtk", "# vtk DataFile Version 2.0\nx\nBINARY\nDATASET UNSTRUCTURED_GRID\n");
  EXPECT_EQ(palpate::load_tet(bin).error().message, bin.string() + ":3: binary VTK files are not supported, expected ASCII");
  const auto msh = dir.write("wrong.msh", "Merge \"other.stl\";\n");
  EXPECT_EQ(palpate::load_tet(msh).error().message,
            msh.string() + ":1: expected a Gmsh mesh header ($MeshFormat, or $NOD for format 1), found 'Merge "
                           "\"other.stl\";'");
  const auto version = dir.write("version.msh", "$MeshFormat\n9.9 0 8\n$EndMeshFormat\n");
  expect_error(palpate::load_tet(version), version, {"Gmsh could not read the mesh: Unknown MSH file version 9.9"});
  const auto node = dir.write("wrong.node", "points 3 0 0\n");
  dir.write("wrong.ele", "1 4 0\n");
  EXPECT_EQ(palpate::load_tet(node).error().message,
            node.string() + ":1: expected the number of points (an integer) as value 1, found 'points'");
  const auto dim = dir.write("dim.node", "# 2-D\n\n3 2 0 0\n");
  dir.write("dim.ele", "1 4 0\n");
  EXPECT_EQ(palpate::load_tet(dim).error().message, dim.string() + ":3: expected dimension 3, found 2");
  const auto ply = dir.write("wrong.ply", "plx\nformat ascii 1.0\nend_header\n");
  EXPECT_EQ(palpate::load_surface(ply).error().message, ply.string() + ":1: expected the PLY magic line 'ply'");
  // A header that never ends (assimp 5.2 would loop forever on it): a damaged end_header line is
  // named where it stands, a header cut short at the end of the file.
  const auto endless = dir.write("endless.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_head/r\n0\n");
  EXPECT_EQ(palpate::load_surface(endless).error().message,
            endless.string() + ":5: expected comment, obj_info, element, property or end_header, found 'end_head/r'");
  const auto cut_short = dir.write("cut_short.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n");
  EXPECT_EQ(palpate::load_surface(cut_short).error().message,
            cut_short.string() + ":4: unexpected end of file, expected 'end_header' to close the PLY header");
  const auto off = dir.write("wrong.off", "OFX\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_EQ(palpate::load_surface(off).error().message, off.string() + ":1: expected the OFF header line 'OFF'");
}

// Damaged Gmsh files that crashed Gmsh 4.8 itself (found by fuzzing) are refused before it reads them.
TEST(MeshErrors, GmshFilesThatWouldCrashGmsh) {
  PALPATE_NEEDS(GMSH, "Gmsh");
  ScratchDir dir;
  const std::string v4 = palpate::test::read_text(palpate::test::test_mesh("cube_v4.msh"));
  const auto replaced = [&](const std::string& name, const std::string& from, const std::string& to) {
    return write_replaced(dir, v4, name, from, to);
  };
  // The $Nodes header promises 1 node, its blocks hold 8 (Gmsh wrote past its array).
  const auto total = replaced("total.msh", "$Nodes\n2 8 1 8", "$Nodes\n2 1 1 8");
  EXPECT_EQ(palpate::load_tet(total).error().message,
            total.string() + ":11: $Nodes: block 0 ('2 1 0 4') does not fit the header's total of 1");
  // A section name run together with the next line (Gmsh segfaulted): Gmsh takes the line for
  // $Nodes by its prefix and reads the section from the line after, whose first block then does
  // not fit the total it read.
  const auto joined = replaced("joined.msh", "$Nodes\n2 8 1 8", "$Nodes02 8 1 8");
  EXPECT_EQ(palpate::load_tet(joined).error().message,
            joined.string() + ":14: $Nodes: block 0 ('1 2 3 4') does not fit the header's total of 1");
  // Tags up to 10^12 (Gmsh sizes a dense array by the largest tag).
  const auto tags = replaced("tags.msh", "$Nodes\n2 8 1 8", "$Nodes\n2 8 1 1000000000000");
  EXPECT_EQ(palpate::load_tet(tags).error().message,
            tags.string() + ":10: $Nodes tags run from 1 to 1000000000000, beyond the file's size (expected 0 to at "
                            "most 1000000)");
  // The smallest tag far out of range too (found by fuzzing: 8e63 overflowed palpate's own conversion).
  const auto low = replaced("low.msh", "$Nodes\n2 8 1 8", "$Nodes\n2 8 8e63 8");
  EXPECT_EQ(palpate::load_tet(low).error().message,
            low.string() + ":10: $Nodes tags run from 8e+63 to 8, beyond the file's size (expected 0 to at most 1000000)");
  const auto many = replaced("many.msh", "$Elements\n2 7 1 7", "$Elements\n2 7000000000 1 7");
  EXPECT_EQ(palpate::load_tet(many).error().message,
            many.string() + ":31: $Elements promises 7000000000 elements, more than the file can hold");
  // Binary: one byte cut out of the nodes shifts every later field.
  std::string bin = palpate::test::read_text(palpate::test::test_mesh("cube_v4_binary.msh"));
  bin.erase(bin.find("$Nodes") + 60, 1);
  const auto cut = dir.write("cut.msh", bin);
  expect_error(palpate::load_tet(cut), cut, {"$Nodes (binary"});
  // Binary: an element's node tag far outside the nodes' range (Gmsh segfaulted).
  std::string far = palpate::test::read_text(palpate::test::test_mesh("cube_v4_binary.msh"));
  far[919] = '\xcb';  // high byte of the last element's last node tag
  const auto far_node = dir.write("far.msh", far);
  expect_error(palpate::load_tet(far_node), far_node, {"$Elements (binary", "outside the $Nodes range [1, 8]"});
  // An entity promising 10^12 bounding entities, and 4·10^9 ghost entities of a partitioned mesh
  // (Gmsh sizes arrays by such counts before reading what they promise).
  const auto bounds = replaced("bounds.msh", "1 0 0 0 1 1 1 1 2 0", "1 0 0 0 1 1 1 1 2 1000000000000");
  EXPECT_EQ(palpate::load_tet(bounds).error().message,
            bounds.string() + ":7: $Entities: promises 1000000000000 bounding entities of an entity, more than the "
                              "file can hold");
  const auto ghosts = replaced("ghosts.msh", "$Entities\n", "$PartitionedEntities\n2\n4000000000\n");
  EXPECT_EQ(palpate::load_tet(ghosts).error().message,
            ghosts.string() + ":6: $PartitionedEntities: promises 4000000000 ghost entities, more than the file can hold");
  // Binary: the surface's count of physical tags raised to 6.9·10^10 (found by fuzzing: Gmsh asked
  // for 141 GB).
  std::string phys = palpate::test::read_text(palpate::test::test_mesh("cube_v4_binary.msh"));
  phys[phys.find("$Entities\n") + 10 + 84 + 4] = '\x10';
  const auto physicals = dir.write("physicals.msh", phys);
  expect_error(palpate::load_tet(physicals), physicals,
               {"$Entities (binary", "promises 68719476737 physical tags of an entity, more than the file can hold"});
  // Format 2, binary (the fuzz seed): an element block promising 2·10^9 tags per element (Gmsh
  // asked for 7.8 GB), and an element count that is not a number (found by fuzzing: '+').
  const std::string v2b = palpate::test::read_text(PALPATE_SOURCE_DIR "/fuzz/corpus/fuzz_gmsh/cube_v2_binary.msh");
  ASSERT_TRUE(palpate::load_tet(dir.write("v2b.msh", v2b)).ok());
  std::string huge_tags = v2b;
  const size_t block = huge_tags.find("$Elements\n5\n") + 12;
  const std::int32_t two_billion = 2000000000;
  std::memcpy(huge_tags.data() + block + 8, &two_billion, 4);
  const auto tags2 = dir.write("tags2.msh", huge_tags);
  expect_error(palpate::load_tet(tags2), tags2,
               {"$Elements (binary, byte 12 of the section): block 0 (5 elements of type 4 with 2000000000 tags "
                "each) does not fit the file or the total of 5"});
  std::string plus = v2b;
  plus.replace(plus.find("$Elements\n5\n"), 12, "$Elements\n+\n");
  const auto no_count = dir.write("plus.msh", plus);
  expect_error(palpate::load_tet(no_count), no_count, {"expected the number of elements after $Elements"});
  // A format-4 body under a "2.2" header: its elements name nodes the format-2 reading of $Nodes
  // never defined (Gmsh dereferenced a null node: `palpate info` crashed; found by fuzzing).
  std::string relabelled = v4;
  relabelled.replace(relabelled.find("4.1 0 8"), 7, "2.2 0 8");
  const auto as_v2 = dir.write("as_v2.msh", relabelled);
  expect_error(palpate::load_tet(as_v2), as_v2, {"$Elements: ", "which $Nodes does not define"});
  // Binary with its byte-order check damaged (Gmsh then byte-swaps every count; found by fuzzing).
  std::string order = palpate::test::read_text(palpate::test::test_mesh("cube_v4_binary.msh"));
  order[order.find("4.1 1 8\n") + 10] = '\xff';
  const auto swapped = dir.write("swapped.msh", order);
  EXPECT_EQ(palpate::load_tet(swapped).error().message,
            swapped.string() + ":3: binary mesh whose byte-order check reads 16711681 (expected the int 1: a "
                               "big-endian or damaged file; palpate reads little-endian binary meshes)");
  // Formats 1 and 2 are walked as Gmsh's fgets finds their sections (found by fuzzing: binary data
  // ending in "\n\xa5$Nodes" hid an element block palpate's line scan passed over and Gmsh read,
  // asking for 2.16 GB; tests/data/fuzz-regressions/fuzz_gmsh/damaged-section-lines.msh). Gmsh
  // takes a section by its name's prefix, and a line longer than 255 bytes as several: an element
  // naming a node no $Nodes defines is found behind either.
  const std::string v2 = palpate::test::read_text(palpate::test::test_mesh("cube_v2.msh"));
  ASSERT_TRUE(palpate::load_tet(dir.write("v2.msh", v2)).ok());
  const auto v2_with = [&](const std::string& name, const std::string& elements_line) {
    std::string text = v2;
    text.replace(text.find("$Elements\n"), 10, elements_line);
    text.replace(text.find("7 4 2 2 1 7 3 8 5"), 17, "7 4 2 2 1 7 3 8 99");
    return dir.write(name, text);
  };
  const auto prefix = v2_with("prefix.msh", "$ElementsOfTheCube\n");
  EXPECT_EQ(palpate::load_tet(prefix).error().message,
            prefix.string() + ":23: $ElementsOfTheCube: element 7 names node 99, which $Nodes does not define");
  const auto long_line = v2_with("long_line.msh", std::string(255, '#') + "$Elements\n");
  EXPECT_EQ(palpate::load_tet(long_line).error().message,
            long_line.string() + ":23: $Elements: element 7 names node 99, which $Nodes does not define");
  // A partition in a format-2 element's tags (Gmsh 4.8 converts old partitions and crashed on a
  // damaged one: `palpate info` segfaulted; found by fuzzing).
  const auto partitioned = dir.write("partitioned.msh", std::string(v2).replace(v2.find("1 2 2 1 1 1 3 4"), 15,
                                                                                 "1 2 3 1 1 2 1 3 4"));
  EXPECT_EQ(palpate::load_tet(partitioned).error().message,
            partitioned.string() + ":17: $Elements: element 1 has partition or parent tag 2: palpate reads format-2 "
                                   "meshes without partitions (save as format 4.1)");
  // MSH3 and post-processing views are refused, not guessed at.
  const auto msh3 = dir.write("msh3.msh", std::string(v2).replace(v2.find("2.2 0 8"), 7, "3 0 8"));
  expect_error(palpate::load_tet(msh3), msh3, {"Gmsh mesh format 3 (MSH3) is not read; save the mesh in format 4.1 or 2.2"});
  const auto view = dir.write("view.msh", v2 + "$NodeData\n1\n\"u\"\n$EndNodeData\n");
  EXPECT_EQ(palpate::load_tet(view).error().message,
            view.string() + ":25: $NodeData: post-processing data is not read; save the mesh without it");
  const auto view4 = dir.write("view4.msh", v4 + "$ElementData\n1\n\"u\"\n$EndElementData\n");
  expect_error(palpate::load_tet(view4), view4, {"$ElementData: post-processing data is not read; save the mesh without it"});
  // Gmsh still reads good files after all of these.
  EXPECT_TRUE(palpate::load_tet(palpate::test::test_mesh("cube_v4.msh")).ok());
  EXPECT_TRUE(palpate::load_tet(palpate::test::test_mesh("cube_v4_binary.msh")).ok());
}

// Random bytes, and valid files with random bytes overwritten, under every extension: each
// either loads and validates or fails with a message that starts with the file name. Never a crash.
TEST(MeshErrors, GarbageNeverCrashes) {
  ScratchDir dir;
  std::mt19937 rng(20240611);
  std::uniform_int_distribution<int> byte(0, 255);
  const auto random_bytes = [&](size_t n) {
    std::string s(n, '\0');
    for (char& c : s) c = static_cast<char>(byte(rng));
    return s;
  };
  const auto check_surface = [&](const std::filesystem::path& f) {
    const auto r = palpate::load_surface(f);
    if (r.ok()) EXPECT_TRUE(palpate::validate(*r, f.string()).ok());
    else EXPECT_TRUE(names_file(r.error().message, f)) << r.error().message;
  };
  const auto check_tet = [&](const std::filesystem::path& f) {
    const auto r = palpate::load_tet(f);
    if (r.ok()) EXPECT_TRUE(palpate::validate(*r, f.string()).ok());
    else EXPECT_TRUE(names_file(r.error().message, f)) << r.error().message;
  };
  for (int round = 0; round < 4; ++round) {
    for (const char* ext : kSurfaceExts) check_surface(dir.write("random" + std::to_string(round) + ext, random_bytes(1000)));
    for (const char* ext : kTetExts) {
      const std::string stem = "random" + std::to_string(round);
      dir.write(stem + ".node", random_bytes(500));
      dir.write(stem + ".ele", random_bytes(500));
      check_tet(dir.write(stem + ext, random_bytes(1000)));
    }
  }
  // Mutants: a valid file with a few bytes replaced by random printable characters.
  const std::pair<std::filesystem::path, bool> sources[] = {
      {palpate::test::test_mesh("cube_ascii.stl"), false}, {palpate::test::test_mesh("cube.ply"), false},
      {palpate::test::test_mesh("cube.off"), false},       {palpate::test::test_mesh("cube_v2.msh"), true},
      {palpate::test::test_mesh("cube_v4.msh"), true},     {palpate::test::test_mesh("cube_v4_binary.msh"), true},
      {data_mesh("liver_tet.vtk"), true},                {data_mesh("liver.obj"), false}};
  std::uniform_int_distribution<int> printable(32, 126);
  for (const auto& [source, tet] : sources) {
    const std::string text = palpate::test::read_text(source);
    ASSERT_FALSE(text.empty()) << source;  // a mutant needs bytes to replace
    for (int round = 0; round < 12; ++round) {
      std::string mutant = text;
      std::uniform_int_distribution<size_t> at(0, mutant.size() - 1);
      for (int k = 0; k < 3; ++k) mutant[at(rng)] = static_cast<char>(round % 2 ? printable(rng) : byte(rng));
      const auto f = dir.write("mutant" + std::to_string(round) + source.extension().string(), mutant);
      SCOPED_TRACE(source.string() + " mutant " + std::to_string(round));
      if (tet) check_tet(f);
      else check_surface(f);
    }
  }
  // TetGen mutants, .node and .ele each.
  const std::string node = palpate::test::read_text(palpate::test::test_mesh("cube_1based.node"));
  const std::string ele = palpate::test::read_text(palpate::test::test_mesh("cube_1based.ele"));
  for (int round = 0; round < 12; ++round) {
    std::string n = node, e = ele;
    std::string& target = round % 2 ? n : e;
    std::uniform_int_distribution<size_t> at(0, target.size() - 1);
    for (int k = 0; k < 2; ++k) target[at(rng)] = static_cast<char>(printable(rng));
    dir.write("tg" + std::to_string(round) + ".node", n);
    check_tet(dir.write("tg" + std::to_string(round) + ".ele", e));
  }
}

}  // namespace

// A PLY header's element counts are checked against what follows it before assimp reads the file
// (it trusted them: a 312-byte cube claiming 100,000,000 vertices ran for over a minute and
// 1.3 GB; claiming 1,000,000 it "read" a mesh the file does not hold).
TEST(MeshErrors, PlyCountsBeyondTheFileAreRefused) {
  ScratchDir dir;
  const std::string cube = palpate::test::read_text(palpate::test::test_mesh("cube.ply"));
  const auto claiming = [&](const std::string& name, const std::string& from, const std::string& to) {
    return write_replaced(dir, cube, name, from, to);
  };
  const auto huge = claiming("huge.ply", "element vertex 8", "element vertex 100000000");
  EXPECT_EQ(palpate::load_surface(huge).error().message,
            huge.string() + ":4: element vertex claims 100000000 but the file holds data for at most 18 (54 numbers "
                            "after the header)");
  const auto million = claiming("million.ply", "element vertex 8", "element vertex 1000000");
  EXPECT_NE(palpate::load_surface(million).error().message.find(":4: element vertex claims 1000000"), std::string::npos);
  const auto faces = claiming("faces.ply", "element face 6", "element face 100000");
  EXPECT_EQ(palpate::load_surface(faces).error().message,
            faces.string() + ":8: element face claims 100000 but the file holds data for at most 30 (54 numbers "
                             "after the header)");
  const auto negative = claiming("negative.ply", "element face 6", "element face -6");
  EXPECT_NE(palpate::load_surface(negative).error().message.find(":8: element face: expected a count >= 0, found '-6'"),
            std::string::npos);
  // Binary: 8 vertices of 3 floats and 6 quads need at least 8·12 + 6·1 bytes.
  std::string bin = "ply\nformat binary_little_endian 1.0\nelement vertex 5000\nproperty float x\nproperty float y\n"
                    "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  bin += std::string(12 * 3 + 1 + 12, '\0');
  const auto binary = dir.write("binary.ply", bin);
  EXPECT_EQ(palpate::load_surface(binary).error().message,
            binary.string() + ":3: element vertex claims 5000 but the file holds data for at most 4 (49 bytes after "
                              "the header)");
  // The true counts still load.
  auto ok = palpate::load_surface(palpate::test::test_mesh("cube.ply"));
  ASSERT_TRUE(ok.ok()) << ok.error().message;
  EXPECT_EQ(ok->V.rows(), 8);
}

// assimp 5.2 sizes its vertex and face arrays by the first vertex and face elements and writes
// later ones into them (found by fuzzing: ASan's heap check failed inside assimp; valgrind showed
// the write past the array): a PLY header and body are walked as assimp reads them first.
TEST(MeshErrors, PlyStructureAssimpWouldMisreadIsRefused) {
  ScratchDir dir;
  const std::string cube = palpate::test::read_text(palpate::test::test_mesh("cube.ply"));
  const auto with = [&](const std::string& name, const std::string& from, const std::string& to) {
    return write_replaced(dir, cube, name, from, to);
  };
  const std::string xyz = "property float x\nproperty float y\nproperty float z\n";
  const auto two_vertex = with("two_vertex.ply", "element face 6",
                               "element vertex 0\n" + xyz + "element face 6");
  EXPECT_EQ(palpate::load_surface(two_vertex).error().message,
            two_vertex.string() + ":8: a second 'element vertex' (assimp writes it into the first one's array)");
  const auto two_face = with("two_face.ply", "end_header",
                             "element tristrips 0\nproperty list int int vertex_indices\nend_header");
  EXPECT_EQ(palpate::load_surface(two_face).error().message,
            two_face.string() + ":10: a second face element 'tristrips' (assimp writes it into the first one's array)");
  const auto format = with("format.ply", "format ascii 1.0", "format asci 1.0");
  EXPECT_EQ(palpate::load_surface(format).error().message,
            format.string() + ":2: expected 'format ascii 1.0' (or binary_little_endian, binary_big_endian), found "
                              "'format asci 1.0'");
  const auto type = with("type.ply", "property float y", "property flaot y");
  EXPECT_NE(palpate::load_surface(type).error().message.find(":6: property 'property flaot y': unknown type"),
            std::string::npos);
  const auto junk = with("junk.ply", "property float z", "prat z");
  EXPECT_EQ(palpate::load_surface(junk).error().message,
            junk.string() + ":7: expected comment, obj_info, element, property or end_header, found 'prat z'");
  const auto comment = with("comment.ply", "property float y", "comment y next\nproperty float y");
  EXPECT_EQ(palpate::load_surface(comment).error().message,
            comment.string() + ":7: a property after a comment or obj_info line (assimp 5.2 ends the element's "
                               "properties at such a line and drops the rest)");
  // The body: a face line with a missing index, a vertex line with an extra value.
  const auto short_face = with("short_face.ply", "4 0 2 3 1", "4 0 2 3");
  EXPECT_NE(palpate::load_surface(short_face).error().message.find(": element face 0: expected 4 int values for "
                                                                     "'vertex_indices'"),
            std::string::npos);
  const auto long_vertex = with("long_vertex.ply", "0 0 0", "0 0 0 7");
  EXPECT_NE(palpate::load_surface(long_vertex).error().message.find(": element vertex 0: 4 values on the line, its "
                                                                      "properties take 3"),
            std::string::npos);
  ASSERT_TRUE(palpate::load_surface(palpate::test::test_mesh("cube.ply")).ok());
}

// assimp 5.2 reads an OFF file's vertex and face lines without skipping comments, and counts its
// face total down for every line that is not a face of 1 to 9 vertices — below zero when comment
// lines follow too few faces (found by fuzzing: `palpate info` segfaulted). The file is walked as
// assimp reads it first.
TEST(MeshErrors, OffLinesAssimpWouldMisreadAreRefused) {
  ScratchDir dir;
  const std::string tri = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n";
  const auto comments = dir.write("comments.off", "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n# a\n# b\n# c\n");
  EXPECT_EQ(palpate::load_surface(comments).error().message,
            comments.string() + ":7: face 1: expected '<n> <n vertex indices>' with n from 3 to 9, found '# a'");
  const auto among = dir.write("among.off", "OFF\n3 1 0\n0 0 0\n# the second vertex\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_EQ(palpate::load_surface(among).error().message,
            among.string() + ":4: vertex 1 of 3: expected 'x y z', found '# the second vertex'");
  const auto ten = dir.write("ten.off", tri + "10 0 1 2 0 1 2 0 1 2 0\n");
  EXPECT_NE(palpate::load_surface(ten).error().message.find(":6: face 0: expected '<n> <n vertex indices>' with n "
                                                            "from 3 to 9"),
            std::string::npos);
  const auto lone_cr = dir.write("lone_cr.off", tri + "3 0 1\r2\n");
  EXPECT_NE(palpate::load_surface(lone_cr).error().message.find("a NUL, form feed or lone carriage return"),
            std::string::npos);
  const auto variant = dir.write("variant.off", "4OFF\n3 1 0\n0 0 0 1\n1 0 0 1\n0 1 0 1\n3 0 1 2\n");
  EXPECT_EQ(palpate::load_surface(variant).error().message,
            variant.string() + ":1: OFF variant '4OFF' is not read (expected OFF, COFF, NOFF, CNOFF or STOFF)");
  // Comments and blank lines before the vertices, CRLF line ends and a count line split over lines still load.
  const auto fine = dir.write("fine.off", "# made by hand\r\nOFF\r\n# counts\r\n3\r\n1 0\r\n\r\n# first vertex next\r\n"
                                          "0 0 0\r\n1 0 0\r\n0 1 0\r\n3 0 1 2\r\n# trailing comment\r\n");
  auto m = palpate::load_surface(fine);
  ASSERT_TRUE(m.ok()) << m.error().message;
  EXPECT_EQ(m->F.rows(), 1);
}

// An OBJ's mtllib is read only as a regular file beside the mesh: a FIFO blocked the load forever,
// /dev/zero was read without end, another directory's file was opened. The mesh loads without it.
TEST(MeshErrors, ObjMaterialLibrariesOnlyBesideTheMesh) {
  ScratchDir dir;
  const std::filesystem::path fifo = dir.path("pipe.mtl");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  dir.write("good.mtl", "newmtl skin\nKd 1 0.8 0.7\n");
  const std::string tet = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
  for (const std::string lib : {"pipe.mtl", "/dev/zero", "/etc/passwd", "../../../../../dev/zero", "good.mtl",
                                "missing.mtl"}) {
    const auto obj = dir.write("tet.obj", "mtllib " + lib + "\nusemtl skin\n" + tet);
    auto m = palpate::load_surface(obj);
    ASSERT_TRUE(m.ok()) << lib << ": " << m.error().message;
    EXPECT_EQ(m->V.rows(), 4) << lib;
    EXPECT_EQ(m->F.rows(), 4) << lib;
  }
}
