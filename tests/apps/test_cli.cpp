// test_cli.cpp — the palpate command as a user meets it: --version, --help, exit codes, errors.
#include "sanitized.h"
#include "shell_run.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <sys/wait.h>

namespace {

using palpate::test::Ran;

// The palpate command with these arguments.
Ran run(const std::string& args) { return palpate::test::shell_run(std::string(PALPATE_CLI) + " " + args); }

}  // namespace

TEST(Cli, VersionPrintsNameAndVersion) {
  Ran r = run("--version");
  EXPECT_EQ(r.code, 0);
  EXPECT_EQ(r.out.rfind("palpate 0.", 0), 0u) << r.out;
  // And the optional components built in (README, Building by hand).
  const std::string components = std::string("components: OSMesa ") + (PALPATE_HAS_OSMESA ? "yes" : "no") +
                                 ", Gmsh " + (PALPATE_HAS_GMSH ? "yes" : "no") + ", CGAL " +
                                 (PALPATE_HAS_CGAL ? "yes" : "no");
  EXPECT_NE(r.out.find(components), std::string::npos) << r.out;
}

TEST(Cli, HelpListsEveryCommand) {
  Ran r = run("--help");
  EXPECT_EQ(r.code, 0);
  for (const char* c : {"run", "info", "precompute"}) EXPECT_NE(r.out.find(c), std::string::npos) << c;
}

TEST(Cli, CommandHelpDescribesItsOptions) {
  Ran r = run("run --help");
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("--out"), std::string::npos) << r.out;
  r = run("info --help");
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("--scale"), std::string::npos) << r.out;
}

TEST(Cli, NoCommandOrUnknownCommandFails) {
  EXPECT_NE(run("").code, 0);
  Ran r = run("frobnicate");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("frobnicate"), std::string::npos) << r.out;
}

TEST(Cli, MissingSceneFileIsNamed) {
  Ran r = run("run /nonexistent/scene.yaml");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("/nonexistent/scene.yaml"), std::string::npos) << r.out;
}

