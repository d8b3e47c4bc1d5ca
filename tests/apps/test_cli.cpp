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

// README, "Exit statuses": 0 ok, 1 a failed run or bad input, 2 the command line, 3 out of memory,
// 128 + the signal when interrupted — never CLI11's internal 104–114.
TEST(Cli, ExitStatusesFollowTheDocumentedConvention) {
  const std::string scenes = std::string(PALPATE_DATA_DIR) + "/scenes/";
  struct Case {
    std::string args;
    int code;
    const char* says;
  };
  const Case cases[] = {
      {"--help", 0, "Usage"},
      {"--version", 0, "palpate "},
      {"run --help", 0, "--out"},
      {"", 2, "subcommand is required"},
      {"frobnicate", 2, "unknown command 'frobnicate'"},
      {"run", 2, "scene is required"},
      {"run --no-such-option " + scenes + "probe.yaml", 2, "--no-such-option"},
      {"run --physics-rate 0 " + scenes + "probe.yaml", 2, "--physics-rate"},
      {"run --coupling sideways " + scenes + "probe.yaml", 2, "--coupling"},
      {"run /nonexistent/scene.yaml", 2, "/nonexistent/scene.yaml"},
      {"precompute --solver exact " + std::string(PALPATE_DATA_DIR) + "/meshes/liver.msh", 2, "--solver"},
      {"run " + std::string(PALPATE_SOURCE_DIR) + "/tests/data/scenes/broken/range.yaml", 1, "poisson_ratio"},
      {"precompute " + std::string(PALPATE_SOURCE_DIR) + "/tests/data/scenes/broken/type.yaml", 1, "dt"},
      {"info " + std::string(PALPATE_SOURCE_DIR) + "/tests/data/scenes/broken/vec3.yaml", 1, "vec3.yaml"},
  };
  for (const Case& c : cases) {
    const Ran r = run(c.args);
    EXPECT_EQ(r.code, c.code) << "palpate " << c.args << "\n" << r.out;
    EXPECT_FALSE(r.code >= 100 && r.code <= 120) << "a CLI11-internal status: palpate " << c.args;
    EXPECT_NE(r.out.find(c.says), std::string::npos) << "palpate " << c.args << "\n" << r.out;
  }
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
  EXPECT_EQ(r.code, 1);  // bad input (README, "Exit statuses")
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
// std::bad_alloc handler (exit 3); on a machine too small for it, the load refuses it (exit 1).
TEST(Cli, OutOfMemoryIsAClearErrorNotAnAbort) {
  if (kAddressSanitized) GTEST_SKIP() << "AddressSanitizer maps terabytes of shadow memory: ulimit -v stops it at start";
  const auto p = std::filesystem::temp_directory_path() / "palpate_cli_oom.yaml";
  std::ofstream(p) << "name: oom\nduration: 0.01\ndt: 0.001\noutput: " << (std::filesystem::temp_directory_path() / "palpate_cli_oom").string()
                   << "\ntissues:\n  - name: big\n    patch: {width: 0.3, height: 0.3, spacing: 0.00005}\n";
  Ran r = palpate::test::shell_run("(ulimit -v 2000000; " + std::string(PALPATE_CLI) + " run -q " + p.string() + ")");
  ASSERT_NE(r.code, -1) << "killed by a signal (an abort?): " << r.out;
  if (r.code == 1) {
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

// `palpate doctor`: every check a line, a failure or warning followed by what to do, exit 1 only
// when something a run needs fails (README, "Exit statuses").
TEST(Cli, DoctorChecksWhatALabNeedsAndSaysWhatToDo) {
  // Without the vendor's library: a warning with the way to install or point at it; exit 0.
  Ran r = run("doctor --hd-library libHD-nonexistent.so");
  EXPECT_EQ(r.code, 0) << r.out;
  for (const char* line : {"ok   cpu ", " vector units ", " realtime ", " locked memory ", "warn openhaptics ",
                           " forcedimension ", " display ", " gnuplot ", " cache "})
    EXPECT_NE(r.out.find(line), std::string::npos) << line << "\n" << r.out;
  EXPECT_NE(r.out.find("libHD-nonexistent.so"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("-> install OpenHaptics"), std::string::npos) << r.out;
  // The test's stand-in libHD.so: found at its path, and the device opens and reports a pose.
  r = run(std::string("doctor --hd-library ") + PALPATE_FAKE_HD);
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find(std::string("ok   openhaptics    found ") + PALPATE_FAKE_HD), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("the default HD device opens; stylus at"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("ok     calibration  calibrated (hdCheckCalibration)"), std::string::npos) << r.out;
  // A device that needs calibrating by hand does not open: exit 1, the way to do it on the line.
  r = palpate::test::shell_run("FAKE_HD_CALIBRATION=manual " + std::string(PALPATE_CLI) + " doctor --hd-library " +
                               PALPATE_FAKE_HD + " 2>&1");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("the device is not calibrated (it needs your hand): put the stylus in its inkwell"),
            std::string::npos) << r.out;
  // One the library could update: updated, and said so.
  r = palpate::test::shell_run("FAKE_HD_CALIBRATION=update " + std::string(PALPATE_CLI) + " doctor --hd-library " +
                               PALPATE_FAKE_HD + " 2>&1");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("updated by the HD library (hdUpdateCalibration)"), std::string::npos) << r.out;
  // A predictor cache that cannot be written fails the check: exit 1, with the way out.
  r = palpate::test::shell_run("XDG_CACHE_HOME=/proc/palpate-no-such-dir " + std::string(PALPATE_CLI) +
                               " doctor --no-device-open 2>&1");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("FAIL cache"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("-> make it writable, or pass --cache DIR"), std::string::npos) << r.out;
}

// A scene's warnings on standard error before the run, which runs as written; none with --quiet.
TEST(Cli, RunPrintsTheScenesWarningsUnlessQuiet) {
  const auto p = std::filesystem::temp_directory_path() / "palpate_cli_warned.yaml";
  std::ofstream(p) << "name: warned\nduration: 0.05\ndt: 0.001\noutput: "
                   << (std::filesystem::temp_directory_path() / "palpate_cli_warned").string()
                   << "\ntool: {kind: needle, axis: [0, -1, 0]}\ndevice:\n  waypoints:\n"
                      "    - {t: 0, position: [0, 0.01, 0]}\n    - {t: 0.05, position: [0.01, 0.004226, 0]}\n"
                      "tissues:\n  - name: a\n    patch: {spacing: 0.002}\n";
  Ran r = palpate::test::shell_run(std::string(PALPATE_CLI) + " run " + p.string() + " 2>&1");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("palpate run: warning: " + p.string() + ":9: device.waypoints[1]: the needle moves 11.5 mm at 60°"),
            std::string::npos)
      << r.out;
  r = palpate::test::shell_run(std::string(PALPATE_CLI) + " run -q " + p.string() + " 2>&1");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out, "");
}

