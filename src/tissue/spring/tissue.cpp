// tissue.cpp — the mass-spring-damper model wired as a scene tissue: set-up from a TissueDef,
// the Tissue interface (step, figures, events, snapshot, reset) over step() of spring.h.
#include <palpate/contact.h>
#include <palpate/spring.h>

#include "tissue/factory.h"
#include "tissue/spring/blade.h"
#include "tissue/spring/shapes.h"

#include <array>
#include <cctype>
#include <cstdio>
#include <cmath>
#include <memory>

namespace palpate {

namespace {

std::string where_of(const SceneDef& scene, const TissueDef& t) {
  return scene.file.string() + ":" + std::to_string(t.line) + ": tissue '" + t.name + "'";
}

std::string format_number(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", x);
  return buf;
}

void translate(RowMat3d& V, const Vec3& by) {
  for (Eigen::Index i = 0; i < V.rows(); ++i) V.row(i) += by.transpose();
}

// Figures written as CSV columns, in this order.
const std::string kFigureNames[] = {"force_N",          "force_x_N",        "force_y_N",      "force_z_N",
                                    "max_displacement_m", "kinetic_energy_J", "anchor_force_N", "contacts",
                                    "resets"};
// With a blade in the scene, then: springs and tetrahedra removed, removals awaiting their correction,
// the correction's rank, new factors installed, whether the blade cuts now, teleports refused; the
// removals the solve in use covers (what a replay installs by: docs/models/cutting.md, "Recording
// and replay") and the ticks a replay's schedule asked for what the replay had not logged.
const std::string kCutFigureNames[] = {"force_N",          "force_x_N",        "force_y_N",      "force_z_N",
                                       "max_displacement_m", "kinetic_energy_J", "anchor_force_N", "contacts",
                                       "resets",           "cut_springs",      "cut_tets",       "cut_pending",
                                       "cut_rank",         "cut_factors",      "cutting",        "blade_jumps",
                                       "cut_installed",    "cut_replay_mismatches"};

// Headless runs and replays install a cut's correction this many ticks after the cut, waiting for
// the worker if need be, so they repeat exactly (docs/models/cutting.md); a real-time loop does not wait.
constexpr int kFixedLatency = 2;

class SpringTissue final : public Tissue, public ContactComplianceSource {
 public:
  SpringTissue(std::string name, int index, SpringModel model)
      : name_(std::move(name)), index_(index), model_(std::move(model)), state_(make_state(model_)) {
    body_ = {&model_, &state_};
  }
  SpringTissue(const SpringTissue&) = delete;
  SpringTissue& operator=(const SpringTissue&) = delete;

  const std::string& name() const override { return name_; }

  // A blade may cut this organ (the scene's tool is a blade): the cutter's worker thread starts here.
  Status enable_cutting(const spring::BladeSettings& blade, const SpringCutOptions& options) {
    uncut_ = std::make_unique<SpringModel>(model_);  // what reset() heals back to (a deep copy)
    blade_settings_ = blade;
    cut_options_ = options;
    return start_cutting();
  }

  Vec3 step(const ToolState& tool, double dt) noexcept override {
    // The predictor is built for one step length: a longer tick runs several steps.
    const long substeps = std::max(1L, std::lround(dt / step_length(model_.options)));
    Vec3 force = Vec3::Zero();
    failed_ = false;
    if (cutter_) {
      // What the worker has ready takes effect from this tick; then the blade cuts what its edge
      // swept through since the last one (the removed springs pull no more in this tick's step).
      cutter_->install();
      // A replay whose recording asked for removals this run never logged has left the recorded
      // run: said once where it starts (the figure counts every such tick).
      const int mismatches = cutter_->status().replay_mismatches;
      if (mismatches > mismatches_)
        if (!mismatched_last_) push_event({tool.time, "cut_replay_mismatch", index_, 0.0, static_cast<double>(mismatches)});
      mismatched_last_ = mismatches > mismatches_;
      mismatches_ = mismatches;
      if (blade_ && blade_->cut(state_, tool, dt) > 0) {
        const SpringCutStatus st = cutter_->status();
        push_event({tool.time, "cut", index_, blade_->depth(), static_cast<double>(st.removed_springs)});
      }
    }
    for (long k = 0; k < substeps; ++k) {
      if (!palpate::step(model_, state_, &tool)) {
        push_event({tool.time, "reset", index_, 0.0, 0.0});
        failed_ = true;
        if (blade_) blade_->reset();
        return Vec3::Zero();
      }
      force = state_.tool_force;
    }
    if (blade_) force = blade_->felt(force, tool, dt);
    return force;
  }

