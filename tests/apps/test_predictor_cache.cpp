// test_predictor_cache.cpp — where a run keeps the predictor a scene does not name (issue 34,
// part 6): in the predictor cache (--cache, else $XDG_CACHE_HOME/palpate/predictors), shared
// between runs, never beside the scene nor in the run's output; a changed organ gets its own file;
// a temporary file a killed save left is removed by the next save once its writer has gone.
#include <palpate/core.h>

#include "shell_run.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

namespace {

namespace fs = std::filesystem;
using palpate::test::Ran;

Ran palpate_cli(const std::string& args) { return palpate::test::shell_run(std::string(PALPATE_CLI) + " " + args); }

class PredictorCache : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / ("palpate_predictor_cache_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  // A 16 x 16 mm mass-spring sheet on the desbrun solver (it has a predictor), no predictor named.
  fs::path scene(double stiffness) const {
    const fs::path file = dir_ / "scene" / "sheet.yaml";
    fs::create_directories(file.parent_path());
    std::ofstream(file) << "name: sheet\nduration: 0.02\ndt: 0.001\noutput: out\n"
                        << "tool: {kind: sphere, radius: 0.002}\n"
                        << "device: {kind: scripted, waypoints: [{t: 0, position: [0, 0.01, 0]}]}\n"
                        << "tissues:\n  - name: sheet\n    model: mass_spring\n"
                        << "    patch: {width: 0.016, height: 0.016, spacing: 0.002}\n"
                        << "    material: {solver: desbrun, stiffness: " << stiffness << ", gravity: false}\n"
                        << "    anchors: [0, 8, 72, 80]\n";
    return file;
  }
  static std::vector<fs::path> predictors_under(const fs::path& root) {
    std::vector<fs::path> found;
    for (const auto& e : fs::recursive_directory_iterator(root))
      if (e.path().extension() == ".predictor") found.push_back(e.path());
    return found;
  }
  fs::path dir_;
};

TEST_F(PredictorCache, ARunKeepsItInTheCacheNeverBesideTheSceneAndTheNextRunFindsIt) {
  const fs::path cache = dir_ / "cache";
  const std::string args = scene(200).string() + " -q --out " + (dir_ / "out").string() + " --cache " + cache.string();
  Ran first = palpate_cli("run " + args);
  ASSERT_EQ(first.code, 0) << first.out;
  const auto in_cache = predictors_under(cache);
  ASSERT_EQ(in_cache.size(), 1u);
  EXPECT_EQ(in_cache[0].filename().string().rfind("sheet-", 0), 0u) << in_cache[0];
  EXPECT_TRUE(predictors_under(dir_ / "scene").empty());  // nothing beside the scene
  EXPECT_TRUE(predictors_under(dir_ / "out").empty());    // nor among the run's outputs
  // A save writes a new file and renames it over the old one (a new inode); a load reads it in place.
  const auto inode = [](const fs::path& p) {
    struct stat st {};
    return ::stat(p.c_str(), &st) == 0 ? st.st_ino : ino_t(0);
  };
  const ino_t written = inode(in_cache[0]);
  ASSERT_NE(written, ino_t(0));

  Ran second = palpate_cli("run " + args);  // the same organ: loaded, not written again
  ASSERT_EQ(second.code, 0) << second.out;
  ASSERT_EQ(predictors_under(cache).size(), 1u);
  EXPECT_EQ(inode(in_cache[0]), written);

  // A stiffer sheet is another predictor: its own file; the first stays for the first scene.
  Ran stiffer = palpate_cli("run " + scene(400).string() + " -q --out " + (dir_ / "out").string() + " --cache " +
                            cache.string());
  ASSERT_EQ(stiffer.code, 0) << stiffer.out;
  EXPECT_EQ(predictors_under(cache).size(), 2u);
  EXPECT_TRUE(fs::exists(in_cache[0]));
}

TEST_F(PredictorCache, PastItsLimitTheLeastRecentlyUsedGo) {
  const fs::path cache = dir_ / "cache";
  const std::string out = " -q --out " + (dir_ / "out").string() + " --cache " + cache.string();
  ASSERT_EQ(palpate_cli("run " + scene(200).string() + out).code, 0);
  const auto first = predictors_under(cache);
  ASSERT_EQ(first.size(), 1u);
  const auto bytes = fs::file_size(first[0]);
  // Room for one and a half: the second save pushes the first (least recently used) out.
  const std::string limit = "PALPATE_CACHE_BYTES=" + std::to_string(bytes * 3 / 2) + " ";
  Ran r = palpate::test::shell_run(limit + PALPATE_CLI + " run " + scene(400).string() + out);
  ASSERT_EQ(r.code, 0) << r.out;
  const auto after = predictors_under(cache);
  ASSERT_EQ(after.size(), 1u);
  EXPECT_NE(after[0], first[0]);
  // Room for two: a third organ's save keeps both the newest and the one used just before.
  const std::string room = "PALPATE_CACHE_BYTES=" + std::to_string(bytes * 5 / 2) + " ";
  ASSERT_EQ(palpate::test::shell_run(room + PALPATE_CLI + " run " + scene(300).string() + out).code, 0);
  EXPECT_EQ(predictors_under(cache).size(), 2u);
  EXPECT_TRUE(fs::exists(after[0]));
}

TEST_F(PredictorCache, WithoutCacheItIsXdgCacheHomes) {
  const fs::path xdg = dir_ / "xdg";
  Ran r = palpate::test::shell_run("XDG_CACHE_HOME=" + xdg.string() + " " + PALPATE_CLI + " run " + scene(200).string() +
                                   " -q --out " + (dir_ / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const auto found = predictors_under(dir_);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].parent_path(), xdg / "palpate" / "predictors");
}

TEST_F(PredictorCache, AStaleTemporaryIsRemovedByTheNextSaveALiveWritersIsKept) {
  const fs::path cache = dir_ / "cache";
  const std::string args = scene(200).string() + " -q --out " + (dir_ / "out").string() + " --cache " + cache.string();
  ASSERT_EQ(palpate_cli("run " + args).code, 0);
  const auto made = predictors_under(cache);
  ASSERT_EQ(made.size(), 1u);
  const fs::path predictor = made[0];
  fs::remove(predictor);
  // A writer that has gone: a child that exited (and was reaped), so its pid names no process.
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  ASSERT_GT(child, 0);
  ::waitpid(child, nullptr, 0);
  fs::path stale = predictor, live = predictor, other = dir_ / "cache" / "other.predictor";
  stale += ".tmp-" + std::to_string(child) + "-0";
  live += ".tmp-" + std::to_string(::getppid()) + "-0";  // a running process: this test's parent
  other += ".tmp-" + std::to_string(child) + "-0";       // another file's: not this save's to remove
  for (const fs::path& p : {stale, live, other}) std::ofstream(p) << "half a predictor";

  Ran again = palpate_cli("run " + args);
  ASSERT_EQ(again.code, 0) << again.out;
  EXPECT_TRUE(fs::exists(predictor));
  EXPECT_FALSE(fs::exists(stale));
  EXPECT_TRUE(fs::exists(live));
  EXPECT_TRUE(fs::exists(other));
}

TEST(StaleTemporaries, OnlyThoseOfAGoneWriterOfThatFileAreRemoved) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("palpate_stale_tmp_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  ASSERT_GT(child, 0);
  ::waitpid(child, nullptr, 0);
  const std::string gone = std::to_string(child), mine = std::to_string(::getpid());
  for (const std::string& name : std::vector<std::string>{"a.bin.tmp-" + gone + "-0", "a.bin.tmp-" + gone + "-7", "a.bin.tmp-" + mine + "-0",
                                 "a.bin.tmp-x-0", "b.bin.tmp-" + gone + "-0", "a.bin"})
    std::ofstream(dir / name) << "x";
  EXPECT_EQ(palpate::remove_stale_temporaries(dir / "a.bin"), 2u);
  EXPECT_FALSE(fs::exists(dir / ("a.bin.tmp-" + gone + "-0")));
  EXPECT_FALSE(fs::exists(dir / ("a.bin.tmp-" + gone + "-7")));
  EXPECT_TRUE(fs::exists(dir / ("a.bin.tmp-" + mine + "-0")));  // this process may be writing it
  EXPECT_TRUE(fs::exists(dir / "a.bin.tmp-x-0"));                // not a writer's name
  EXPECT_TRUE(fs::exists(dir / ("b.bin.tmp-" + gone + "-0")));   // another file's
  EXPECT_TRUE(fs::exists(dir / "a.bin"));
  EXPECT_EQ(palpate::remove_stale_temporaries(dir / "missing" / "a.bin"), 0u);  // no folder: nothing, no throw
  fs::remove_all(dir);
}

}  // namespace
