// commands.cpp — the CLI's info, precompute and run as functions: the same options, plain Python
// objects back; a run on a thread of its own that Ctrl-C stops at a tick boundary.
#include "module.h"

#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <future>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace palpate::python {

using namespace pybind11::literals;

namespace {

py::dict info(const std::filesystem::path& file, double scale) {
  MeshInfo m;
  {
    std::optional<Error> err;
    {
      py::gil_scoped_release nogil;
      if (is_tet_file(file)) {
        auto r = load_tet(file, scale);
        if (r) m = describe(*r); else err = r.error();
      } else {
        auto r = load_surface(file, scale);
        if (r) m = describe(*r); else err = r.error();
      }
    }
    if (err) raise(*err);
  }
  const bool has_volume = m.kind == "tetrahedral" || m.closed;
  return py::dict("file"_a = file.string(), "kind"_a = m.kind, "vertices"_a = m.vertices, "triangles"_a = m.triangles,
                  "tetrahedra"_a = m.tetrahedra, "bbox_min"_a = vec3_copy(m.bbox_min), "bbox_max"_a = vec3_copy(m.bbox_max),
                  "size"_a = vec3_copy(m.bbox_max - m.bbox_min), "closed"_a = m.closed, "boundary_edges"_a = m.boundary_edges,
                  "manifold"_a = m.manifold, "non_manifold_edges"_a = m.non_manifold_edges,
                  "volume"_a = has_volume ? py::object(py::float_(m.volume)) : py::object(py::none()),
                  "edges"_a = py::dict("count"_a = m.edges.count, "min"_a = m.edges.min, "mean"_a = m.edges.mean,
                                       "median"_a = m.edges.median, "max"_a = m.edges.max));
}

py::dict precompute_one(const std::string& label, SpringNetwork network, const SpringModelOptions& options,
                        const std::filesystem::path& file) {
  const size_t n = network.size(), s = network.springs.size();
  std::optional<Error> err;
  py::dict d;
  double seconds = 0;
  size_t nnz = 0, anchored = 0;
  {
    py::gil_scoped_release nogil;
    const auto t0 = std::chrono::steady_clock::now();
    auto model = build_spring_model(std::move(network), options);
    if (!model) {
      err = Error{label + ": " + model.error().message};
    } else {
      seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      nnz = model->predictor.value.size();
      anchored = model->network.anchors.size();
      if (Status st = save_predictor(file, *model); !st) err = st.error();
    }
  }
  if (err) raise(*err);
  const bool desbrun = options.solver == SpringSolver::desbrun;
  return py::dict("tissue"_a = label, "vertices"_a = n, "springs"_a = s, "anchored"_a = anchored, "dt"_a = options.dt,
                  "solver"_a = desbrun ? "desbrun" : "sparse", "nonzeros"_a = desbrun ? n * n : nnz, "seconds"_a = seconds,
                  "file"_a = file, "bytes"_a = std::filesystem::file_size(file));
}

// `palpate precompute`: a scene's mass-spring tissues (or one: tissue=) or a mesh with the
// material given here; a list of what was written, one dict per predictor.
py::list precompute(const std::filesystem::path& input, std::optional<std::filesystem::path> out,
                    std::optional<std::filesystem::path> cache, std::optional<std::string> tissue, double dt,
                    const std::string& solver_name, const std::string& topology, double stiffness, double youngs_modulus,
                    double spring_damping, double point_damping, double mass, double density, double scale,
                    std::vector<int> anchors) {
  py::list written;
  const auto ext = input.extension().string();
  if (ext == ".yaml" || ext == ".yml") {
    SceneDef scene = take(load_scene(input));
    int done = 0;
    for (size_t i = 0; i < scene.tissues.size(); ++i) {
      const TissueDef& t = scene.tissues[i];
      if (t.model != "mass_spring" || (tissue && t.name != *tissue)) continue;
      auto setup = take(spring_setup(scene, int(i), file_tissue_services(cache ? *cache : default_predictor_cache())));
      if (setup.options.solver == SpringSolver::exact)
        raise(Error{"tissue '" + t.name + "' uses the exact solver, which has no predictor"});
      if (out && done > 0)
        raise(Error{"-o names one file but the scene has several mass_spring tissues; use --tissue NAME"});
      const std::filesystem::path file = out ? *out : setup.predictor;
      written.append(precompute_one(t.name, std::move(setup.network), setup.options, file));
      ++done;
    }
    if (done == 0) raise(Error{input.string() + ": no mass_spring tissue" + (tissue ? " named '" + *tissue + "'" : "")});
    return written;
  }
  SpringMaterialDef m;
  m.topology = topology;
  m.stiffness = stiffness;
  m.youngs_modulus = youngs_modulus;
  m.spring_damping = spring_damping;
  m.mass = mass;
  m.density = density;
  auto net_opt = take(network_options(m, std::move(anchors), input.string()));
  auto solver = parse_solver(solver_name, "--solver");
  if (!solver || *solver == SpringSolver::exact) raise(Error{"--solver must be desbrun or sparse"});
  MeshRef ref;
  ref.file = input;
  ref.scale = scale;
  SpringNetwork net;
  {
    std::optional<Error> err;
    {
      py::gil_scoped_release nogil;
      auto r = spring_network_from_file(ref, net_opt);
      if (r) net = std::move(*r); else err = r.error();
    }
    if (err) raise(*err);
  }
  SpringModelOptions o;
  o.dt = dt;
  o.solver = *solver;
  o.point_damping = point_damping;
  std::filesystem::path file = out ? *out : std::filesystem::path(input).replace_extension(".predictor");
  written.append(precompute_one(input.filename().string(), std::move(net), o, file));
  return written;
}

py::dict summary_dict(const RunSummary& s) {
  py::list events, frames, us, plots, physics, tools, exports, export_files;
  for (const RunEvent& e : s.events)
    events.append(py::dict("time"_a = e.time, "kind"_a = e.kind, "tissue"_a = e.tissue, "depth"_a = e.depth, "force"_a = e.force));
  for (const RunFrame& f : s.frames) frames.append(py::dict("time"_a = f.time, "file"_a = f.file));
  for (const RunFrame& f : s.ultrasound) us.append(py::dict("time"_a = f.time, "file"_a = f.file));
  for (const RunFrame& f : s.exports) exports.append(py::dict("time"_a = f.time, "file"_a = f.file));
  for (const auto& f : s.export_files) export_files.append(py::cast(f));
  for (const auto& p : s.plots) plots.append(py::cast(p));
  for (const LoopToolStats& t : s.tools)
    tools.append(py::dict("name"_a = t.name, "max_force"_a = t.max_force, "max_force_limit"_a = t.max_force_limit,
                          "safety"_a = safety_dict(t.safety)));
  for (const LoopPhysicsStats& p : s.physics)
    physics.append(py::dict("tissue"_a = p.tissue, "period"_a = p.period, "steps"_a = p.steps, "step"_a = timing(p.step),
                            "late"_a = p.late));
  return py::dict("ticks"_a = s.ticks, "interrupted"_a = s.interrupted, "dt"_a = s.dt,
                  "step"_a = py::dict("median"_a = s.step_median, "p99"_a = s.step_p99, "max"_a = s.step_max),
                  "stages"_a = stages_dict(s.stages), "max_force"_a = s.max_force, "realtime"_a = s.realtime,
                  "period"_a = timing(s.period), "deadline_misses"_a = s.deadline_misses, "safety"_a = safety_dict(s.safety),
                  "recorder_dropped"_a = s.recorder_dropped, "events"_a = events, "metrics"_a = metrics_dict(s.metrics),
                  "csv"_a = s.csv, "summary_json"_a = s.summary_json, "plots"_a = plots, "plot_error"_a = s.plot_error,
                  "frames"_a = frames, "frame_error"_a = s.frame_error, "ultrasound"_a = us,
                  "ultrasound_error"_a = s.ultrasound_error, "exports"_a = exports, "export_files"_a = export_files,
                  "export_error"_a = s.export_error, "tools"_a = tools, "physics"_a = physics,
                  "tissues"_a = s.tissue_names);
}

// `palpate run`: the scene with its own devices for its duration, outputs under `out`; the summary.
py::dict run(const PyScene& scene_in, std::optional<std::filesystem::path> out, std::optional<std::filesystem::path> cache,
             bool realtime, std::optional<std::string> device, std::optional<std::filesystem::path> recording,
             std::optional<std::string> coupling, double physics_rate, int frames, int ultrasound, bool plots,
             const py::object& exports, double export_every) {
  SceneDef scene = scene_in.def;
  if (device) scene.device.kind = *device;
  if (recording) {
    scene.device.recording = *recording;
    if (!device) scene.device.kind = "replay";
  }
  if (coupling) scene.device.coupling = *coupling;
  scene = take(expand_anatomy(scene));
  RunOptions opt;
  if (out) opt.out = *out;
  if (cache) opt.cache = *cache;
  opt.realtime = realtime;
  opt.plots = plots;
  if (physics_rate > 0) opt.physics_dt.assign(scene.tissues.size(), 1.0 / physics_rate);
  opt.frames = frames;
  opt.ultrasound = ultrasound;
  // export: "vtu", "gltf", or a list of them (docs/export.md).
  if (py::isinstance<py::str>(exports)) opt.exports.push_back(exports.cast<std::string>());
  else if (!exports.is_none()) opt.exports = exports.cast<std::vector<std::string>>();
  for (const std::string& f : opt.exports)
    if (f != "vtu" && f != "gltf") throw py::value_error("export: '" + f + "' is not an export format (vtu, gltf)");
  if (!(export_every > 0) || !std::isfinite(export_every))
    throw py::value_error("export_every: " + std::to_string(export_every) + " s, expected a time > 0");
  opt.export_every = export_every;
  // The run goes on a thread of its own, Python never called from it; this one waits without the
  // GIL and looks at Python's signals every 50 ms. Ctrl-C (KeyboardInterrupt, or any signal
  // handler that raises) stops the run at a tick boundary as the CLI's does — the force ramped to
  // zero, the outputs written up to the last tick run, summary.json saying "interrupted": true —
  // and is then raised here.
  std::atomic<bool> interrupt{false};
  opt.interrupt = &interrupt;
  std::packaged_task<Result<RunSummary>()> task([&] { return run_scene(scene, opt); });
  std::future<Result<RunSummary>> result = task.get_future();
  std::thread worker(std::move(task));
  bool signalled = false;
  for (bool done = false; !done;) {
    {
      py::gil_scoped_release nogil;
      done = result.wait_for(std::chrono::milliseconds(50)) == std::future_status::ready;
    }
    if (!done && !signalled && PyErr_CheckSignals() != 0) {
      signalled = true;  // the exception is set now, raised once the run has stopped
      interrupt.store(true);
    }
  }
  worker.join();
  std::optional<Result<RunSummary>> r;
  try {
    r.emplace(result.get());  // an exception the run threw (out of memory) is thrown here
  } catch (...) {
    if (signalled) PyErr_Clear();
    throw;
  }
  if (signalled) throw py::error_already_set();
  return summary_dict(take(std::move(*r)));
}

}  // namespace

