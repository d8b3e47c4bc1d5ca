// simulation.cpp — Simulation::build: a SceneDef compiled once into tissues, tools, devices, the
// outcome model, the loop's settings and the loop; the only place a scene is assembled.
#include <palpate/simulation.h>

#include <palpate/anatomy.h>
#include <palpate/outcome.h>
#include <palpate/ultrasound.h>
#include <palpate/tissue_files.h>

#include <cmath>

namespace palpate {

const char* tool_role_name(ToolRole role) noexcept {
  switch (role) {
    case ToolRole::sphere: return "sphere";
    case ToolRole::needle: return "needle";
    case ToolRole::blade: return "blade";
    case ToolRole::ultrasound_probe: return "ultrasound_probe";
    case ToolRole::grasper: return "grasper";
  }
  return "?";
}

namespace {

std::string scene_where(const SceneDef& scene) {
  return scene.file.empty() ? std::string("scene") : scene.file.string();
}

}  // namespace

Result<LoopSettings> scene_loop_settings(const SceneDef& scene_in, const SimulationOptions& options) {
  auto expanded = expand_anatomy(scene_in);  // the outcome model reads every tissue's role
  if (!expanded) return expanded.error();
  const SceneDef& scene = *expanded;
  const std::string where = scene_where(scene);
  if (!(scene.dt > 0) || !std::isfinite(scene.dt)) return Error{where + ": dt must be > 0 s"};
  LoopSettings ls;
  ls.dt = scene.dt;
  ls.realtime = options.realtime;
  ls.try_realtime_priority = options.realtime_priority;
  ls.max_ticks = options.stop_after_duration ? static_cast<std::uint64_t>(std::llround(scene.duration / scene.dt)) : 0;
  ls.ramp_in = scene.device.ramp_in;
  if (scene.device.coupling == "direct")
    ls.coupling = Coupling::direct;
  else if (scene.device.coupling == "virtual")
    ls.coupling = Coupling::virtual_;
  else
    return Error{where + ": device.coupling '" + scene.device.coupling + "' is not one of direct | virtual"};
  ls.proxy_mass = scene.device.proxy_mass;
  ls.watchdog.overrun_margin = options.overrun_margin >= 0 ? options.overrun_margin : scene.device.overrun_margin;
  ls.watchdog.stall_timeout = scene.device.stall_timeout;
  ls.passivity = passivity_settings(scene.device);
  ls.tool = scene.tool;
  ls.outcome = build_outcome_model(scene);
  return ls;
}

struct Simulation::Impl {
  SceneDef scene;
  SimulationOptions options;
  LoopSettings settings;
  std::vector<std::unique_ptr<Tissue>> tissues;  // what the loop steps (the wrappers, with snapshots)
  std::vector<Tissue*> inner;                    // the models themselves (linked as layers)
  std::vector<SnapshotTissue*> snaps;            // tissues[i] as a SnapshotTissue, or null
  std::vector<std::unique_ptr<Device>> owned_devices;
  std::unique_ptr<NeckCompression> probe_model;
  std::vector<SimulationTool> tools;
  std::unique_ptr<HapticLoop> loop;

  void link() {
    link_layers(inner);  // stacked layers press on each other (scene order: outside in)
  }

  void adopt(size_t i, std::unique_ptr<Tissue> t) {
    inner[i] = t.get();
    if (options.snapshots) {
      auto wrapped = std::make_unique<SnapshotTissue>(std::move(t));
      snaps[i] = wrapped.get();
      tissues[i] = std::move(wrapped);
    } else {
      snaps[i] = nullptr;
      tissues[i] = std::move(t);
    }
  }

  double physics_dt(size_t i) const {
    if (i < options.physics_dt.size()) return options.physics_dt[i];
    if (i < scene.tissues.size()) return scene_physics_dt(scene.tissues[i]);
    return 0.0;  // a tissue the caller built beyond the scene's
  }

  Device* override_for(const std::string& tool) const {
    for (const DeviceOverride& d : options.devices)
      if (d.tool == tool) return d.device;
    return nullptr;
  }

