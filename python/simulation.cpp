// simulation.cpp — palpate.Simulation: a scene built once and stepped headless with the driven
// tools' poses from Python (step, step_many with the GIL released), and palpate.Tissue: a tissue's
// state as read-only numpy views of palpate's own memory, kept alive by the views themselves.
#include "module.h"

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace palpate::python {

using namespace pybind11::literals;

namespace {

// A material key set from Python through the Def's parameter table (its range and choices), so a
// value the loader would refuse is refused here with the same kind of message.
template <class Def>
bool set_param(Def& def, const std::string& key, const py::handle& value, const std::string& where) {
  for (const Param<Def>& p : param_table(static_cast<const Def*>(nullptr))) {
    if (key != p.key) continue;
    auto range = [&](double v) {
      if (!(v >= p.min && v <= p.max))
        raise(Error{where + ": " + key + ": " + py::str(value).cast<std::string>() + " is out of range [" +
                    std::to_string(p.min) + ", " + std::to_string(p.max) + "]" + (*p.unit ? std::string(" ") + p.unit : "")});
    };
    std::visit(
        [&](auto field) {
          using F = std::remove_reference_t<decltype(def.*field)>;
          if constexpr (std::is_same_v<F, double>) {
            const double v = value.cast<double>();
            range(v);
            def.*field = v;
          } else if constexpr (std::is_same_v<F, int>) {
            const int v = value.cast<int>();
            range(v);
            def.*field = v;
          } else if constexpr (std::is_same_v<F, bool>) {
            def.*field = value.cast<bool>();
          } else if constexpr (std::is_same_v<F, Vec3>) {
            const Vec3 v = to_vec3(value, key.c_str());
            for (int i = 0; i < 3; ++i) range(v[i]);
            def.*field = v;
          } else if constexpr (std::is_same_v<F, std::string>) {
            const auto v = value.cast<std::string>();
            if (*p.choices) {
              const std::string choices = std::string("|") + p.choices + "|";
              if (choices.find("|" + v + "|") == std::string::npos)
                raise(Error{where + ": " + key + ": '" + v + "' is not one of " + p.choices});
            }
            def.*field = v;
          } else {
            def.*field = value.cast<std::filesystem::path>();
          }
        },
        p.field);
    return true;
  }
  return false;
}

// One built simulation and what it steps with. Shared: the Python Simulation holds it, and so does
// every numpy view of its state (through the view's base object), so a view never outlives the
// memory it shows, even after the Python object rebuilt (set_material) or was deleted.
struct Core {
  SceneDef scene;
  std::vector<std::unique_ptr<VirtualDevice>> devices;  // before sim: destroyed after it
  std::vector<std::string> driven;                      // tool names Python drives (devices[i])
  std::vector<Vec3> last_position;                      // per driven tool: the velocity's difference
  std::vector<bool> has_last;
  std::unique_ptr<Simulation> sim;
  HapticLoop* loop = nullptr;
  std::filesystem::path record_dir;  // a temporary folder this Core removes
  std::filesystem::path csv;
  std::vector<std::vector<float>> spring_rest;  // (3n) per tissue: mass-spring rest positions (copy)
  bool finished = false;
  std::mutex stepping;  // one stepping call at a time (taken with the GIL released)

  ~Core() {
    if (loop) loop->stop();
    sim.reset();
    if (!record_dir.empty()) {
      std::error_code ec;
      std::filesystem::remove_all(record_dir, ec);
    }
  }

  int driven_index(const std::string& tool) const {
    for (size_t i = 0; i < driven.size(); ++i)
      if (driven[i] == tool) return int(i);
    return -1;
  }

  // Device side of a pose from Python (called with or without the GIL; no Python here).
  void set_pose(int d, const Vec3& p, const Quat& q, std::uint32_t buttons) noexcept {
    DeviceState s;
    s.position = p;
    s.orientation = q;
    s.buttons = buttons;
    s.velocity = has_last[size_t(d)] ? Vec3((p - last_position[size_t(d)]) / scene.dt) : Vec3::Zero();
    last_position[size_t(d)] = p;
    has_last[size_t(d)] = true;
    devices[size_t(d)]->set_pose(s);
  }
};

std::shared_ptr<Core> build_core(const SceneDef& scene, const std::vector<std::string>& drive, py::object record,
                                 const std::filesystem::path& cache, const std::vector<double>& physics_dt) {
  auto core = std::make_shared<Core>();
  core->scene = scene;
  SimulationOptions o;
  o.cache = cache;
  o.physics_dt = physics_dt;
  o.stop_after_duration = false;
  for (const std::string& name : drive) {
    const DeviceDef& def = name == "probe" && scene.probe       ? scene.probe->device
                           : name == "grasper" && scene.grasper ? scene.grasper->device
                                                                : scene.device;
    auto dev = std::make_unique<VirtualDevice>(device_limits(def));
    o.devices.push_back({name, dev.get()});
    core->devices.push_back(std::move(dev));
    core->driven.push_back(name);
  }
  core->last_position.assign(drive.size(), Vec3::Zero());
  core->has_last.assign(drive.size(), false);
  if (record.is_none() || (py::isinstance<py::bool_>(record) && !record.cast<bool>())) {
  } else if (py::isinstance<py::bool_>(record)) {
    std::string tmpl = (std::filesystem::temp_directory_path() / "palpate-py-XXXXXX").string();
    if (!::mkdtemp(tmpl.data())) raise(Error{"record: cannot make a temporary folder in " + std::filesystem::temp_directory_path().string()});
    core->record_dir = tmpl;
    core->csv = core->record_dir / "run.csv";
  } else {
    core->csv = record.cast<std::filesystem::path>();
  }
  std::optional<Error> err;
  {
    py::gil_scoped_release nogil;  // building precomputes (a mass-spring predictor can take minutes)
    auto built = Simulation::build(scene, o);
    if (built) core->sim = std::move(*built); else err = built.error();
  }
  if (err) raise(*err);
  for (const std::string& name : drive)
    if (!core->sim->tool(name)) raise(Error{"drive: the scene has no tool named '" + name + "' (its tools: tool, and probe when it has one)"});
  // Mass-spring rest positions: the state at build is the rest state (copied once, see TissueView).
  core->spring_rest.resize(core->sim->tissue_count());
  for (size_t i = 0; i < core->sim->tissue_count(); ++i) {
    if (core->sim->tissue(i).charged_layer()) continue;
    TissueSnapshot snap;
    core->sim->tissue(i).snapshot(snap);
    auto& r = core->spring_rest[i];
    r.reserve(3 * snap.points.size());
    for (const Vec3f& p : snap.points) r.insert(r.end(), {p.x(), p.y(), p.z()});
  }
  auto loop = core->sim->open_loop(core->csv);
  if (!loop) raise(loop.error());
  core->loop = *loop;
  return core;
}

// A numpy array over `ptr` (not copied), read-only, whose base keeps `core` alive.
template <class T>
py::array view(const std::shared_ptr<Core>& core, const T* ptr, std::vector<py::ssize_t> shape,
               std::vector<py::ssize_t> strides = {}) {
  py::capsule base(new std::shared_ptr<Core>(core), [](void* p) { delete static_cast<std::shared_ptr<Core>*>(p); });
  py::array a = strides.empty() ? py::array_t<T>(shape, ptr, base) : py::array_t<T>(shape, strides, ptr, base);
  a.attr("setflags")("write"_a = false);
  return a;
}

// One tissue of a Simulation, by index.
struct TissueView {
  std::shared_ptr<Core> core;
  size_t index = 0;

  Tissue& tissue() const { return core->sim->tissue(index); }
  const TissueDef& def() const { return core->sim->scene().tissues[index]; }
  const ChargedLayer* charged() const { return tissue().charged_layer(); }
  const SpringBody* spring() const { return tissue().spring_body(); }
  size_t count() const {
    if (const ChargedLayer* c = charged()) return c->state->x.size();
    return core->spring_rest[index].size() / 3;
  }
};

class PySimulation {
 public:
  PySimulation(const PyScene& scene, std::vector<std::string> drive, py::object record, std::filesystem::path cache,
               std::vector<double> physics_dt)
      : drive_(std::move(drive)), record_(std::move(record)), cache_(std::move(cache)), physics_dt_(std::move(physics_dt)) {
    core_ = build_core(scene.def, drive_, record_, cache_, physics_dt_);
  }

  const std::shared_ptr<Core>& core() const { return core_; }
  Core& c() const {
    if (core_->finished) throw py::value_error("this Simulation was finished: build a new one (or set_material) to step again");
    return *core_;
  }

  double dt() const { return core_->scene.dt; }
  std::uint64_t ticks() const { return core_->loop->stats().ticks; }
  double time() const { return double(ticks()) * dt(); }

  py::list tools() const {
    py::list l;
    for (const SimulationTool& t : core_->sim->tools())
      l.append(py::dict("name"_a = t.name, "role"_a = tool_role_name(t.role), "loop_index"_a = t.loop_index,
                        "driven"_a = core_->driven_index(t.name) >= 0, "axis"_a = vec3_copy(t.axis)));
    return l;
  }

  int driven(const std::string& tool) const {
    const int d = core_->driven_index(tool);
    if (d < 0) throw py::value_error("tool '" + tool + "' is not driven from Python (Simulation(..., drive=[...]))");
    return d;
  }
  size_t loop_index(const std::string& tool) const {
    const SimulationTool* t = core_->sim->tool(tool);
    if (!t) throw py::value_error("no tool named '" + tool + "'");
    return t->loop_index;
  }

  void set_pose(const py::handle& position, const py::handle& orientation, std::uint32_t buttons, const std::string& tool) {
    Core& k = c();
    const int d = driven(tool);
    k.set_pose(d, to_vec3(position, "position"), to_quat(orientation), buttons);
  }

  // Ticks with the poses set (and the scene's own devices for the tools Python does not drive).
  void advance(std::uint64_t n) {
    Core& k = c();
    py::gil_scoped_release nogil;
    std::lock_guard lock(k.stepping);
    k.loop->run_headless(n);
  }

  py::array_t<double> step(const py::handle& position, const py::handle& orientation, std::uint32_t buttons,
                           const std::string& tool) {
    if (!position.is_none()) set_pose(position, orientation, buttons, tool);
    advance(1);
    return vec3_copy(core_->loop->tool_sample(loop_index(tool)).force);
  }

  // poses (N, 3) positions, or (N, 7) positions and orientations (w, x, y, z): one tick each, in
  // C++ with the GIL released; the force sent to the tool's device at each tick, (N, 3) N.
  py::array_t<double> step_many(const py::array_t<double, py::array::c_style | py::array::forcecast>& poses,
                                std::uint32_t buttons, const std::string& tool) {
    Core& k = c();
    if (poses.ndim() != 2 || (poses.shape(1) != 3 && poses.shape(1) != 7))
      throw py::value_error("step_many: poses must be (N, 3) positions or (N, 7) positions and quaternions (w, x, y, z)");
    const int d = driven(tool);
    const size_t li = loop_index(tool);
    const auto n = size_t(poses.shape(0));
    const auto cols = size_t(poses.shape(1));
    const double* in = poses.data();
    py::array_t<double> forces({py::ssize_t(n), py::ssize_t(3)});
    double* out = forces.mutable_data();
    bool bad = false;
    {
      py::gil_scoped_release nogil;
      std::lock_guard lock(k.stepping);
      for (size_t i = 0; i < n; ++i) {
        const double* r = in + i * cols;
        Quat q = Quat::Identity();
        if (cols == 7) {
          q = Quat(r[3], r[4], r[5], r[6]);
          const double norm = q.norm();
          if (!(norm > 0) || !std::isfinite(norm)) {
            bad = true;
            break;
          }
          q.coeffs() /= norm;
        }
        k.set_pose(d, Vec3(r[0], r[1], r[2]), q, buttons);
        k.loop->run_headless(1);
        const Vec3 f = k.loop->tool_sample(li).force;
        out[3 * i] = f.x(), out[3 * i + 1] = f.y(), out[3 * i + 2] = f.z();
      }
    }
    if (bad) throw py::value_error("step_many: a zero or non-finite quaternion");
    return forces;
  }

  py::dict sample(const std::string& tool) const {
    const ToolSample s = core_->loop->tool_sample(loop_index(tool));
    return py::dict("valid"_a = s.valid, "time"_a = s.time, "tick"_a = s.tick, "position"_a = vec3_copy(s.position),
                    "orientation"_a = py::make_tuple(s.orientation.w(), s.orientation.x(), s.orientation.y(), s.orientation.z()),
                    "axis"_a = vec3_copy(s.axis), "force"_a = vec3_copy(s.force));
  }

  py::dict stats() const {
    const LoopStats s = core_->loop->stats();
    py::list tools;
    for (const LoopToolStats& t : s.tools)
      tools.append(py::dict("name"_a = t.name, "max_force"_a = t.max_force, "max_force_limit"_a = t.max_force_limit,
                            "safety"_a = safety_dict(t.safety), "last_force"_a = vec3_copy(t.last_force)));
    return py::dict("ticks"_a = s.ticks, "step"_a = timing(s.step), "stages"_a = stages_dict(s.stages),
                    "safety"_a = safety_dict(s.safety), "max_force"_a = s.max_force, "metrics"_a = metrics_dict(s.metrics),
                    "last_force"_a = vec3_copy(s.last_force), "last_position"_a = vec3_copy(s.last_position),
                    "recorder_dropped"_a = s.recorder_dropped, "tools"_a = tools);
  }

  py::dict metrics() const { return metrics_dict(core_->loop->stats().metrics); }

  // Ends the recording: the events (tissue names, not indices) and the kept series as arrays.
  py::dict finish() {
    Core& k = c();
    {
      py::gil_scoped_release nogil;
      std::lock_guard lock(k.stepping);
      k.loop->stop();
    }
    k.finished = true;
    check(k.loop->finish_recording());
    py::list events;
    for (const HapticLoop::Event& e : k.loop->events())
      events.append(py::dict("time"_a = e.time, "kind"_a = e.kind,
                             "tissue"_a = e.tissue >= 0 && size_t(e.tissue) < k.sim->tissue_count()
                                              ? py::object(py::str(k.sim->tissue(size_t(e.tissue)).name()))
                                              : py::object(py::none()),
                             "depth"_a = e.depth, "force"_a = e.force));
    py::dict series;
    const auto& cols = k.loop->series_columns();
    const auto& data = k.loop->series();
    for (size_t i = 0; i < cols.size() && i < data.size(); ++i)
      series[py::str(cols[i])] = py::array_t<double>(py::ssize_t(data[i].size()), data[i].data());
    return py::dict("events"_a = events, "series"_a = series, "metrics"_a = metrics(),
                    "csv"_a = k.record_dir.empty() && !k.csv.empty() ? py::object(py::cast(k.csv)) : py::object(py::none()));
  }

  // The one write path: a tissue's material keys changed (range-checked by its table) and the whole
  // simulation rebuilt from the changed scene (t = 0, at rest). Views taken before still show the
  // previous build (it lives while they do): take them again.
  void set_material(const std::string& tissue, const py::kwargs& values) {
    SceneDef scene = core_->sim->scene();  // expanded: the anatomy's layers are tissues by now
    TissueDef* t = nullptr;
    for (TissueDef& x : scene.tissues)
      if (x.name == tissue) t = &x;
    if (!t) throw py::value_error("set_material: no tissue named '" + tissue + "'");
    const std::string where = (scene.file.empty() ? std::string("<scene>") : scene.file.string()) + ": tissue '" + tissue + "': material";
    for (auto [k, v] : values) {
      const auto key = k.cast<std::string>();
      const bool ok = t->model == "mass_spring" ? set_param(t->spring, key, v, where) : set_param(t->charged, key, v, where);
      if (!ok) raise(Error{where + ": unknown key '" + key + "' for a " + t->model + " material"});
    }
    auto fresh = build_core(scene, drive_, record_, cache_, physics_dt_);
    {
      py::gil_scoped_release nogil;
      std::lock_guard lock(core_->stepping);
      core_->loop->stop();
    }
    core_ = std::move(fresh);
  }

  PyScene scene() const { return {core_->sim->scene()}; }

 private:
  std::shared_ptr<Core> core_;
  std::vector<std::string> drive_;
  py::object record_;
  std::filesystem::path cache_;
  std::vector<double> physics_dt_;
};

}  // namespace

void bind_simulation(py::module_& m) {
  py::class_<TissueView>(m, "Tissue",
                         "One tissue of a Simulation. State arrays are read-only views of palpate's memory "
                         "(see docs/python.md: which are views, which are copies).")
      .def_property_readonly("name", [](const TissueView& t) { return t.tissue().name(); })
      .def_property_readonly("index", [](const TissueView& t) { return t.index; })
      .def_property_readonly("model", [](const TissueView& t) { return t.def().model; })
      .def_property_readonly("role", [](const TissueView& t) { return t.def().role; })
      .def_property_readonly("count", &TissueView::count, "Particles (charged) or masses (mass-spring).")
      .def_property_readonly("layout", [](const TissueView& t) { return t.charged() ? "soa" : t.spring() ? "aos" : "copy"; },
                             "'soa': x, y, z are views (n,) float32; 'aos': positions and velocities are (n, 3) "
                             "float64 views (mass-spring); 'copy': positions is a (n, 3) copy (another model).")
      .def_property_readonly("x", [](const TissueView& t) -> py::object {
            const ChargedLayer* c = t.charged();
            if (!c) return py::none();
            return view(t.core, c->state->x.data(), {py::ssize_t(c->state->x.size())});
          }, "Charged: particle x (n,) float32, m: a view. Mass-spring: None (positions is a copy).")
      .def_property_readonly("y", [](const TissueView& t) -> py::object {
            const ChargedLayer* c = t.charged();
            if (!c) return py::none();
            return view(t.core, c->state->y.data(), {py::ssize_t(c->state->y.size())});
          })
      .def_property_readonly("z", [](const TissueView& t) -> py::object {
            const ChargedLayer* c = t.charged();
            if (!c) return py::none();
            return view(t.core, c->state->z.data(), {py::ssize_t(c->state->z.size())});
          })
      .def_property_readonly("positions", [](const TissueView& t) -> py::object {
            if (const ChargedLayer* c = t.charged()) {
              const auto n = py::ssize_t(c->state->x.size());
              return py::make_tuple(view(t.core, c->state->x.data(), {n}), view(t.core, c->state->y.data(), {n}),
                                    view(t.core, c->state->z.data(), {n}));
            }
            if (const SpringBody* b = t.spring()) {
              const RowMat3d& x = b->state->x;
              return view(t.core, x.data(), {py::ssize_t(x.rows()), py::ssize_t(3)});
            }
            TissueSnapshot snap;
            t.tissue().snapshot(snap);
            py::array_t<float> a({py::ssize_t(snap.points.size()), py::ssize_t(3)});
            float* p = a.mutable_data();
            for (size_t i = 0; i < snap.points.size(); ++i)
              p[3 * i] = snap.points[i].x(), p[3 * i + 1] = snap.points[i].y(), p[3 * i + 2] = snap.points[i].z();
            return a;
          },
          "Charged: (x, y, z), three (n,) float32 views. Mass-spring: a (n, 3) float64 view of its state's "
          "positions (SpringState::x).")
      .def_property_readonly("velocities", [](const TissueView& t) -> py::object {
            const SpringBody* b = t.spring();
            if (!b) return py::none();
            const RowMat3d& v = b->state->v;
            return view(t.core, v.data(), {py::ssize_t(v.rows()), py::ssize_t(3)});
          },
          "m/s. Mass-spring: a (n, 3) float64 view of its state's velocities (SpringState::v). Charged: None "
          "(its particles carry no velocity).")
      .def_property_readonly("rest_positions", [](const TissueView& t) -> py::object {
            if (const ChargedLayer* c = t.charged()) {
              const auto n = py::ssize_t(c->model->origin_x.size());
              return py::make_tuple(view(t.core, c->model->origin_x.data(), {n}), view(t.core, c->model->origin_y.data(), {n}),
                                    view(t.core, c->model->origin_z.data(), {n}));
            }
            if (const SpringBody* b = t.spring()) {
              const RowMat3d& r = b->model->network.rest;
              return view(t.core, r.data(), {py::ssize_t(r.rows()), py::ssize_t(3)});
            }
            const auto& r = t.core->spring_rest[t.index];
            return view(t.core, r.data(), {py::ssize_t(r.size() / 3), py::ssize_t(3)});
          },
          "Charged: the model's origins (x, y, z), (n,) float32 views. Mass-spring: a (n, 3) float64 view of its "
          "network's rest positions.")
      .def_property_readonly("flags", [](const TissueView& t) -> py::object {
            const ChargedLayer* c = t.charged();
            if (!c) return py::none();
            return view(t.core, c->state->flags.data(), {py::ssize_t(c->state->flags.size())});
          }, "Charged: (n,) uint8 view: bit 0 active, bit 1 queued, bit 2 charge reversed (a hole).")
      .def_property_readonly("force", [](const TissueView& t) -> py::object {
            if (const ChargedLayer* c = t.charged()) return view(t.core, c->state->force.data(), {3});
            const auto names = t.tissue().figure_names();
            std::vector<double> v(names.size());
            t.tissue().figures(v);
            Vec3 f = Vec3::Zero();
            for (size_t i = 0; i < names.size(); ++i) {
              if (names[i] == "force_x_N") f.x() = v[i];
              if (names[i] == "force_y_N") f.y() = v[i];
              if (names[i] == "force_z_N") f.z() = v[i];
            }
            return vec3_copy(f);
          }, "N, the tissue's force on the tool at its last step, (3,) float64: a view (charged), a copy (mass-spring).")
      .def("figures", [](const TissueView& t) {
            const auto names = t.tissue().figure_names();
            std::vector<double> v(names.size());
            t.tissue().figures(v);
            py::dict d;
            for (size_t i = 0; i < names.size(); ++i) d[py::str(names[i])] = v[i];
            return d;
          }, "The tissue's figures (its run.csv columns) now: a dict of floats.")
      .def("snapshot", [](const TissueView& t) {
            TissueSnapshot s;
            t.tissue().snapshot(s);
            py::array_t<float> pts({py::ssize_t(s.points.size()), py::ssize_t(3)});
            for (size_t i = 0; i < s.points.size(); ++i)
              for (int k = 0; k < 3; ++k) pts.mutable_at(py::ssize_t(i), k) = s.points[i][k];
            py::array_t<int> tri({py::ssize_t(s.triangles.size()), py::ssize_t(3)});
            for (size_t i = 0; i < s.triangles.size(); ++i)
              for (int k = 0; k < 3; ++k) tri.mutable_at(py::ssize_t(i), k) = s.triangles[i][size_t(k)];
            py::array_t<int> links({py::ssize_t(s.links.size()), py::ssize_t(2)});
            for (size_t i = 0; i < s.links.size(); ++i)
              for (int k = 0; k < 2; ++k) links.mutable_at(py::ssize_t(i), k) = s.links[i][size_t(k)];
            return py::dict("points"_a = pts, "triangles"_a = tri, "links"_a = links, "rows_cols"_a = s.rows_cols);
          }, "A copy of what is drawn: points (n, 3) float32, triangles, links.")
      .def("__repr__", [](const TissueView& t) { return "<palpate.Tissue '" + t.tissue().name() + "' " + t.def().model + ">"; });

  py::class_<PySimulation>(m, "Simulation",
                           "A scene built once (Simulation::build) and stepped headless, tick by tick, with the "
                           "driven tools' poses from Python.")
      .def(py::init([](const py::object& scene, std::vector<std::string> drive, py::object record,
                       std::optional<std::filesystem::path> cache, std::vector<double> physics_dt) {
             return std::make_unique<PySimulation>(to_scene(scene), std::move(drive), std::move(record),
                                                   cache ? *cache : std::filesystem::path(), std::move(physics_dt));
           }),
           "scene"_a, "drive"_a = std::vector<std::string>{"tool"}, "record"_a = true, "cache"_a = py::none(),
           "physics_dt"_a = std::vector<double>{})
      .def_property_readonly("dt", &PySimulation::dt)
      .def_property_readonly("ticks", &PySimulation::ticks)
      .def_property_readonly("time", &PySimulation::time)
      .def_property_readonly("duration_ticks", [](const PySimulation& s) { return s.core()->sim->duration_ticks(); })
      .def_property_readonly("scene", &PySimulation::scene)
      .def_property_readonly("tools", &PySimulation::tools)
      .def_property_readonly("tissues", [](const PySimulation& s) {
            std::vector<TissueView> v;
            for (size_t i = 0; i < s.core()->sim->tissue_count(); ++i) v.push_back({s.core(), i});
            return v;
          })
      .def("tissue", [](const PySimulation& s, const py::object& key) {
            if (py::isinstance<py::int_>(key)) {
              const auto i = key.cast<size_t>();
              if (i >= s.core()->sim->tissue_count()) throw py::index_error("no tissue " + std::to_string(i));
              return TissueView{s.core(), i};
            }
            const auto name = key.cast<std::string>();
            for (size_t i = 0; i < s.core()->sim->tissue_count(); ++i)
              if (s.core()->sim->tissue(i).name() == name) return TissueView{s.core(), i};
            throw py::key_error("no tissue named '" + name + "'");
          }, "key"_a, "A tissue by index or name.")
      .def("set_pose", &PySimulation::set_pose, "position"_a, "orientation"_a = py::none(), "buttons"_a = 0,
           "tool"_a = "tool", "The pose a driven tool's device reports from the next tick on (m; (w, x, y, z)).")
      .def("advance", &PySimulation::advance, "ticks"_a = 1,
           "Run ticks with the poses set (GIL released); undriven tools follow the scene's devices.")
      .def("step", &PySimulation::step, "position"_a = py::none(), "orientation"_a = py::none(), "buttons"_a = 0,
           "tool"_a = "tool", "One tick with this pose; the force sent to the tool's device, (3,) N.")
      .def("step_many", &PySimulation::step_many, "poses"_a, "buttons"_a = 0, "tool"_a = "tool",
           "One tick per row of poses ((N, 3) or (N, 7): x, y, z, qw, qx, qy, qz), in C++ with the GIL "
           "released; the force sent at each tick, (N, 3) N.")
      .def("sample", &PySimulation::sample, "tool"_a = "tool", "The tool's newest tick: time, pose, force.")
      .def("stats", &PySimulation::stats, "The loop's statistics: ticks, step and per-stage timing (s), safety, metrics.")
      .def("metrics", &PySimulation::metrics, "The outcome and the trainee's metrics so far.")
      .def("finish", &PySimulation::finish, "Stop and end the recording: events, the kept series, metrics.")
      .def("set_material", &PySimulation::set_material, "tissue"_a,
           "The write path: change a tissue's material keys and rebuild (t = 0, at rest).");
}

}  // namespace palpate::python
