// test_fuzz_inputs.cpp — the fuzzers' inputs in the normal suite (fuzz/README.md). Every seed of
// fuzz/corpus/<target>/ is one of the project's own valid files and must load; every input a fuzz
// target found a problem with, kept in tests/data/fuzz-regressions/<target>/, must now load or be
// refused with an error that names its file (and, when `<input>.expect` is there, says what that
// file says). Under the fuzz preset (ASan + UBSan) a crash, leak or undefined behaviour on any of
// them fails the run, as it failed the fuzzer.
#include <palpate/device.h>
#include <palpate/mesh.h>
#include <palpate/scene.h>
#include <palpate/spring.h>
#include <palpate/mesh_load.h>
#include <palpate/tissue_files.h>

#include "spring_cut_paths.h"
#include "charged_cut_drive.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace palpate;

namespace {

std::string read_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

class Scratch {
 public:
  Scratch() : dir_(fs::temp_directory_path() / ("palpate_fuzz_inputs_" + std::to_string(::getpid()))) {
    fs::create_directories(dir_);
  }
  ~Scratch() {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  fs::path write(const std::string& name, const std::string& bytes) const {
    std::ofstream(dir_ / name, std::ios::binary | std::ios::trunc) << bytes;
    return dir_ / name;
  }
  const fs::path& dir() const { return dir_; }

 private:
  fs::path dir_;
};

// What a fuzz target does with its input, as the fuzz target does it (fuzz/fuzz_*.cpp): nullopt
// when it loaded, else the error. `where` gets what the error must name.
std::optional<std::string> run_target(const std::string& target, const std::string& bytes, const Scratch& scratch,
                                      std::string& where) {
  const auto outcome = [&where](const auto& result, const fs::path& file) -> std::optional<std::string> {
    where = file.string();
    if (result) return std::nullopt;
    return result.error().message;
  };
  if (target.rfind("fuzz_surface_", 0) == 0) {
    const fs::path f = scratch.write("input." + target.substr(13), bytes);
    return outcome(load_surface(f), f);
  }
  if (target == "fuzz_gmsh" || target == "fuzz_vtk") {
    const fs::path f = scratch.write(target == "fuzz_gmsh" ? "input.msh" : "input.vtk", bytes);
    return outcome(load_tet(f), f);
  }
  if (target == "fuzz_tetgen") {
    const std::string sep = "\n%%ele%%\n";
    const size_t at = bytes.find(sep);
    const fs::path node = scratch.write("input.node", at == std::string::npos ? bytes : bytes.substr(0, at + 1));
    scratch.write("input.ele", at == std::string::npos ? std::string() : bytes.substr(at + sep.size()));
    const Result<TetMesh> m = load_tet(node);
    where = (scratch.dir() / "input.").string();
    if (m) return std::nullopt;
    return m.error().message;
  }
  if (target == "fuzz_scene") {
    const Result<SceneDef> s = parse_scene(bytes, "fuzz-scene.yaml", PALPATE_DATA_DIR "/scenes");
    where = "fuzz-scene.yaml";
    if (s) return std::nullopt;
    return s.error().message;
  }
  if (target == "fuzz_trajectory_csv") {
    const fs::path f = scratch.write("input.csv", bytes);
    return outcome(load_trajectory_csv(f), f);
  }
  if (target == "fuzz_recording_csv") {
    const fs::path f = scratch.write("input.csv", bytes);
    return outcome(load_recording_csv(f), f);
  }
  if (target == "fuzz_charged_cut") {  // blade paths, not a file: run as the fuzz target runs them
    where = "fuzz_charged_cut";
    return fuzz::drive_charged_cut(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size());
  }
  if (target == "fuzz_predictor") {
    // The unit cube's networks for each precomputing solver, as fuzz_predictor.cpp builds them:
    // loaded when it loads for one of them.
    const fs::path f = scratch.write("input.predictor", bytes);
    where = f.string();
    const Result<TetMesh> mesh = load_tet(PALPATE_TEST_DATA_DIR "/meshes/cube_1based.node");
    if (!mesh) return mesh.error().message;
    SpringNetworkOptions net_options;
    net_options.anchors = {0, 1};
    std::string errors;
    for (SpringSolver solver : {SpringSolver::desbrun, SpringSolver::sparse}) {
      Result<SpringNetwork> net = make_spring_network(*mesh, net_options, "cube");
      if (!net) return net.error().message;
      SpringModelOptions options;
      options.solver = solver;
      const Result<SpringPredictor> p = load_predictor(f, *net, options);
      if (p) return std::nullopt;
      errors += p.error().message + "\n";
    }
    return errors;
  }
  if (target == "fuzz_spring_cut") {
    // Not a reader: a blade path (spring_cut_paths.h), whose properties must hold.
    static const SpringModel base = cut_paths::block_model();
    where = "blade path";
    const auto r = cut_paths::run_blade_path(base, reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size(), true);
    const bool cut_inverted =
        r.inverted != 0 &&
        cut_paths::run_blade_path(base, reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size(), false, 1e9)
                .inverted == 0;
    if (r.finite && r.open_edges == 0 && !cut_inverted && r.backward <= 1e-14 && r.residual <= 1e-9) return std::nullopt;
    return "blade path: finite " + std::to_string(r.finite) + ", open edges " + std::to_string(r.open_edges) +
           ", inverted " + std::to_string(r.inverted) + ", residual " + std::to_string(r.residual);
  }
  ADD_FAILURE() << "no reader for the fuzz target directory '" << target << "'";
  return "unknown target";
}

std::vector<fs::path> inputs(const fs::path& root) {
  std::vector<fs::path> files;
  if (!fs::exists(root)) return files;
  for (const auto& e : fs::recursive_directory_iterator(root))
    if (e.is_regular_file() && e.path().extension() != ".expect" && e.path().filename() != "README.md")
      files.push_back(e.path());
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace

TEST(FuzzInputs, EverySeedLoads) {
  const Scratch scratch;
  const std::vector<fs::path> seeds = inputs(PALPATE_SOURCE_DIR "/fuzz/corpus");
  ASSERT_GE(seeds.size(), 11u) << "each fuzz target has seeds";
  for (const fs::path& seed : seeds) {
    std::string where;
    const std::string target = seed.parent_path().filename().string();
    const auto error = run_target(target, read_bytes(seed), scratch, where);
    if (!PALPATE_HAS_GMSH && target == "fuzz_gmsh") {  // a good .msh file, that only Gmsh reads
      EXPECT_NE(error.value_or("").find("palpate was built without Gmsh"), std::string::npos) << seed << ": " << error.value_or("");
      continue;
    }
    EXPECT_FALSE(error) << seed << ": " << error.value_or("");
  }
}

TEST(FuzzInputs, EveryFindingIsRefusedClearly) {
  const Scratch scratch;
  for (const fs::path& input : inputs(PALPATE_TEST_DATA_DIR "/fuzz-regressions")) {
    std::string where;
    const auto error = run_target(input.parent_path().filename().string(), read_bytes(input), scratch, where);
    fs::path expect = input;
    expect += ".expect";
    if (fs::exists(expect)) {
      std::string want = read_bytes(expect);
      while (!want.empty() && (want.back() == '\n' || want.back() == '\r')) want.pop_back();
      ASSERT_TRUE(error) << input << " loaded; expected an error saying '" << want << "'";
      EXPECT_NE(error->find(want), std::string::npos) << input << ": '" << *error << "' does not say '" << want << "'";
    }
    if (error) {
      EXPECT_NE(error->find(where), std::string::npos) << input << ": '" << *error << "' does not name " << where;
    }
  }
}
