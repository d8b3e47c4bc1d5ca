// palpate/tissue.h — the interface every tissue model offers the haptic loop, and its factory.
#pragma once

#include <palpate/core.h>
#include <palpate/mesh.h>
#include <palpate/scene_def.h>

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace palpate {

struct ChargedLayer;  // palpate/charged.h
struct SpringBody;    // palpate/spring.h

// The tool as the tissues see it this tick. For a sphere probe `tip` is its centre; for a needle
// it is the needle's tip and `axis` points from the handle to the tip.
struct ToolState {
  double time = 0;              // s since the start of the run
  Vec3 tip = Vec3::Zero();      // m, the haptic interaction point (HIP)
  Vec3 axis = Vec3(0, -1, 0);   // unit
  Vec3 velocity = Vec3::Zero(); // m/s
  double radius = 0.001;        // m
  double length = 0.0;          // m, needle shaft length, or a blade's edge length (0 for a sphere)
  bool needle = false;
  // A scalpel (docs/models/cutting.md): its cutting edge runs from tip − length·axis to tip. It
  // presses like a probe; pressed in past a material's cutting_force, the tissue its edge sweeps
  // through between two ticks is cut.
  bool blade = false;
  bool grasp = false;           // grasping: a model that supports it pulls along with the tool
};

// Something that happened in a tissue during a step (a puncture, a watchdog reset, ...).
// Fixed-size and allocation-free so a step can emit it.
struct TissueEvent {
  double time = 0;       // s
  const char* kind = ""; // static string: "puncture", "exit", "reset", ...
  int tissue = -1;       // index of the tissue in the scene
  double depth = 0;      // m, tool depth below the tissue's rest surface at the event
  double force = 0;      // N, magnitude of the peak force that led to it
};

// Positions to draw, copied out of the state (the render thread never reads live state).
struct TissueSnapshot {
  std::vector<Vec3f> points;              // particles or masses, m
  std::vector<int> rows_cols;             // {rows, cols} when points form a control grid, else {}
  std::vector<std::array<int, 3>> triangles;  // surface over the points, if any
  std::vector<std::array<int, 2>> links;      // neighbour links or springs
  // Per point, where the model has them (exports: docs/export.md); empty otherwise.
  std::vector<Vec3f> velocities;              // m/s (mass-spring)
  std::vector<Vec3f> loads;                   // N, the external (contact, grasp) load on the point at
                                              // the last step (mass-spring)
  std::vector<std::uint8_t> punctured;        // 1 where the particle's charge is reversed (charged)
  // Neighbour links a blade cut (charged; docs/models/cutting.md): not in `links`, and no triangle
  // of `triangles` has one as an edge; a renderer drawing the control grid drops the cells they
  // lie in (grid_cut_cells in palpate/surface.h). Empty while nothing is cut.
  std::vector<std::array<int, 2>> cut_links;
};

// A tissue model instance wired into a scene. `step` is the 1 kHz path: noexcept, no allocation,
// no locks, no I/O. Numerical trouble is recovered inside (state reset, zero force, an event).
class ContactComplianceSource;  // palpate/contact.h

class Tissue {
 public:
  virtual ~Tissue() = default;
  virtual const std::string& name() const = 0;
  // Advance by dt seconds with the tool where `tool` says; return the force the tissue exerts on
  // the tool (N). Events are appended to the tissue's queue, drained by `drain_events`.
  virtual Vec3 step(const ToolState& tool, double dt) noexcept = 0;
  // Whether the last step() failed (numerical trouble: the state was reset and the force is an
  // ordinary zero). The loop counts it as `step_failed` and restarts the force's ramp-in.
  virtual bool last_step_failed() const noexcept { return false; }
  // Names of the per-tissue figures written as CSV columns; fixed once built.
  virtual std::span<const std::string> figure_names() const = 0;
  // Current values of those figures, out.size() == figure_names().size().
  virtual void figures(std::span<double> out) const noexcept = 0;
  // Move queued events into `out`; returns how many. Never allocates.
  virtual size_t drain_events(std::span<TissueEvent> out) noexcept = 0;
  // Copy what is drawn into `snap` (may allocate: not called from the haptic thread's step).
  virtual void snapshot(TissueSnapshot& snap) const = 0;
  // Back to the rest state.
  virtual void reset() noexcept = 0;
  // Whether a wall-clock paced loop steps this tissue (HapticLoop::create says so): then work a model
  // does off the stepping thread (a cut's correction, a new factor) takes effect when ready and the
  // step never waits for it; otherwise (headless runs, replays) at fixed ticks, so runs repeat exactly.
  virtual void set_real_time(bool real_time) noexcept { (void)real_time; }
  // A second tool in the other hand that acts on the tissues as the first does (a grasper; the
  // scene's `grasper`, LoopTool::tissue_tool): posed before each step(), its force read after it. A
  // model without it ignores the tool and gives it no force.
  virtual void set_second_tool(const ToolState& tool) noexcept { (void)tool; }
  virtual Vec3 second_tool_force() const noexcept { return Vec3::Zero(); }
  // A replay of a recorded run (docs/models/cutting.md, "Recording and replay"): `installed` is the
  // recording's `<tissue>.cut_installed` figure, one value a tick from the first: how much of its
  // off-thread work (a cut's corrections and new factors) the step used at each tick. A headless
  // replay takes that work in at those same ticks, so it repeats the run tick for tick (a real-time
  // loop never waits, and does not follow it). Not called while the loop steps; may allocate; an
  // error for a schedule that is not whole numbers >= 0 rising. Default: nothing to schedule.
  virtual Status set_install_schedule(std::span<const std::int32_t> installed) { (void)installed; return {}; }
  // Layers stacked in a scene press on each other: a tissue may be pushed by the tissues listed
  // before it (scenes list them from the outside in). `above` are those tissues, live; a model
  // without the coupling ignores them. Not called while the haptic loop steps the tissues.
  virtual void set_layers_above(std::span<Tissue* const> above) { (void)above; }
  // This tissue as a charged-particle layer for that coupling, or null for other models.
  virtual const ChargedLayer* charged_layer() const noexcept { return nullptr; }
  // This tissue as a mass-spring body (its model and live state, read-only), or null for other
  // models: for readers outside the haptic path (exports, Python's views) while nothing steps it.
  virtual const SpringBody* spring_body() const noexcept { return nullptr; }
  // This tissue's compliant contact patch for a multi-rate loop (palpate/haptics.h), or null.
  virtual ContactComplianceSource* contact_compliance() noexcept { return nullptr; }
};

// Tell every tissue which ones lie above it: tissues[i] is pressed by tissues[0 .. i-1]. Call it
// after building the tissues and again after replacing one.
void link_layers(std::span<Tissue* const> tissues);

// A predictor as its store found it (TissueServices::read_predictor).
struct StoredPredictor {
  bool present = false;  // a payload was read; otherwise `why` says why none is usable
  std::string payload;   // the spring model's bytes (decode_predictor)
  std::string why;       // absent or unusable: "x.predictor: no predictor file", "...: corrupted: checksum mismatch"
};

// What a tissue model needs from the layers above it, handed in by whoever builds it (the
// Simulation's builder: file_tissue_services() in palpate/tissue_files.h). A model never opens a
// file nor runs a mesher itself (DESIGN.md §3): a program that builds models from meshes it made
// links neither the mesh loaders nor Gmsh or CGAL, and hands in only what its scene needs. A
// service left null is an error naming what was asked for, when a scene needs it.
struct TissueServices {
  // A surface mesh file, scaled and validated against `need` (palpate/mesh_load.h's load_surface).
  std::function<Result<SurfaceMesh>(const std::filesystem::path& file, double scale, const SurfaceRequirements& need)>
      load_surface;
  // A tetrahedral mesh file, scaled and validated (load_tet).
  std::function<Result<TetMesh>(const std::filesystem::path& file, double scale)> load_tet;
  // A closed surface filled with tetrahedra (palpate/meshing.h's tetrahedralize).
  std::function<Result<TetMesh>(const SurfaceMesh& surface, const FillOptions& options)> fill;
  // A surface remeshed isotropically to `target_edge` (remesh_isotropic).
  std::function<Result<SurfaceMesh>(const SurfaceMesh& surface, double target_edge, const std::string& where)> remesh;
  // A spring model's predictor: what is stored at `file` (absent, unusable and why, or its payload);
  // an error when the path is refused outright (a directory, a FIFO, a device: never computed
  // around, nor renamed over). And storing one (atomically).
  std::function<Result<StoredPredictor>(const std::filesystem::path& file)> read_predictor;
  std::function<Status(const std::filesystem::path& file, std::string_view payload)> write_predictor;
  // Where a predictor the scene does not name is kept (material.predictor empty): shared between
  // runs, named by the tissue and predictor_key. Empty: such a predictor is computed every time.
  std::filesystem::path predictor_cache;
};

// Build the tissue a scene describes (its meshes and predictor through `services`; precomputes
// what the model needs). `index` is the tissue's place in the scene, used in events and messages.
// palpate/tissue_files.h has the overload without services, with the files' own.
Result<std::unique_ptr<Tissue>> make_tissue(const SceneDef& scene, int index, const TissueServices& services);

}  // namespace palpate