  void set_second_tool(const ToolState& tool) noexcept override {
    state_.second_tool = tool;
    state_.has_second_tool = true;
  }
  Vec3 second_tool_force() const noexcept override { return state_.second_tool_force; }

  bool last_step_failed() const noexcept override { return failed_; }
  void set_real_time(bool real_time) noexcept override {
    real_time_ = real_time;
    if (cutter_) cutter_->set_fixed_latency(real_time ? -1 : kFixedLatency);
  }
  Status set_install_schedule(std::span<const std::int32_t> installed) override {
    if (!cutter_) return {};  // nothing cuts this organ: nothing to install
    return cutter_->set_install_schedule(installed);
  }
  ContactComplianceSource* contact_compliance() noexcept override { return this; }

  // The compliant patch for a multi-rate loop (issue 24): only when one step() is one step of the
  // predictor (its compliance is that step's), built on the physics thread at its first call.
  bool contact_patch(const ToolState& tool, double dt, double horizon, ContactPatch& out) noexcept override {
    if (failed_ || std::lround(dt / step_length(model_.options)) != 1) return false;
    try {
      if (!compliance_) compliance_ = std::make_unique<SpringCompliance>(model_);
      // Reach: where the tool can go before the next patch, twice over, and at least a millimetre.
      const double margin = std::max(0.001, 2.0 * tool.velocity.norm() * std::max(dt, horizon));
      return compliance_->contact_patch(state_, tool, margin, out);
    } catch (...) {  // out of memory: the loop renders the linearised contact instead
      return false;
    }
  }

  std::span<const std::string> figure_names() const override {
    return cutter_ ? std::span<const std::string>(kCutFigureNames) : std::span<const std::string>(kFigureNames);
  }

  void figures(std::span<double> out) const noexcept override {
    const double values[] = {state_.tool_force.norm(),
                             state_.tool_force.x(),
                             state_.tool_force.y(),
                             state_.tool_force.z(),
                             max_displacement(model_, state_),
                             kinetic_energy(model_, state_),
                             state_.anchor_force.norm(),
                             static_cast<double>(state_.contacts),
                             static_cast<double>(state_.resets)};
    for (size_t i = 0; i < out.size() && i < std::size(values); ++i) out[i] = values[i];
    if (cutter_ && out.size() >= std::size(kCutFigureNames)) {
      const SpringCutStatus st = cutter_->status();
      const double cut[] = {static_cast<double>(st.removed_springs), static_cast<double>(st.removed_tets),
                            static_cast<double>(st.pending), static_cast<double>(st.correction_rank),
                            static_cast<double>(st.factors), blade_ && blade_->cutting() ? 1.0 : 0.0,
                            static_cast<double>(blade_ ? blade_->jumps() : 0), static_cast<double>(st.installed),
                            static_cast<double>(st.replay_mismatches)};
      std::copy(std::begin(cut), std::end(cut), out.begin() + static_cast<std::ptrdiff_t>(std::size(kFigureNames)));
    }
  }

  size_t drain_events(std::span<TissueEvent> out) noexcept override {
    size_t n = 0;
    while (n < out.size() && count_ > 0) {
      out[n++] = events_[head_];
      head_ = (head_ + 1) % events_.size();
      --count_;
    }
    return n;
  }

  void snapshot(TissueSnapshot& snap) const override {
    const Eigen::Index n = state_.x.rows();
    snap.points.resize(static_cast<size_t>(n));
    for (Eigen::Index i = 0; i < n; ++i) snap.points[static_cast<size_t>(i)] = state_.x.row(i).transpose().cast<float>();
    snap.rows_cols.clear();
    snap.triangles = model_.network.triangles;
    if (cutter_) {
      const auto& gone = cutter_->removed_springs();
      snap.links.clear();
      for (size_t e = 0; e < model_.network.springs.size(); ++e)
        if (!gone[e]) snap.links.push_back(model_.network.springs[e]);
    } else {
      snap.links.assign(model_.network.springs.begin(), model_.network.springs.end());
    }
    // Velocities, and the contact's load on the vertices it holds (zero elsewhere).
    snap.velocities.resize(static_cast<size_t>(n));
    for (Eigen::Index i = 0; i < n; ++i) snap.velocities[static_cast<size_t>(i)] = state_.v.row(i).transpose().cast<float>();
    snap.loads.assign(static_cast<size_t>(n), Vec3f::Zero());
    for (int k = 0; k < state_.contact_vertex_count; ++k) {
      const int v = state_.contact_vertex[static_cast<size_t>(k)];
      if (v >= 0 && v < n) snap.loads[static_cast<size_t>(v)] += state_.contact_load[static_cast<size_t>(k)].cast<float>();
    }
    snap.punctured.clear();
  }

