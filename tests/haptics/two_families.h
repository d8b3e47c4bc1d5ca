// two_families.h — issue 38's bench scene, shared by its test (test_two_families.cpp) and its
// benchmark (bench/bench_device.cpp): the CVC scene with the needle on a Touch played by the fake
// libHD (tests/fake_hd) and the ultrasound probe on an omega.7 played by the fake libdhd.so.3
// (tests/fake_dhd), each fake playing the hand the scene's scripted device would have been.
#pragma once

#include <palpate/device.h>
#include <palpate/scene.h>

#include "fake_dhd/fake_dhd_client.h"
#include "haptics/fake_hd_client.h"

#include <string>
#include <vector>

namespace palpate::test {

// Loads data/scenes/cvc.yaml, sets its devices to the fakes (paths `hd`, `dhd`: the built fake
// libraries) and gives the fakes the scene's hands: the needle's waypoints sampled at the Touch's
// 1 kHz servo for `seconds` + 5 s (the fake plays its poses in a loop), the probe's as the omega's
// timed trajectory. An error text, or "" with `scene` ready to run (realtime).
inline std::string two_families_cvc(SceneDef& scene, FakeHd& hd, FakeDhd& dhd, double seconds) {
  auto loaded = load_scene(std::string(PALPATE_DATA_DIR) + "/scenes/cvc.yaml");
  if (!loaded) return loaded.error().message;
  scene = *loaded;
  if (!scene.probe) return "cvc.yaml has no probe";
  if (!hd.lib || !dhd.lib) return "a fake device library did not load";
  scene.duration = seconds;
  ScriptedDevice needle(scene.device.waypoints, {}, scene.tool.axis);
  std::vector<double> needle_mm;
  for (int k = 0; k < int((seconds + 5.0) * 1000); ++k) {
    DeviceState st;
    needle.read(double(k) * 1e-3, st);
    for (int c = 0; c < 3; ++c) needle_mm.push_back(st.position[c] * 1e3);
  }
  std::vector<double> probe_txyz;
  for (const Waypoint& w : scene.probe->device.waypoints)
    probe_txyz.insert(probe_txyz.end(), {w.t, w.position.x(), w.position.y(), w.position.z()});
  hd.reset(1);
  const double identity[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};  // the needle along the scene's tool.axis
  hd.set_rotation(identity);
  hd.set_poses(needle_mm.data(), int(needle_mm.size() / 3));
  dhd.reset(1);  // one omega.7, calibrated
  dhd.set_trajectory(0, probe_txyz.data(), int(probe_txyz.size() / 4));
  scene.device.kind = "openhaptics";
  scene.device.hd_library = PALPATE_FAKE_HD;
  scene.probe->device.kind = "forcedimension";
  scene.probe->device.dhd_library = PALPATE_FAKE_DHD;
  return "";
}

}  // namespace palpate::test