TEST(Cli, BadSceneGivesFileAndLine) {
  const auto p = std::filesystem::temp_directory_path() / "palpate_cli_bad.yaml";
  std::ofstream(p) << "name: x\nduration: -1\n";
  Ran r = run("run " + p.string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("palpate_cli_bad.yaml:2"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("duration"), std::string::npos) << r.out;
}

TEST(Cli, InfoDescribesTheSharedLiver) {
  Ran r = run(std::string("info ") + PALPATE_DATA_DIR + "/meshes/liver.msh");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("tetrahedral"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("181"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("596"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("36.56"), std::string::npos) << r.out;

  r = run(std::string("info ") + PALPATE_DATA_DIR + "/meshes/liver_tet_boundary.obj");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("closed      yes"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("manifold    yes"), std::string::npos) << r.out;
}

TEST(Cli, InfoOnBadMeshFailsWithItsName) {
  const auto p = std::filesystem::temp_directory_path() / "palpate_cli_empty.obj";
  std::ofstream(p) << "# nothing\n";
  Ran r = run("info " + p.string());
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("palpate_cli_empty.obj"), std::string::npos) << r.out;
}

namespace {

// probe.yaml made `seconds` long, written to a temporary file.
std::filesystem::path long_probe_scene(const std::string& name, double seconds) {
  std::ifstream in(std::string(PALPATE_DATA_DIR) + "/scenes/probe.yaml");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string from = "duration: 4.0";
  const size_t at = text.find(from);
  if (at != std::string::npos) text.replace(at, from.size(), "duration: " + std::to_string(int(seconds)));
  const auto p = std::filesystem::temp_directory_path() / name;
  std::ofstream(p) << text;
  return p;
}

// What a run interrupted after about a second left in `out`: run.csv's rows up to its last tick,
// each whole, consecutive from tick 0, as many as summary.json says; no .part file.
void expect_complete_interrupted_outputs(const std::filesystem::path& out) {
  std::ifstream csv(out / "run.csv");
  ASSERT_TRUE(csv.good()) << out;
  std::string line, header;
  std::getline(csv, header);
  long rows = 0;
  while (std::getline(csv, line)) {
    // tick is column 9; every row has the header's column count.
    size_t commas = 0, field = 0;
    std::string tick;
    for (char c : line) {
      if (c == ',') {
        ++commas, ++field;
        continue;
      }
      if (field == 8) tick += c;
    }
    ASSERT_EQ(commas, size_t(std::count(header.begin(), header.end(), ','))) << "row " << rows << ": " << line;
    ASSERT_EQ(std::stol(tick), rows) << line;
    ++rows;
  }
  std::ifstream js(out / "summary.json");
  const std::string summary((std::istreambuf_iterator<char>(js)), std::istreambuf_iterator<char>());
  EXPECT_NE(summary.find("\"interrupted\": true"), std::string::npos) << summary.substr(0, 400);
  EXPECT_NE(summary.find("\"ticks\": " + std::to_string(rows) + ","), std::string::npos) << rows;
  EXPECT_GT(rows, 100);
  for (const auto& e : std::filesystem::directory_iterator(out))
    EXPECT_NE(e.path().extension(), ".part") << e.path();
}

}  // namespace

// Ctrl-C or SIGTERM during `palpate run`, realtime or headless: the run stops at a tick, ramps the
// force out, writes run.csv up to its last tick and summary.json marked "interrupted", and exits
// 128 + the signal's number.
TEST(Cli, InterruptedRunWritesCompleteOutputs) {
  struct Case {
    const char* flags;
    const char* signal;
    int code;
  };
  for (const Case& c : {Case{"--realtime", "INT", 130}, Case{"", "TERM", 143}}) {
    const auto scene = long_probe_scene("palpate_cli_long_probe.yaml", 600);
    const auto out = std::filesystem::temp_directory_path() / "palpate_cli_interrupted";
    std::filesystem::remove_all(out);
    std::string cmd = "(";  // a subshell, so that its stderr is captured with it
    cmd += std::string(PALPATE_CLI) + " run -q " + c.flags + " --out " + out.string() + " " + scene.string();
    // Signalled a second after its first rows reach run.csv.part (not at a fixed time: on a loaded
    // machine the scene's load can take longer than that).
    const std::string part = (out / "run.csv.part").string();
    cmd += " & pid=$!; for i in $(seq 300); do [ -s " + part + " ] && break; sleep 0.1; done; sleep 1; kill -" +
           std::string(c.signal) + " $pid; wait $pid)";
    Ran r = palpate::test::shell_run(cmd);
    EXPECT_EQ(r.code, c.code) << c.flags << ": " << r.out;
    EXPECT_NE(r.out.find(std::string("interrupted (SIG") + c.signal + ")"), std::string::npos) << r.out;
    expect_complete_interrupted_outputs(out);
  }
}

// Out of memory is a message and an exit status, never an abort: a patch that passes the load-time
// estimate on this machine but not the address-space limit set here (ulimit -v) ends in main()'s
// std::bad_alloc handler (exit 3); on a machine too small for it, the load refuses it (exit 2).
TEST(Cli, OutOfMemoryIsAClearErrorNotAnAbort) {
  if (kAddressSanitized) GTEST_SKIP() << "AddressSanitizer maps terabytes of shadow memory: ulimit -v stops it at start";
  const auto p = std::filesystem::temp_directory_path() / "palpate_cli_oom.yaml";
  std::ofstream(p) << "name: oom\nduration: 0.01\ndt: 0.001\noutput: " << (std::filesystem::temp_directory_path() / "palpate_cli_oom").string()
                   << "\ntissues:\n  - name: big\n    patch: {width: 0.3, height: 0.3, spacing: 0.00005}\n";
  Ran r = palpate::test::shell_run("(ulimit -v 2000000; " + std::string(PALPATE_CLI) + " run -q " + p.string() + ")");
  ASSERT_NE(r.code, -1) << "killed by a signal (an abort?): " << r.out;
  if (r.code == 2) {
    EXPECT_NE(r.out.find("tissues[0].patch.spacing"), std::string::npos) << r.out;
  } else {
    EXPECT_EQ(r.code, 3) << r.out;
    EXPECT_NE(r.out.find("palpate: out of memory"), std::string::npos) << r.out;
  }
}

TEST(Cli, UltrasoundWritesItsImagesAndNeedsAProbe) {
  namespace fs = std::filesystem;
  const fs::path out = fs::temp_directory_path() / "palpate_test_cli_ultrasound";
  fs::remove_all(out);
  Ran r = run(std::string("run ") + PALPATE_DATA_DIR + "/scenes/cvc.yaml --ultrasound 2 --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("probe      max force"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("us_000.png  (t = 0.001 s)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("us_001.png  (t = 12.800 s)"), std::string::npos) << r.out;
  EXPECT_TRUE(fs::exists(out / "us_000.png") && fs::exists(out / "us_001.png"));
  fs::remove_all(out);
  // A scene without a probe: the error says what is missing.
  r = run(std::string("run ") + PALPATE_DATA_DIR + "/scenes/cvc-overlap.yaml --ultrasound 2 --out " + out.string());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("ultrasound images need a 'probe' section in the scene"), std::string::npos) << r.out;
  fs::remove_all(out);
}

// The plots are among a run's outputs: a run that could not write them (no gnuplot on the PATH
// here) says why and exits non-zero, with run.csv and summary.json whole beside it.
TEST(Cli, ARunWhosePlotsCouldNotBeWrittenExitsNonZero) {
  const auto out = std::filesystem::temp_directory_path() / "palpate_cli_no_plots";
  std::filesystem::remove_all(out);
  Ran r = palpate::test::shell_run("PATH=/nonexistent " + std::string(PALPATE_CLI) + " run " PALPATE_DATA_DIR
                                   "/scenes/probe.yaml --out " + out.string());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("palpate run: no plots: "), std::string::npos) << r.out;
  EXPECT_TRUE(std::filesystem::exists(out / "run.csv"));
  EXPECT_TRUE(std::filesystem::exists(out / "summary.json"));
  std::filesystem::remove_all(out);
}
