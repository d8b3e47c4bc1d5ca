// mesh_test_files.h — helpers for the mesh tests: data paths, a scratch folder, the unit cube.
#pragma once

#include <palpate/mesh.h>

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <unistd.h>

namespace palpate::test {

inline std::filesystem::path data_mesh(const std::string& name) {
  return std::filesystem::path(PALPATE_DATA_DIR) / "meshes" / name;
}
inline std::filesystem::path test_mesh(const std::string& name) {
  return std::filesystem::path(PALPATE_TEST_DATA_DIR) / "meshes" / name;
}

// A fresh folder per test for files the test writes itself; removed afterwards.
class ScratchDir {
 public:
  ScratchDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = std::filesystem::temp_directory_path() /
           ("palpate_mesh_" + std::to_string(::getpid()) + "_" + info->test_suite_name() + "_" + info->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  ~ScratchDir() {
    if (std::getenv("PALPATE_KEEP_SCRATCH")) return;  // for looking at what a failing test wrote
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;

  std::filesystem::path write(const std::string& name, const std::string& bytes) const {
    const auto path = dir_ / name;
    std::ofstream(path, std::ios::binary) << bytes;
    return path;
  }
  std::filesystem::path path(const std::string& name) const { return dir_ / name; }

 private:
  std::filesystem::path dir_;
};

// The unit cube [0,1]³: vertex i at (i&1, (i>>1)&1, (i>>2)&1).
inline RowMat3d cube_vertices() {
  RowMat3d V(8, 3);
  for (int i = 0; i < 8; ++i) V.row(i) << (i & 1), (i >> 1) & 1, (i >> 2) & 1;
  return V;
}
// Its 12 boundary triangles, counter-clockwise seen from outside.
inline SurfaceMesh cube_surface() {
  SurfaceMesh m;
  m.V = cube_vertices();
  m.F.resize(12, 3);
  m.F << 0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6, 0, 1, 5, 0, 5, 4, 2, 6, 7, 2, 7, 3, 0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5;
  compute_normals(m);
  return m;
}
// Five positively oriented tetrahedra filling it (a central one of volume 1/3, four corners of 1/6).
inline TetMesh cube_tets() {
  TetMesh m;
  m.V = cube_vertices();
  m.T.resize(5, 4);
  m.T << 1, 2, 4, 7, 0, 1, 2, 4, 3, 2, 1, 7, 5, 1, 4, 7, 6, 2, 7, 4;
  return m;
}

inline std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

}  // namespace palpate::test