TEST(Cli, InfoJsonGivesTheSameFiguresAsText) {
  const std::string mesh = std::string(PALPATE_DATA_DIR) + "/meshes/liver.msh";
  const Ran text = run("info " + mesh);
  const Ran json = run("info --json " + mesh);
  ASSERT_EQ(json.code, 0) << json.out;
  ASSERT_EQ(text.code, 0) << text.out;
  auto field = [&](const std::string& key) {
    const size_t at = json.out.find("\"" + key + "\": ");
    EXPECT_NE(at, std::string::npos) << key << "\n" << json.out;
    return at == std::string::npos ? std::string() : json.out.substr(at + key.size() + 4, json.out.find_first_of(",\n", at) - at - key.size() - 4);
  };
  EXPECT_EQ(field("kind"), "\"tetrahedral\"");
  EXPECT_NE(text.out.find("vertices    " + field("vertices") + "\n"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("tetrahedra  " + field("tetrahedra") + "\n"), std::string::npos) << text.out;
  EXPECT_EQ(field("closed"), "true");
  EXPECT_EQ(json.out.front(), '{');
}

// Every command has --quiet (errors only) and --verbose (what was loaded from where, each stage's
// timing); the two exclude each other (a usage error).
TEST(Cli, VerboseSaysWhatWasLoadedFromWhereAndQuietPrintsNothingButErrors) {
  namespace fs = std::filesystem;
  const fs::path out = fs::temp_directory_path() / "palpate_test_cli_verbose";
  const std::string probe = std::string(PALPATE_DATA_DIR) + "/scenes/probe.yaml";
  Ran r = run("run -v " + probe + " -o " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("loaded     scene " + fs::absolute(probe).lexically_normal().string()), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("loaded     tool device: scripted, 5 waypoints"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("loaded     tissue patch (charged_particles, tissue): flat patch"), std::string::npos) << r.out;
  for (const char* stage : {"read_devices", "step_tissues", "render_forces", "watchdog", "safety_and_write", "record",
                            "live_figures"})
    EXPECT_NE(r.out.find(std::string("stage      ") + stage), std::string::npos) << stage << "\n" << r.out;
  // A mass-spring tissue's predictor: where it comes from.
  r = run(std::string("run -v ") + PALPATE_DATA_DIR + "/scenes/liver-springs.yaml -o " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("loaded     tissue liver (mass_spring, tissue): mesh "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("predictor from the cache "), std::string::npos) << r.out;
  // Quiet: nothing on standard output for a good run, a good mesh or a healthy doctor's ok lines.
  r = palpate::test::shell_run(std::string(PALPATE_CLI) + " run -q " + probe + " -o " + out.string() + " 2>/dev/null");
  EXPECT_EQ(r.code, 0);
  EXPECT_EQ(r.out, "");
  r = palpate::test::shell_run(std::string(PALPATE_CLI) + " info -q " + PALPATE_DATA_DIR + "/meshes/liver.msh");
  EXPECT_EQ(r.code, 0);
  EXPECT_EQ(r.out, "");
  r = palpate::test::shell_run(std::string(PALPATE_CLI) + " doctor -q --no-device-open --hd-library " + PALPATE_FAKE_HD);
  EXPECT_EQ(r.out.find("ok   "), std::string::npos) << r.out;
  // ... but the error still: a refused mesh, named.
  r = run(std::string("info -q ") + PALPATE_SOURCE_DIR + "/tests/data/scenes/broken/vec3.yaml");
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.out.find("vec3.yaml"), std::string::npos) << r.out;
  // Both at once: a usage error.
  for (const char* command : {"run", "view", "precompute", "info", "doctor"}) {
    r = run(std::string(command) + " -q -v " + probe);
    EXPECT_EQ(r.code, 2) << command << "\n" << r.out;
    EXPECT_NE(r.out.find("excludes"), std::string::npos) << command << "\n" << r.out;
  }
  fs::remove_all(out);
}

// Images at chosen times (issue 35: evenly spaced, none fell in cvc.yaml's compression check):
// each after the tick that ends nearest its time; times out of order, outside the run or with a
// count besides are refused, named.
TEST(Cli, FramesAndUltrasoundImagesAtChosenTimes) {
  namespace fs = std::filesystem;
  const fs::path out = fs::temp_directory_path() / "palpate_test_cli_times";
  fs::remove_all(out);
  const std::string probe = std::string(PALPATE_DATA_DIR) + "/scenes/probe.yaml";
  Ran r = run("run " + probe + " --frame-times 0.5,2,3.75 -o " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("frame_000.png  (t = 0.500 s)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("frame_001.png  (t = 2.000 s)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("frame_002.png  (t = 3.750 s)"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(out / "frame_003.png"));
  // A time of 0 is the first tick's image.
  r = run("run " + probe + " -q --frame-times 0 -o " + out.string());
  EXPECT_EQ(r.code, 0) << r.out;
  r = run("run " + probe + " --frame-times 2,0.5 -o " + out.string());
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.out.find("frame_times: expected ascending times, each on a tick of its own: 0.5 s"), std::string::npos) << r.out;
  r = run("run " + probe + " --frame-times 1,1.0004 -o " + out.string());
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.out.find("each on a tick of its own"), std::string::npos) << r.out;
  r = run("run " + probe + " --frame-times 9 -o " + out.string());
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.out.find("frame_times: 9 s is outside the run (0 to 4 s)"), std::string::npos) << r.out;
  r = run("run " + probe + " --frame-times 1 --frames 3 -o " + out.string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("excludes"), std::string::npos) << r.out;
  // Ultrasound at chosen times, in the CVC scene's compression check (docs/cvc.md).
  r = run(std::string("run ") + PALPATE_DATA_DIR + "/scenes/cvc.yaml --ultrasound-times 0.001,2.5 -o " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("us_000.png  (t = 0.001 s)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("us_001.png  (t = 2.500 s)"), std::string::npos) << r.out;
  fs::remove_all(out);
}