  const SpringBody* spring_body() const noexcept override { return &body_; }

  // Back to rest, and a cut organ whole again (a new attempt). (A step's own recovery from numerical
  // trouble, palpate::reset in step(), keeps the wound: it puts back positions, not springs.) A
  // replay's install schedule goes with the old cutter: a new attempt is not the recorded run.
  void reset() noexcept override {
    if (uncut_ && cutter_ && cutter_->status().removed_springs + cutter_->status().removed_tets > 0) {
      try {
        blade_.reset();
        cutter_.reset();  // its worker stops; the model no longer points at its correction
        model_ = *uncut_;
        (void)start_cutting();
      } catch (...) {  // out of memory: the organ stays as it was (cut), nothing half-made
      }
    }
    palpate::reset(model_, state_);
    if (blade_) blade_->reset();
  }

  const SpringModel& model() const { return model_; }

 private:
  void push_event(const TissueEvent& e) noexcept {
    if (count_ == events_.size()) {  // full: drop the oldest
      head_ = (head_ + 1) % events_.size();
      --count_;
    }
    events_[(head_ + count_) % events_.size()] = e;
    ++count_;
  }

  std::string name_;
  int index_;
  SpringModel model_;
  SpringState state_;
  SpringBody body_;  // points at model_ and state_ (the tissue is never copied nor moved)
  bool failed_ = false;  // the last step() reset the state
  std::unique_ptr<SpringCompliance> compliance_;
  Status start_cutting() {
    auto cutter = SpringCutter::create(model_, cut_options_);
    if (!cutter) return cutter.error();
    cutter_ = std::move(*cutter);
    mismatches_ = 0;
    mismatched_last_ = false;
    blade_ = std::make_unique<spring::BladeCut>(model_, *cutter_, blade_settings_);
    if (real_time_) cutter_->set_fixed_latency(-1);
    return {};
  }

