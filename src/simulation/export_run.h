// export_run.h — a run's exports (RunOptions::exports; docs/export.md): the tissues' snapshots and
// the tools' samples turned into VTU grids (with a PVD of their times) and an animated glTF scene.
// Called by run_simulation on its own thread, off the tick path, where frames are drawn.
#pragma once

#include <palpate/core.h>
#include <palpate/export.h>
#include <palpate/haptics.h>
#include <palpate/scene_def.h>
#include <palpate/tissue.h>

#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace palpate {

class Simulation;

// What a tool looks like at a saved frame.
struct ExportToolSample {
  bool valid = false;  // false before the first tick (t = 0): no pose yet
  Vec3 position = Vec3::Zero();
  Quat orientation = Quat::Identity();
  Vec3 axis = Vec3(0, -1, 0);
  Vec3 force = Vec3::Zero();  // N, sent to its device
};

class RunExporter {
 public:
  // Checks the formats ("vtu", "gltf"), makes `out` (and out/vtu) and proves it writable, removes an
  // earlier run's exports there; `rest` are the tissues' snapshots before the first tick.
  static Result<std::unique_ptr<RunExporter>> open(Simulation& sim, const std::vector<std::string>& formats,
                                                   const std::filesystem::path& out, int resolution,
                                                   std::span<const TissueSnapshot> rest);
  ~RunExporter();
  // One saved state at `time` (s); `tools` in the simulation's tool order.
  Status add(double time, std::span<const TissueSnapshot> tissues, std::span<const ExportToolSample> tools);
  // The tools' first pose (after the first tick): the t = 0 state's tools, which have none yet.
  Status first_pose(std::span<const ExportToolSample> tools);
  // Writes run.pvd and run.glb (whichever were asked for); `files` gets every file written.
  Status finish(std::vector<std::filesystem::path>& files);
  // The states saved so far: their times and a file each (the first part's .vtu, else run.glb).
  const std::vector<std::pair<double, std::filesystem::path>>& saved() const { return saved_; }

 private:
  RunExporter() = default;
  struct Part;
  ExportGrid tissue_grid(size_t i, const TissueSnapshot& snap, double time, Status& status);
  Status write_tools(size_t k, double time, std::span<const ExportToolSample> tools);

  std::filesystem::path out_;
  bool vtu_ = false, gltf_ = false;
  std::vector<std::unique_ptr<Part>> parts_;  // one per tissue
  std::vector<std::string> tool_names_, tool_kinds_;
  std::vector<double> tool_radius_, tool_length_;
  std::vector<Vec3> tool_first_;  // each tool's position at its first valid sample (displacement)
  std::vector<bool> tool_seen_;
  std::vector<PvdDataSet> pvd_;
  std::unique_ptr<GltfScene> gltf_scene_;
  std::vector<std::vector<float>> gltf_points_;  // scratch
  std::vector<std::pair<size_t, double>> pending_tools_;  // tools files waiting for a first pose (t = 0)
  bool gltf_waiting_ = false;  // a frame before any tool was valid (t = 0) waits for the first pose
  std::vector<std::vector<std::vector<float>>> gltf_held_;  // that frame's surfaces
  double gltf_held_time_ = 0;
  std::vector<std::pair<double, std::filesystem::path>> saved_;
  std::vector<std::filesystem::path> written_;
  int digits_ = 4;
  size_t count_ = 0;
};

}  // namespace palpate
