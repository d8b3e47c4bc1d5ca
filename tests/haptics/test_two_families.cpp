// test_two_families.cpp — issue 38's bench: the realtime CVC scene with the needle on a Touch (the
// fake libHD, tests/fake_hd) and the ultrasound probe on an omega (the fake libdhd.so.3,
// tests/fake_dhd), both backends in one process, each with its own safety filter and passivity
// controller. Every frame either device's motors got is finite, within that device's limit and its
// rate limit, and neither device reports an error.
#include <palpate/device.h>
#include <palpate/run.h>
#include <palpate/scene.h>

#include "haptics/two_families.h"
#include "sanitized.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <vector>

namespace fs = std::filesystem;
using palpate::Vec3;

namespace {

// Each frame's force within `max_force`, and its change from the frame before (zero before the
// first) within `max_step`: what a device's own guard promises its motors.
void expect_frames_within(const std::vector<Vec3>& frames, double max_force, double max_step, const char* which) {
  ASSERT_FALSE(frames.empty()) << which;
  Vec3 prev = Vec3::Zero();
  double peak = 0;
  for (size_t i = 0; i < frames.size(); ++i) {
    const Vec3& f = frames[i];
    ASSERT_TRUE(f.allFinite()) << which << " frame " << i;
    ASSERT_LE(f.norm(), max_force + 1e-9) << which << " frame " << i;
    ASSERT_LE((f - prev).norm(), max_step + 1e-9) << which << " frame " << i;
    prev = f;
    peak = std::max(peak, f.norm());
  }
  std::printf("%s: %zu frames, peak %.3f N\n", which, frames.size(), peak);
}

TEST(TwoDeviceFamilies, TheCvcSceneWithTheNeedleOnATouchAndTheProbeOnAnOmegaStaysWithinEachDevicesLimits) {
  // Realtime runs under a sanitizer miss their deadlines by design (the overrun watchdog's zero
  // force is then the point); the device tests run under TSan (tests/CMakeLists.txt).
  if (kSanitized) GTEST_SKIP() << "realtime timing: release suite only";
  palpate::test::FakeHd hd;
  palpate::test::FakeDhd dhd;
  palpate::SceneDef scene_def;
  // 2.5 s: the probe's firm press and release, the needle reaching the skin.
  ASSERT_EQ(palpate::test::two_families_cvc(scene_def, hd, dhd, 2.5), "");
  auto* scene = &scene_def;
  const double dt = scene->dt;
  const double needle_limit = scene->device.max_force, probe_limit = scene->probe->device.max_force;
  const double needle_rate = scene->device.max_force_rate, probe_rate = scene->probe->device.max_force_rate;

  const fs::path out = fs::temp_directory_path() / "palpate_test_two_families";
  fs::remove_all(out);
  palpate::RunOptions o;
  o.out = out;
  o.plots = false;
  o.realtime = true;
  o.realtime_priority = false;
  auto r = palpate::run_scene(*scene, o);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->ticks, size_t(std::llround(scene->duration / dt)));
  std::ifstream in(out / "summary.json");
  const auto j = nlohmann::json::parse(in);
  EXPECT_EQ(j["safety"]["device_failed"].get<int>(), 0);
  EXPECT_EQ(j["safety"]["non_finite"].get<int>(), 0);
  ASSERT_TRUE(j.contains("probe")) << j.dump();
  EXPECT_EQ(j["probe"]["safety"]["device_failed"].get<int>(), 0);
  EXPECT_GT(j["probe"]["max_force_N"].get<double>(), 1.0);  // the firm press reached the omega
  EXPECT_LE(j["probe"]["safety"]["max_force_N"].get<double>(), probe_limit);

  // Every frame each device's motors got. The servo frames are the devices' own 1 kHz.
  expect_frames_within(hd.all_forces(), needle_limit, needle_rate * 1e-3, "Touch (needle)");
  std::vector<Vec3> omega;
  for (const auto& s : dhd.sent(0)) omega.push_back(s.force);
  expect_frames_within(omega, probe_limit, probe_rate * 1e-3, "omega (probe)");
  EXPECT_EQ(hd.frame_errors(), 0);
  fs::remove_all(out);
}

}  // namespace