  std::unique_ptr<SpringModel> uncut_;        // the model before any cut (reset() heals to it)
  spring::BladeSettings blade_settings_;
  SpringCutOptions cut_options_;
  bool real_time_ = false;
  int mismatches_ = 0;            // the cutter's replay_mismatches after the last install
  bool mismatched_last_ = false;  // the last install was one (a run of them is one event)
  std::unique_ptr<SpringCutter> cutter_;      // the scene's tool is a blade (declared after model_: dies first)
  std::unique_ptr<spring::BladeCut> blade_;
  std::array<TissueEvent, 64> events_{};
  size_t head_ = 0, count_ = 0;
};

}  // namespace

std::unique_ptr<Tissue> make_spring_tissue(std::string name, SpringModel model) {
  return std::make_unique<SpringTissue>(std::move(name), 0, std::move(model));
}

Result<SpringNetwork> spring_network_from_file(const MeshRef& ref, const SpringNetworkOptions& o,
                                               const TissueServices& services) {
  const std::string where = ref.file.string();
  if (is_tet_file(ref.file)) {
    if (!services.load_tet) return Error{where + ": no tetrahedral mesh loader was handed to the tissue's builder"};
    auto tet = services.load_tet(ref.file, ref.scale);
    if (!tet) return tet.error();
    translate(tet->V, ref.translate);
    return make_spring_network(*tet, o, where);
  }
  SurfaceRequirements need;
  need.closed = need.manifold = (o.topology == SpringTopology::tet_edges || o.density > 0 || o.youngs_modulus > 0);
  if (!services.load_surface) return Error{where + ": no surface loader was handed to the tissue's builder"};
  auto surface = services.load_surface(ref.file, ref.scale, need);
  if (!surface) return surface.error();
  translate(surface->V, ref.translate);
  if (o.topology == SpringTopology::tet_edges) {
    if (!services.fill) return Error{where + ": no tetrahedral mesher was handed to the tissue's builder (topology tet_edges fills the surface)"};
    auto tet = services.fill(*surface, o.fill);
    if (!tet) return Error{where + ": filling the surface with tetrahedra failed: " + tet.error().message};
    return make_spring_network(*tet, o, where + " (tetrahedralized)");
  }
  return make_spring_network(*surface, o, where);
}

Result<SpringTissueSetup> spring_setup(const SceneDef& scene, int index, const TissueServices& services) {
  const TissueDef& t = scene.tissues.at(static_cast<size_t>(index));
  const std::string where = where_of(scene, t);
  const SpringMaterialDef& m = t.spring;
  auto net_opt = network_options(m, t.anchors, where);
  if (!net_opt) return net_opt.error();
  auto solver = parse_solver(m.solver, where);
  if (!solver) return solver.error();
  SpringTissueSetup setup;
  if (m.predictor_policy == "load_or_compute") setup.policy = PredictorPolicy::load_or_compute;
  else if (m.predictor_policy == "require_file") setup.policy = PredictorPolicy::require_file;
  else return Error{where + ": predictor_policy '" + m.predictor_policy + "' is not one of load_or_compute|require_file"};
  Result<SpringNetwork> net = Error{where + ": needs a patch or a mesh"};
  if (t.mesh) {
    net = spring_network_from_file(*t.mesh, *net_opt, services);
    if (!net) return Error{where + ": " + net.error().message};
  } else if (t.patch && t.patch->shape == "sphere") {
    // A solid ball (a large organ made at load: issue 24's scene): the tets of a grid of `spacing`
    // whose centroids lie within `radius`, centred at `center`. With no anchors listed it rests on
    // its bottom cap: the vertices in the lowest 5 % of its height are held.
    TetMesh ball = spring::make_tet_ball(t.patch->radius, t.patch->spacing);
    if (ball.V.rows() == 0) return Error{where + ": the sphere patch holds no tetrahedra (radius < spacing?)"};
    const Vec3 mid = 0.5 * (ball.V.colwise().minCoeff() + ball.V.colwise().maxCoeff()).transpose();
    translate(ball.V, t.patch->center - mid);
    if (t.anchors.empty()) {
      const double lo = ball.V.col(1).minCoeff(), hi = ball.V.col(1).maxCoeff();
      for (Eigen::Index i = 0; i < ball.V.rows(); ++i)
        if (ball.V(i, 1) < lo + 0.05 * (hi - lo)) net_opt->anchors.push_back(static_cast<int>(i));
    }
    net = make_spring_network(ball, *net_opt, where);
    if (!net) return net.error();
  } else if (t.patch && t.patch->shape == "gallbladder") {
    // The gallbladder on the liver's underside (issue 37's scene), at its published size; with no
    // anchors listed the liver's top face is held.
    if (!(t.patch->spacing >= 0.001 && t.patch->spacing <= 0.01))
      return Error{where + ": a gallbladder patch's spacing is " + format_number(t.patch->spacing) +
                   " m; expected 0.001 to 0.01 m (the organ is 80 mm long)"};
    spring::GallbladderBed bed = spring::make_gallbladder_bed(t.patch->spacing, t.patch->center);
    if (t.anchors.empty()) net_opt->anchors = bed.held;
    net = make_spring_network(bed.mesh, *net_opt, where);
    if (!net) return net.error();
  } else if (t.patch) {
    if (t.patch->shape != "flat")
      return Error{where + ": a mass_spring patch must be flat, a sphere or a gallbladder (shape '" + t.patch->shape +
                   "'); use a mesh for other shapes"};
    net = make_spring_network(spring::make_sheet(*t.patch), *net_opt, where);
    if (!net) return net.error();
  } else {
    return net.error();
  }
  setup.network = std::move(*net);
  SpringModelOptions& o = setup.options;
  if (m.integrator == "bdf2") o.integrator = SpringIntegrator::bdf2;
  else if (m.integrator != "backward_euler")
    return Error{where + ": material.integrator '" + m.integrator + "' is not one of backward_euler|bdf2"};
  // One step per physics period (or per tick): BDF2's predictor is built for 2/3 of it.
  o.dt = (m.physics_rate > 0 ? 1.0 / m.physics_rate : scene.dt) *
         (o.integrator == SpringIntegrator::bdf2 ? 2.0 / 3.0 : 1.0);
  o.solver = *solver;
  o.point_damping = m.point_damping;
  o.gravity = m.gravity;
  o.gravity_acceleration = m.gravity_acceleration;
  o.angular_momentum_correction = m.angular_momentum_correction;
  o.contact_stiffness = m.contact_stiffness;
  if (m.contact == "surface") o.contact = SpringContact::surface;
  else if (m.contact == "vertices") o.contact = SpringContact::vertices;
  else return Error{where + ": material.contact '" + m.contact + "' is not one of surface|vertices"};
  o.grasp_radius = m.grasp_radius;
  o.grasp_stiffness = m.grasp_stiffness;
  o.grasp_release_time = m.grasp_release_time;
  o.single_precision = m.single_precision;
  o.exact_iterations = m.exact_iterations;
  o.directional_correction = m.directional_correction;
  const std::filesystem::path base = scene.file.has_parent_path() ? scene.file.parent_path() : std::filesystem::path{};
  if (!m.predictor.empty()) {
    const std::filesystem::path p = m.predictor;
    setup.predictor = p.is_absolute() ? p : base / p;
  } else if (o.solver != SpringSolver::exact && !services.predictor_cache.empty()) {
    // In the cache, never beside the scene: named by the tissue (letters, digits, '-' and '_'
    // kept) and by everything the predictor depends on, so another scene's organ, or this one
    // changed, gets its own file and an unchanged one finds it again.
    std::string name = t.name.empty() ? "tissue" + std::to_string(index) : t.name;
    for (char& c : name)
      if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '_';
    char key[17];
    std::snprintf(key, sizeof key, "%016llx", static_cast<unsigned long long>(predictor_key(setup.network, o)));
    setup.predictor = services.predictor_cache / (name + "-" + key + ".predictor");
  }
  return setup;
}

Result<std::unique_ptr<Tissue>> make_spring_tissue(const SceneDef& scene, int index, const TissueServices& services) {
  auto setup = spring_setup(scene, index, services);
  if (!setup) return setup.error();
  const TissueDef& t = scene.tissues.at(static_cast<size_t>(index));
  const bool blade = scene.tool.kind == "blade";
  if (blade && t.spring.physics_rate > 0)
    return Error{where_of(scene, t) + ": material.physics_rate: a blade cannot cut a multi-rate organ yet (its "
                 "haptic-rate compliance would not follow the cut); set physics_rate: 0"};
  if (blade && setup->options.solver == SpringSolver::exact)
    return Error{where_of(scene, t) + ": material.solver: a blade cuts organs with a predictor (desbrun or sparse), "
                 "not the exact solver"};
  if (blade && t.spring.contact == "surface" && !(t.spring.contact_stiffness * scene.tool.radius > t.spring.cutting_force))
    return Error{where_of(scene, t) + ": material.contact_stiffness: " + format_number(t.spring.contact_stiffness) +
                 " N/m holds the blade (radius " + format_number(scene.tool.radius) + " m) to at most " +
                 format_number(t.spring.contact_stiffness * scene.tool.radius) +
                 " N before its edge slips through the surface, short of cutting_force " +
                 format_number(t.spring.cutting_force) + " N; expected contact_stiffness > cutting_force / tool.radius"};
  auto model = build_spring_model(std::move(setup->network), setup->options, setup->predictor, setup->policy, services);
  if (!model) return Error{where_of(scene, t) + ": " + model.error().message};
  // On the multi-rate path the step's contact uses the exact diagonal of A⁻¹, so that it agrees with
  // the exact compliance the haptic thread renders between its steps (issue 24).
  if (t.spring.physics_rate > 0) (void)use_exact_contact_compliance(*model);
  auto tissue = std::make_unique<SpringTissue>(t.name, index, std::move(*model));
  if (blade) {
    spring::BladeSettings bs;
    bs.cutting_force = t.spring.cutting_force;
    bs.drag_per_length = t.spring.cutting_drag_per_length;
    SpringCutOptions co;
    co.fixed_latency = kFixedLatency;
    if (Status st = tissue->enable_cutting(bs, co); !st) return Error{where_of(scene, t) + ": " + st.error().message};
  }
  return std::unique_ptr<Tissue>(std::move(tissue));
}

}  // namespace palpate
