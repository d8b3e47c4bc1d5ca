// palpate/simulation.h — a scene compiled once: its tissues (built, stacked), its tools addressed
// by name and role with their devices and force models, the outcome model and the loop's settings,
// and the haptic loop over them. `palpate run`, `palpate view`, the benchmarks and the tests build
// from a SceneDef through Simulation::build and nowhere else (../shared/STYLE.md §15, as MuJoCo's
// mj_compile → mj_makeData).
#pragma once

#include <palpate/core.h>
#include <palpate/device.h>
#include <palpate/haptics.h>
#include <palpate/scene_def.h>
#include <palpate/snapshot_tissue.h>
#include <palpate/tissue.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace palpate {

// What a tool does in a scene. A scene's `tool` is a needle, a blade or a sphere (a palpating tip,
// which also grasps while the device's first button is held); its `probe` is an ultrasound probe.
enum class ToolRole : std::uint8_t {
  sphere,           // the HIP of the charged-particle paper: presses, grasps (tool.kind sphere)
  needle,           // punctures; its shaft is felt (tool.kind needle)
  blade,            // a scalpel: presses, and cuts where its edge sweeps (tool.kind blade)
  ultrasound_probe, // the other hand's linear transducer, pressing the neck (scene `probe`)
  grasper           // the other hand's grasper on the tissues (scene `grasper`)
};
const char* tool_role_name(ToolRole role) noexcept;

// One tool of a built simulation. Devices and force models are owned by the Simulation unless the
// front end handed its own device in (SimulationOptions::devices).
struct SimulationTool {
  std::string name;                 // "tool" (the scene's `tool`), "probe" (its `probe`), "grasper"; its CSV prefix
  ToolRole role = ToolRole::sphere;
  size_t loop_index = 0;            // HapticLoop::tool_sample(loop_index)
  Device* device = nullptr;         // never null
  ToolForceModel* model = nullptr;  // the tool's own force law (the probe's); null: the tissues' contact
  const DeviceDef* device_def = nullptr;  // the scene's definition of its device
  Vec3 axis = Vec3(0, -1, 0);       // unit, the direction it points at identity (device frame)
};

// A device a front end supplies for a tool in place of the scene's (the viewer's mouse-driven
// VirtualDevice). Not owned; it must outlive the Simulation.
struct DeviceOverride {
  std::string tool;         // a SimulationTool's name
  Device* device = nullptr;
};

struct SimulationOptions {
  bool realtime = false;            // the loop runs on its own thread, paced by the wall clock
  bool realtime_priority = true;    // realtime: ask for SCHED_FIFO (ignored when not permitted)
  std::vector<double> physics_dt;   // s per tissue (by index): > 0 steps it on its own thread at that
                                    // period; missing = the scene's (material.physics_rate), 0 = every tick
  bool snapshots = false;           // wrap each tissue in a SnapshotTissue (frames, the viewer)
  double overrun_margin = -1;       // s; < 0 = the scene's device.overrun_margin
  bool stop_after_duration = true;  // the loop stops by itself after the scene's duration
  std::vector<DeviceOverride> devices;
  std::filesystem::path cache;      // predictors the scene does not name are kept here (shared
                                    // between runs); "" = default_predictor_cache()
};

// The loop settings a scene gives (coupling, proxy, watchdog, ramp, tool, outcome model), with the
// front end's options applied (no recording: open_loop's). What a Simulation's loop is made with;
// an error naming the scene's file and key for a value the loop cannot take.
Result<LoopSettings> scene_loop_settings(const SceneDef& scene, const SimulationOptions& options = {});

class Simulation {
 public:
  // Build every tissue the scene describes (loading meshes, precomputing), stack them (scene order:
  // outside in), make each tool's device and force model and the loop's settings. The loop itself
  // is made by open_loop(), so a front end can check what it will write first.
  static Result<std::unique_ptr<Simulation>> build(const SceneDef& scene, const SimulationOptions& options = {});
  // The same with tissues the caller built (a model of its own); `scene.tissues` is then not built,
  // but a tissue i < scene.tissues.size() still takes that entry's physics rate and role.
  static Result<std::unique_ptr<Simulation>> build(const SceneDef& scene, std::vector<std::unique_ptr<Tissue>> tissues,
                                                   const SimulationOptions& options = {});
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  const SceneDef& scene() const noexcept;
  const SimulationOptions& options() const noexcept;
  const LoopSettings& loop_settings() const noexcept;
  std::uint64_t duration_ticks() const noexcept;  // the scene's duration / dt, rounded

  size_t tissue_count() const noexcept;
  Tissue& tissue(size_t i) noexcept;
  // The tissue's SnapshotTissue wrapper (options.snapshots), else null.
  SnapshotTissue* snapshot(size_t i) noexcept;
  // The first tissue with that role ("skin", "vein", ...); -1 when none.
  int tissue_with_role(std::string_view role) const noexcept;

  std::span<const SimulationTool> tools() const noexcept;
  const SimulationTool* tool(std::string_view name) const noexcept;   // null when none has that name
  const SimulationTool* tool(ToolRole role) const noexcept;           // the first of that role, or null

  // Make the haptic loop over the tissues and tools (not started), recording every tick to `csv`
  // (via <csv>.part; "" = no recording); a loop made before is stopped and replaced.
  Result<HapticLoop*> open_loop(const std::filesystem::path& csv = {});
  HapticLoop* loop() noexcept;  // the loop open_loop made; null before it, or after replace_tissue
  // Replace tissue i (a material edited in the viewer), built from `def` (make_tissue): the loop is
  // stopped and closed, the tissue wrapped as the others are, the layers relinked, and the scene's
  // entry, its physics rate and the outcome model follow `def`; open_loop() again to go on.
  Status replace_tissue(size_t i, std::unique_ptr<Tissue> tissue, const TissueDef& def);

  struct Impl;

 private:
  explicit Simulation(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace palpate