void bind_commands(py::module_& m) {
  m.def("info", &info, "file"_a, "scale"_a = 1.0, "`palpate info`: what a mesh holds (a dict).");
  m.def("precompute", &precompute, "input"_a, "out"_a = py::none(), "cache"_a = py::none(), "tissue"_a = py::none(),
        "dt"_a = 0.001, "solver"_a = "sparse", "topology"_a = "tet_edges", "stiffness"_a = 100.0, "youngs_modulus"_a = 0.0,
        "spring_damping"_a = 0.1, "point_damping"_a = 0.5, "mass"_a = 0.1, "density"_a = 0.0, "scale"_a = 1.0,
        "anchors"_a = std::vector<int>{}, "`palpate precompute`: write mass-spring predictors; a list of dicts.");
  m.def("run", [](const py::object& scene, std::optional<std::filesystem::path> out, std::optional<std::filesystem::path> cache,
                  bool realtime, std::optional<std::string> device, std::optional<std::filesystem::path> recording,
                  std::optional<std::string> coupling, double physics_rate, int frames, int ultrasound, bool plots,
                  const py::object& exports, double export_every) {
          return run(to_scene(scene), out, cache, realtime, device, recording, coupling, physics_rate, frames, ultrasound, plots,
                     exports, export_every);
        },
        "scene"_a, "out"_a = py::none(), "cache"_a = py::none(), "realtime"_a = false, "device"_a = py::none(),
        "recording"_a = py::none(), "coupling"_a = py::none(), "physics_rate"_a = 0.0, "frames"_a = 0, "ultrasound"_a = 0,
        "plots"_a = true, "export"_a = py::none(), "export_every"_a = 0.1,
        "`palpate run`: the scene with its devices for its duration (GIL released); the summary. "
        "export: 'vtu', 'gltf' or both in a list (docs/export.md), a state every export_every s.");
}

}  // namespace palpate::python
