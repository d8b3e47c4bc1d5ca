// tissue.cpp — the charged-particle model wired as a scene tissue: build from a patch or a mesh,
// step with the tool as HIP, figures, events, snapshot, reset.
#include <palpate/charged.h>

#include "tissue/charged/mesh_ref.h"
#include "tissue/factory.h"

#include <algorithm>
#include <array>
#include <string>
#include <vector>

namespace palpate {

namespace {

class ChargedTissue final : public Tissue {
 public:
  ChargedTissue(std::string name, int index, ChargedModel model)
      : name_(std::move(name)), index_(index), model_(std::move(model)), state_(make_charged_state(model_)) {}

  const std::string& name() const override { return name_; }

  Vec3 step(const ToolState& tool, double dt) noexcept override {
    ChargedHip hip;
    hip.position = tool.tip;
    hip.axis = tool.axis;
    hip.velocity = tool.velocity;
    // A needle's shaft follows its tip through the holes; a sphere probe is only its centre.
    hip.shaft_length = tool.needle ? tool.length : 0.0;
    // The sphere of influence is the tool's radius plus the particles' (the seed's definition);
    // only a needle punctures.
    hip.radius = tool.radius;
    hip.sharp = tool.needle;
    hip.blade = tool.blade;
    hip.edge_length = tool.blade ? tool.length : 0.0;
    const long resets = state_.stats.numeric_resets;
    const Vec3 f = palpate::step(model_, state_, hip, dt, index_, above_);
    failed_ = state_.stats.numeric_resets != resets;
    return f;
  }

  bool last_step_failed() const noexcept override { return failed_; }

  std::span<const std::string> figure_names() const override { return kFigureNames; }

  void figures(std::span<double> out) const noexcept override {
    const double values[] = {
        state_.force.norm(),
        state_.stats.max_displacement,
        static_cast<double>(state_.active_count),
        static_cast<double>(state_.stats.contacts),
        static_cast<double>(state_.stats.pinned),
        std::any_of(state_.holes.begin(), state_.holes.end(), [](const ChargedHole& h) { return h.in_track; })
            ? 1.0 : 0.0,
        static_cast<double>(std::count_if(state_.holes.begin(), state_.holes.end(),
                                          [](const ChargedHole& h) { return h.open; })),
        static_cast<double>(state_.stats.propagation_visits),
        state_.stats.indentation,
        state_.stats.shaft_in_layer,
    };
    std::copy_n(values, std::min(out.size(), std::size(values)), out.begin());
  }

  size_t drain_events(std::span<TissueEvent> out) noexcept override {
    return palpate::drain_events(state_, out);
  }

  void snapshot(TissueSnapshot& snap) const override {
    const size_t n = model_.size();
    snap.points.resize(n);
    for (size_t i = 0; i < n; ++i) snap.points[i] = Vec3f(state_.x[i], state_.y[i], state_.z[i]);
    snap.rows_cols.clear();
    if (model_.layout != ChargedLayout::mesh) snap.rows_cols = {model_.rows, model_.cols};
    snap.triangles = model_.triangles;
    snap.links.clear();
    std::array<int, 6> nb{};
    for (size_t i = 0; i < n; ++i) {
      const int count = model_.neighbours_of(static_cast<int>(i), nb);
      for (int k = 0; k < count; ++k)
        if (nb[static_cast<size_t>(k)] > static_cast<int>(i))
          snap.links.push_back({static_cast<int>(i), nb[static_cast<size_t>(k)]});
    }
    // Cut links are not drawn: listed apart, and the triangles over them dropped.
    snap.cut_links.clear();
    if (state_.cut_link_count > 0) {
      snap.links.clear();
      for (size_t i = 0; i < n; ++i) {
        model_.neighbour_slots(static_cast<int>(i), nb);
        for (int k = 0; k < 6; ++k) {
          const int j = nb[static_cast<size_t>(k)];
          if (j <= static_cast<int>(i)) continue;
          (link_cut(state_, static_cast<int>(i), k) ? snap.cut_links : snap.links).push_back({static_cast<int>(i), j});
        }
      }
      std::erase_if(snap.triangles, [&](const std::array<int, 3>& t) {
        for (int e = 0; e < 3; ++e) {
          const int a = t[static_cast<size_t>(e)], b = t[static_cast<size_t>((e + 1) % 3)];
          const int k = charged_slot_of(model_, a, b);
          if (k >= 0 && link_cut(state_, a, k)) return true;
        }
        return false;
      });
    }
    snap.velocities.clear();  // a charged layer's particles carry no velocity
    snap.loads.clear();
    snap.punctured.resize(n);
    for (size_t i = 0; i < n; ++i) snap.punctured[i] = state_.reversed(i) ? 1 : 0;
  }

  // Back to rest for a new run: the cuts heal too (a numerical-trouble reset inside step keeps them).
  void reset() noexcept override { palpate::clear_cuts(model_, state_); }

  void set_layers_above(std::span<Tissue* const> above) override {
    above_.clear();
    for (Tissue* t : above)
      if (const ChargedLayer* layer = t ? t->charged_layer() : nullptr) above_.push_back(*layer);
  }

  const ChargedLayer* charged_layer() const noexcept override { return &self_; }

 private:
  static inline const std::string kFigureNames[] = {
      "force_N", "max_displacement_m", "active_particles", "contact_particles",
      "pinned_particles", "punctured", "holes", "propagation_visits",
      "indentation_m", "shaft_in_layer_m"};
  std::string name_;
  int index_;
  ChargedModel model_;
  ChargedState state_;
  bool failed_ = false;  // the last step() reset the state
  ChargedLayer self_{&model_, &state_};
  std::vector<ChargedLayer> above_;  // the charged layers that press on this one (set_layers_above)
};

}  // namespace

Result<std::unique_ptr<Tissue>> make_charged_tissue(const SceneDef& scene, int index, const TissueServices& services) {
  if (index < 0 || static_cast<size_t>(index) >= scene.tissues.size())
    return Error{scene.file.string() + ": no tissue " + std::to_string(index) + " (the scene has " +
                 std::to_string(scene.tissues.size()) + ")"};
  const TissueDef& t = scene.tissues[static_cast<size_t>(index)];
  const std::string where = scene.file.string() + ":" + std::to_string(t.line) + ": tissue '" + t.name + "'";
  if (t.patch.has_value() == t.mesh.has_value())
    return Error{where + ": expected exactly one of 'patch' and 'mesh'"};
  Result<ChargedModel> model = t.patch ? build_charged_patch(*t.patch, t.charged, where)
                                       : charged::build_on_mesh_ref(*t.mesh, t.charged, where, services);
  if (!model) return model.error();
  // An anchor must name a particle of this patch (an index past it was accepted and ignored).
  const size_t n = model->size();
  for (size_t i = 0; i < t.anchors.size(); ++i)
    if (t.anchors[i] < 0 || static_cast<size_t>(t.anchors[i]) >= n)
      return Error{where + ": anchors[" + std::to_string(i) + "]: " + std::to_string(t.anchors[i]) +
                   " is not a particle of the patch (it has " + std::to_string(n) + ": 0.." +
                   std::to_string(n == 0 ? 0 : n - 1) + ")"};
  return std::unique_ptr<Tissue>(std::make_unique<ChargedTissue>(t.name, index, std::move(*model)));
}

}  // namespace palpate