  Status make_loop(const std::filesystem::path& csv) {
    if (loop) loop->stop();
    loop.reset();
    LoopSettings ls = settings;
    ls.csv = csv;
    std::vector<LoopTissue> lt;
    for (size_t i = 0; i < tissues.size(); ++i) lt.push_back({tissues[i].get(), physics_dt(i)});
    std::vector<LoopTool> extra;
    for (const SimulationTool& t : tools)
      if (t.loop_index > 0) {
        extra.push_back({t.name, t.device, t.model, t.device_def ? t.device_def->ramp_in : 0.1, std::nullopt,
                         t.device_def ? passivity_settings(*t.device_def) : PassivitySettings{}});
        if (t.role == ToolRole::grasper && scene.grasper) {
          ToolDef g;
          g.kind = "sphere";
          g.radius = scene.grasper->radius;
          g.axis = t.axis;
          extra.back().tissue_tool = g;
        }
      }
    auto built = HapticLoop::create(*tools.front().device, std::move(lt), ls, std::move(extra));
    if (!built) return built.error();
    loop = std::move(*built);
    return {};
  }
};

Result<std::unique_ptr<Simulation>> Simulation::build(const SceneDef& scene_in, const SimulationOptions& options) {
  auto scene = expand_anatomy(scene_in);  // the neck's layers generated here, not by the parser
  if (!scene) return scene.error();
  std::vector<std::unique_ptr<Tissue>> tissues;
  const TissueServices services = file_tissue_services(options.cache.empty() ? default_predictor_cache() : options.cache);
  for (int i = 0; i < static_cast<int>(scene->tissues.size()); ++i) {
    auto t = make_tissue(*scene, i, services);
    if (!t) return t.error();
    tissues.push_back(std::move(*t));
  }
  return build(*scene, std::move(tissues), options);
}

Result<std::unique_ptr<Simulation>> Simulation::build(const SceneDef& scene_in, std::vector<std::unique_ptr<Tissue>> tissues,
                                                      const SimulationOptions& options) {
  auto expanded = expand_anatomy(scene_in);
  if (!expanded) return expanded.error();
  const SceneDef& scene = *expanded;
  const std::string where = scene_where(scene);
  auto impl = std::make_unique<Impl>();
  Impl& m = *impl;
  m.scene = scene;
  m.options = options;
  for (size_t i = 0; i < tissues.size(); ++i)
    if (!tissues[i]) return Error{where + ": tissue " + std::to_string(i) + " is null"};
  for (const DeviceOverride& d : options.devices)
    if (!d.device || (d.tool != "tool" && !(d.tool == "probe" && scene.probe) && !(d.tool == "grasper" && scene.grasper)))
      return Error{where + ": a device was handed in for tool '" + d.tool + "', which " +
                   (d.device ? "the scene does not have (its tools: tool" + std::string(scene.probe ? ", probe" : "") +
                                   std::string(scene.grasper ? ", grasper" : "") + ")"
                             : "is null")};

  auto settings = scene_loop_settings(scene, options);
  if (!settings) return settings.error();
  m.settings = std::move(*settings);

  // Tools: the scene's `tool` on its `device`, then its ultrasound `probe` on `probe.device`. A
  // device in the hand needs the wall clock: a headless run would send it forces of simulated time
  // (2,000 ticks while a Touch's servo ran 104 frames). Refused before any device is opened.
  const bool probe = scene.probe.has_value();
  if (probe && !scene.anatomy) return Error{where + ": probe: needs an 'anatomy' (the ultrasound images the generated neck)"};
  struct Want {
    const char* name;
    const char* key;
    ToolRole role;
    const DeviceDef* def;
    Vec3 axis;
  };
  // The definitions the tools keep pointing at are the Simulation's own copy of the scene.
  const ToolRole role = scene.tool.kind == "needle" ? ToolRole::needle
                        : scene.tool.kind == "blade" ? ToolRole::blade
                                                     : ToolRole::sphere;
  std::vector<Want> wants = {{"tool", "device", role,
                              &m.scene.device, scene.tool.axis}};
  if (probe) wants.push_back({"probe", "probe.device", ToolRole::ultrasound_probe, &m.scene.probe->device, scene.probe->axis});
  if (scene.grasper) {
    if (probe) return Error{where + ": grasper: the other hand holds the ultrasound probe or a grasper, not both"};
    wants.push_back({"grasper", "grasper.device", ToolRole::grasper, &m.scene.grasper->device, Vec3(0, -1, 0)});
  }
  for (const Want& w : wants) {
    Device* given = m.override_for(w.name);
    if (!given && (w.def->kind == "openhaptics" || w.def->kind == "forcedimension") && !options.realtime)
      return Error{where + ": " + w.key + " kind '" + w.def->kind + "' needs a realtime run (`palpate run --realtime`, "
                   "SimulationOptions::realtime): a headless run is not paced by the wall clock"};
  }
  for (size_t k = 0; k < wants.size(); ++k) {
    const Want& w = wants[k];
    SimulationTool t;
    t.name = w.name;
    t.role = w.role;
    t.loop_index = k;
    t.device_def = w.def;
    t.axis = w.axis;
    t.device = m.override_for(w.name);
    if (!t.device) {
      auto d = make_device(*w.def, w.axis, where, w.key);
      if (!d) return d.error();
      t.device = d->get();
      m.owned_devices.push_back(std::move(*d));
    }
    if (w.role == ToolRole::ultrasound_probe) {
      m.probe_model = std::make_unique<NeckCompression>(*scene.anatomy, *scene.probe);
      t.model = m.probe_model.get();
    }
    m.tools.push_back(std::move(t));
  }

  // A replay of a recorded run: a tissue whose recording says at which tick its off-thread work
  // (a cut's corrections and new factors) took effect takes it in at those ticks, so the replay
  // repeats the recorded run's wound and forces tick for tick, a real-time run's too
  // (docs/models/cutting.md, "Recording and replay").
  if (!m.override_for("tool") && scene.device.kind == "replay" && !scene.device.recording.empty())
    for (const auto& t : tissues) {
      auto installed = load_recording_counts(scene.device.recording, t->name() + ".cut_installed");
      if (!installed) return installed.error();
      if (installed->empty()) continue;
      if (Status s = t->set_install_schedule(*installed); !s)
        return Error{scene.device.recording.string() + ": column '" + t->name() + ".cut_installed': " + s.error().message};
    }

  // Tissues: linked as layers as built, then (for frames and the viewer) each wrapped so its drawn
  // state is handed to other threads without the stepping thread waiting.
  m.tissues.resize(tissues.size());
  m.inner.resize(tissues.size());
  m.snaps.resize(tissues.size());
  for (size_t i = 0; i < tissues.size(); ++i) m.inner[i] = tissues[i].get();
  m.link();
  for (size_t i = 0; i < tissues.size(); ++i) m.adopt(i, std::move(tissues[i]));
  return std::unique_ptr<Simulation>(new Simulation(std::move(impl)));
}

Simulation::Simulation(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

Simulation::~Simulation() {
  if (impl_ && impl_->loop) impl_->loop->stop();  // before the tissues and devices it uses go
}

const SceneDef& Simulation::scene() const noexcept { return impl_->scene; }
const SimulationOptions& Simulation::options() const noexcept { return impl_->options; }
const LoopSettings& Simulation::loop_settings() const noexcept { return impl_->settings; }
std::uint64_t Simulation::duration_ticks() const noexcept {
  return static_cast<std::uint64_t>(std::llround(impl_->scene.duration / impl_->scene.dt));
}
size_t Simulation::tissue_count() const noexcept { return impl_->tissues.size(); }
Tissue& Simulation::tissue(size_t i) noexcept { return *impl_->tissues[i]; }
SnapshotTissue* Simulation::snapshot(size_t i) noexcept { return i < impl_->snaps.size() ? impl_->snaps[i] : nullptr; }

int Simulation::tissue_with_role(std::string_view role) const noexcept {
  const auto& defs = impl_->scene.tissues;
  for (size_t i = 0; i < defs.size() && i < impl_->tissues.size(); ++i)
    if (defs[i].role == role) return static_cast<int>(i);
  return -1;
}

std::span<const SimulationTool> Simulation::tools() const noexcept { return impl_->tools; }

const SimulationTool* Simulation::tool(std::string_view name) const noexcept {
  for (const SimulationTool& t : impl_->tools)
    if (t.name == name) return &t;
  return nullptr;
}

const SimulationTool* Simulation::tool(ToolRole role) const noexcept {
  for (const SimulationTool& t : impl_->tools)
    if (t.role == role) return &t;
  return nullptr;
}

Result<HapticLoop*> Simulation::open_loop(const std::filesystem::path& csv) {
  if (Status s = impl_->make_loop(csv); !s) return s.error();
  return impl_->loop.get();
}

HapticLoop* Simulation::loop() noexcept { return impl_->loop.get(); }

Status Simulation::replace_tissue(size_t i, std::unique_ptr<Tissue> tissue, const TissueDef& def) {
  Impl& m = *impl_;
  if (i >= m.tissues.size()) return Error{"simulation: no tissue " + std::to_string(i)};
  if (!tissue) return Error{"simulation: tissue " + std::to_string(i) + ": the replacement is null"};
  SceneDef scene = m.scene;
  if (i < scene.tissues.size()) scene.tissues[i] = def;
  auto settings = scene_loop_settings(scene, m.options);
  if (!settings) return settings.error();
  if (m.loop) m.loop->stop();
  m.loop.reset();  // nothing steps or reads the old tissue any more
  // Only the tissue's entry changes: the tools point into m.scene's device definitions.
  if (i < m.scene.tissues.size()) m.scene.tissues[i] = def;
  m.settings = std::move(*settings);
  m.adopt(i, std::move(tissue));
  m.link();
  return {};
}

}  // namespace palpate
