// test_cli.cpp — the palpate command as a user meets it: --version, --help, exit codes, errors.
#include "shell_run.h"

#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
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
