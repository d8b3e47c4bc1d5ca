// test_memory_estimates.cpp — what cannot fit in memory is refused at load, naming the key, the
// count and the memory: a scene file too large to parse (1,000,000 waypoints), waypoints, a
// trajectory, a charged patch laid on a mesh too finely, a mass-spring tissue's all-pairs springs
// and a dense (desbrun) predictor's n² doubles. PALPATE_MEMORY_LIMIT stands for a smaller machine.
#include <palpate/scene.h>
#include <palpate/tissue.h>
#include <palpate/tissue_files.h>

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

namespace fs = std::filesystem;

namespace {

// PALPATE_MEMORY_LIMIT set for one scope.
struct MemoryLimit {
  explicit MemoryLimit(const char* bytes) { ::setenv("PALPATE_MEMORY_LIMIT", bytes, 1); }
  ~MemoryLimit() { ::unsetenv("PALPATE_MEMORY_LIMIT"); }
};

std::string tissue_error(const std::string& yaml) {
  const fs::path dir = fs::temp_directory_path() / "palpate_test_memory_estimates";
  fs::create_directories(dir);
  auto s = palpate::parse_scene("output: " + dir.string() + "\n" + yaml, "m.yaml", dir);
  if (!s) return s.error().message;
  for (int i = 0; i < int(s->tissues.size()); ++i)
    if (auto t = palpate::make_tissue(*s, i); !t) return t.error().message;
  return "";
}

}  // namespace

// The scene of 1,000,000 waypoints (52 MB of YAML: 3.9 GB and 3 minutes in the parser on
// the test machine) where 2 GB may be used: refused before it is parsed, naming the file, its size
// and lines, the memory, and where long paths belong.
TEST(MemoryEstimates, ASceneFileTooLargeToParseIsRefusedBeforeParsing) {
  const fs::path p = fs::temp_directory_path() / "palpate_test_million_waypoints.yaml";
  {
    std::FILE* f = std::fopen(p.c_str(), "w");
    ASSERT_NE(f, nullptr);
    std::fputs("name: big\nduration: 1\ndevice:\n  waypoints:\n", f);
    for (int i = 0; i < 1000000; ++i) std::fprintf(f, "    - {t: %.6f, position: [0.001, %.6f, 0]}\n", i * 1e-6, 0.01 - i * 1e-8);
    std::fputs("tissues:\n  - name: a\n    patch: {width: 0.01, height: 0.01}\n", f);
    std::fclose(f);
  }
  MemoryLimit limit("2e9");
  auto s = palpate::load_scene(p);
  ASSERT_FALSE(s.ok());
  const std::string& m = s.error().message;
  EXPECT_EQ(m.rfind(p.string() + ": 52 MB in 1000007 lines is about 4.16 GB to parse, more than this machine's 2 GB "
                                 "of memory; long paths belong in a trajectory CSV (device.trajectory",
                    0),
            0u)
      << m;
  EXPECT_NE(m.find("rather than device.waypoints"), std::string::npos) << m;
  fs::remove(p);
}

// Waypoints and a trajectory that would not fit in half the memory: refused naming the key, the
// count and the memory.
TEST(MemoryEstimates, WaypointsAndTrajectoriesThatCannotFitAreRefused) {
  std::string yaml = "device:\n  waypoints:\n";
  for (int i = 0; i < 2000; ++i) yaml += "    - {t: " + std::to_string(i * 0.001) + ", position: [0, 0, 0]}\n";
  yaml += "tissues:\n  - name: a\n    patch: {}\n";
  MemoryLimit limit("2e5");
  auto s = palpate::parse_scene(yaml, "w.yaml");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().message,
            "w.yaml:3: device.waypoints: 2000 waypoints need about 176 kB, more than half of this machine's 200 kB "
            "of memory; expected a trajectory CSV (device.trajectory) or fewer waypoints");
  const fs::path csv = fs::temp_directory_path() / "palpate_test_memory_trajectory.csv";
  {
    std::ofstream out(csv);
    for (int i = 0; i < 10000; ++i) out << i * 0.001 << ",0,0.0" << i % 10 << ",0\n";
  }
  s = palpate::parse_scene("device: {trajectory: " + csv.string() + "}\ntissues:\n  - name: a\n    patch: {}\n", "t.yaml");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().message.rfind("t.yaml:1: device.trajectory: " + csv.string() + " is about ", 0), 0u)
      << s.error().message;
  EXPECT_NE(s.error().message.find("more than half of this machine's 200 kB of memory"), std::string::npos)
      << s.error().message;
}

// A charged patch laid on a mesh: its particles estimated from the surface's area before it is
// built. A 1 m cube (6 m²) at 0.1 mm passes the check along the surface (10,000 particles across)
// but would be 6.9e8 particles, past the model's index range.
TEST(MemoryEstimates, AChargedPatchLaidTooFinelyOnAMeshIsRefusedNamingMeshSpacing) {
  const std::string m = tissue_error(
      "tissues:\n  - name: cube\n    mesh: {file: " PALPATE_TEST_DATA_DIR "/meshes/cube.off}\n"
      "    material: {mesh_spacing: 0.0001}\n");
  EXPECT_NE(m.find("material 'mesh_spacing' (0.0001 m) lays about 6.9282e+08 particles on the surface's 6 m², about "
                   "208 GB to build, more than the model's index range (134217728 particles); expected a coarser "
                   "mesh_spacing"),
            std::string::npos) << m;
  // Where 2 GB may be used, 0.5 mm (2.8e7 particles, 8.3 GB) is refused for the memory.
  MemoryLimit limit("2e9");
  const std::string m2 = tissue_error(
      "tissues:\n  - name: cube\n    mesh: {file: " PALPATE_TEST_DATA_DIR "/meshes/cube.off}\n"
      "    material: {mesh_spacing: 0.0005}\n");
  EXPECT_NE(m2.find("more than this machine's 2 GB of memory; expected a coarser mesh_spacing"), std::string::npos) << m2;
}

// A mass-spring tissue's springs and predictor where 0.2 GB may be used: all_pairs on 40,401
// vertices (8.2e8 springs) and a dense predictor of 2,601 vertices, each refused naming its key.
TEST(MemoryEstimates, SpringTissuesThatCannotFitAreRefusedNamingTheKey) {
  MemoryLimit limit("2e8");
  std::string m = tissue_error(
      "tissues:\n  - name: sheet\n    model: mass_spring\n    patch: {width: 0.2, height: 0.2, spacing: 0.001}\n"
      "    material: {topology: all_pairs, solver: sparse}\n");
  EXPECT_NE(m.find("material.topology 'all_pairs' on 40401 vertices is 8.16e+08 springs, about 52.2 GB, more than "
                   "this machine's 200 MB of memory; expected topology edges or tet_edges"),
            std::string::npos) << m;
  m = tissue_error(
      "tissues:\n  - name: sheet\n    model: mass_spring\n    patch: {width: 0.05, height: 0.05, spacing: 0.001}\n"
      "    material: {solver: desbrun}\n");
  EXPECT_NE(m.find("material.solver 'desbrun' keeps a dense n x n inverse: 2601 vertices, 54.1 MB kept and about "
                   "216 MB to build, more than this machine's 200 MB of memory (use solver: sparse)"),
            std::string::npos) << m;
}
