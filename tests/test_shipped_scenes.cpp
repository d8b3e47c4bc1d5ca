// test_shipped_scenes.cpp — every scene in data/scenes runs headless, and every one whose tool is
// meant to reach its tissue touches it, within the device's limits; a needle's run never needs the
// safety filter's rate limit.
#include <palpate/run.h>
#include <palpate/scene.h>

#include "components.h"
#include "sanitized.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

using namespace palpate;

TEST(ShippedScenes, EachRunsAndItsToolTouchesItsTissue) {
  namespace fs = std::filesystem;
  int ran = 0;
  for (const auto& entry : fs::directory_iterator(PALPATE_SOURCE_DIR "/data/scenes")) {
    if (entry.path().extension() != ".yaml") continue;
    const std::string name = entry.path().filename().string();
    // Under a sanitizer the 54k-vertex organ's scene alone is past ctest's 300 s (its mesh, its
    // factorisation and 1,500 ticks): run in full by the release suite only.
    if (kSanitized && name == "large-organ.yaml") continue;
    // The gallbladder's 8,000 ticks of a 3,000-vertex organ with 15 new factors: under the sanitizers
    // once, by CutScenes (the whole scene, tick by tick), not again here (CI's time budget).
    if (kSanitized && name == "gallbladder.yaml") continue;
    if (!missing_component(entry.path()).empty()) continue;  // a build without it (components.h)
    auto scene = load_scene(entry.path());
    ASSERT_TRUE(scene.ok()) << scene.error().message;
    RunOptions o;
    o.out = fs::temp_directory_path() / ("palpate_shipped_" + name);
    o.plots = false;
    auto r = run_scene(*scene, o);
    fs::remove_all(o.out);
    ASSERT_TRUE(r.ok()) << name << ": " << r.error().message;
    ++ran;
    EXPECT_LE(r->max_force, scene->device.max_force) << name;
    EXPECT_EQ(r->safety.non_finite, 0u) << name;
    EXPECT_EQ(r->safety.step_failed, 0u) << name;
    EXPECT_GT(r->max_force, 0.1) << name << ": the tool never touched its tissue";
    // No shipped scene needs the rate limit: a needle's normal insertion and withdrawal (issue 19),
    // a probe's steady press and let-go (liver-springs), a grasped organ let go (liver-probe: its
    // pull fades over the material's grasp_release_time, where it used to drop 1.26 N in a tick).
    // large-organ.yaml too, since its physics step's contact uses the exact diagonal of A⁻¹ (its
    // lift-off used to drop 0.40 N in a tick); its slide's steps at each 50 Hz physics step are now
    // ≤ 0.04 N (they were up to 0.154 N before the patch's points moved between steps; docs/haptics.md).
    EXPECT_EQ(r->safety.rate_limited, 0u) << name;
  }
  EXPECT_GE(ran, (kSanitized ? 8 : 10) - (PALPATE_HAS_GMSH ? 0 : 2));  // liver-probe, liver-springs: .msh
}
