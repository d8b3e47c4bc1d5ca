// bench_contact_render.cpp — the multi-rate loop's force against the synchronous truth (issue 24):
// the same scripted probing (press 5 mm, slide 8 mm, release; 1.5 s) of the 11k and 54k tet-ball
// organs, run synchronously (a full 1 ms step every tick) and through the physics worker at 50, 100
// and 250 Hz (inline, deterministic; the model's predictor built for the physics step) with the
// force between steps from the exact compliance (Compliance) or the secant linearisation (Secant).
// Counters: force_rms_error and force_max_error relative to the peak force of the truth;
// render_rms_error and render_max_error against the physics model's own step taken every tick from
// its last physics state at the tool's pose (the rendering's error alone), same scale.
#include <palpate/spring.h>

#include "haptics/render_error.h"

#include <benchmark/benchmark.h>

#include <chrono>
#include <map>
#include <memory>
#include <string>

namespace {

using namespace palpate;

struct Organ {
  SpringNetwork network;
  ProbeScript script;
  std::vector<Vec3> truth;
  double truth_ms_per_tick = 0;
  std::map<int, std::unique_ptr<SpringModel>> at_rate;  // Hz → the model stepped at that rate
};

// The truth: the organ's 1 ms model as it is by default. At a physics rate: the model as the
// multi-rate path builds it (data/scenes/large-organ.yaml) — directional_correction on (backward
// Euler's damping of transverse motion, which the DS99 predictor's constant matrix over-damps by
// h (K_L − K), 20 times more at 20 ms than at 1 ms) and the step's contact against the exact
// diagonal of A⁻¹ (use_exact_contact_compliance).
SpringModelOptions options(double dt, bool physics_rate) {
  SpringModelOptions o;
  o.dt = dt;
  o.solver = SpringSolver::sparse;
  o.directional_correction = physics_rate;
  return o;
}

// Built once per process: the network, the synchronous truth, the models at each rate.
Organ& organ(double radius_in_spacings) {
  static std::map<double, std::unique_ptr<Organ>> organs;
  auto& o = organs[radius_in_spacings];
  if (!o) {
    o = std::make_unique<Organ>();
    o->network = tet_ball_organ(radius_in_spacings);
    o->script = probe_script(o->network);
    const SpringModel model = *build_spring_model(o->network, options(o->script.dt, false));
    const auto t0 = std::chrono::steady_clock::now();
    o->truth = synchronous_forces(model, o->script);
    o->truth_ms_per_tick = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count() /
                           static_cast<double>(o->truth.size());
  }
  return *o;
}

void render(benchmark::State& state, double radius_in_spacings, MultiRateContact method, int hz) {
  Organ& o = organ(radius_in_spacings);
  auto& model = o.at_rate[hz];
  if (!model) {
    model = std::make_unique<SpringModel>(*build_spring_model(o.network, options(1.0 / hz, true)));
    use_exact_contact_compliance(*model);
  }
  RenderError e;
  for (auto _ : state) e = multirate_error(*model, method, o.script, o.truth, 1000.0, true);
  state.counters["force_rms_error"] = e.rms;
  state.counters["force_max_error"] = e.max;
  state.counters["peak_force_N"] = e.peak;
  // The rendering alone: against the physics model's own step taken every tick at the tool's pose.
  state.counters["render_rms_error"] = e.step_rms;
  state.counters["render_max_error"] = e.step_max;
  state.counters["patch_ticks"] = static_cast<double>(e.patch_ticks);
  state.counters["patch_fallbacks"] = static_cast<double>(e.patch_fallbacks);
  state.counters["physics_steps"] = static_cast<double>(e.physics_steps);
  state.counters["vertices"] = static_cast<double>(o.network.size());
  state.counters["truth_ms_per_tick"] = o.truth_ms_per_tick;
}

const bool registered = [] {
  for (const auto& [organ_name, radius] : {std::pair{"Organ11k", 13.4}, std::pair{"Organ54k", 22.9}})
    for (const auto& [method_name, method] :
         {std::pair{"Compliance", MultiRateContact::compliance}, std::pair{"Secant", MultiRateContact::linearised}})
      for (int hz : {50, 100, 250})
        benchmark::RegisterBenchmark(
            (std::string("BM_ContactRender/") + organ_name + "/" + method_name + "/" + std::to_string(hz) + "Hz").c_str(),
            [radius, method, hz](benchmark::State& s) { render(s, radius, method, hz); })
            ->Iterations(1)
            ->Unit(benchmark::kMillisecond);
  return true;
}();

}  // namespace
