// bench_contact_render.cpp — the multi-rate loop's force against the synchronous truth (issue 24):
// the same scripted probing (press 5 mm, slide 8 mm, release; 1.5 s) of the 11k and 54k tet-ball
// organs, run synchronously (a full 1 ms step every tick) and through the physics worker at 50, 100
// and 250 Hz (inline, deterministic; the model's predictor built for the physics step) with the
// force between steps from the exact compliance (Compliance) or the secant linearisation (Secant),
// the organ stepped by backward Euler or (…BDF2) by BDF2 at the physics period.
// Counters: force_rms_error and force_max_error relative to the peak force of the truth;
// render_rms_error and render_max_error against the physics model's own step taken every tick from
// its last physics state at the tool's pose (the rendering's error alone), same scale.
// PALPATE_EXACT_ITERATIONS=N steps the physics-rate models with N of the exact linearised step's
// conjugate-gradient iterations after the predictor (SpringModelOptions::exact_iterations: N more
// solves per step), to measure what converging the step buys; PALPATE_RENDER_DUMP=DIR writes each
// row's forces tick by tick.
#include <palpate/spring.h>

#include "render_error.h"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
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
  std::map<std::pair<int, SpringIntegrator>, std::unique_ptr<SpringModel>> at_rate;  // the model stepped at a rate (Hz)
};

// The truth: the organ's 1 ms model as it is by default. At a physics rate: the model as the
// multi-rate path builds it (data/scenes/large-organ.yaml) — directional_correction on (backward
// Euler's damping of transverse motion, which the DS99 predictor's constant matrix over-damps by
// h (K_L − K), 20 times more at 20 ms than at 1 ms) and the step's contact against the exact
// diagonal of A⁻¹ (use_exact_contact_compliance).
// With BDF2 (`integrator: bdf2`, the shipped scene's) the predictor is built for 2/3 of the period.
SpringModelOptions options(double period, bool physics_rate, SpringIntegrator integrator = SpringIntegrator::backward_euler) {
  SpringModelOptions o;
  o.integrator = integrator;
  o.dt = integrator == SpringIntegrator::bdf2 ? period * 2 / 3 : period;
  o.solver = SpringSolver::sparse;
  o.directional_correction = physics_rate;
  if (const char* e = std::getenv("PALPATE_EXACT_ITERATIONS"); e && physics_rate) o.exact_iterations = std::max(0, std::atoi(e));
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

void render(benchmark::State& state, double radius_in_spacings, MultiRateContact method, int hz,
            SpringIntegrator integrator, const std::string& name) {
  Organ& o = organ(radius_in_spacings);
  auto& model = o.at_rate[{hz, integrator}];
  if (!model) {
    model = std::make_unique<SpringModel>(*build_spring_model(o.network, options(1.0 / hz, true, integrator)));
    use_exact_contact_compliance(*model);
  }
  RenderError e;
  for (auto _ : state) e = multirate_error(*model, method, o.script, o.truth, 1000.0, true);
  state.counters["force_rms_error"] = e.rms;
  // Where the error is: each leg's RMS (press, slide, release), same scale.
  const char* legs[] = {"rms_press", "rms_slide", "rms_release"};
  const size_t per_leg = e.force.size() / 3;
  for (size_t l = 0; l < 3 && e.peak > 0; ++l) {
    double sum2 = 0;
    for (size_t k = l * per_leg; k < (l + 1) * per_leg; ++k) sum2 += (e.force[k] - o.truth[k]).squaredNorm();
    state.counters[legs[l]] = std::sqrt(sum2 / static_cast<double>(per_leg)) / e.peak;
  }
  if (const char* dump = std::getenv("PALPATE_RENDER_DUMP")) {  // tick, truth |F|, rendered |F|
    if (FILE* f = std::fopen((std::string(dump) + "/" + name + ".csv").c_str(), "w")) {
      for (size_t k = 0; k < e.force.size(); ++k)
        std::fprintf(f, "%zu,%.6f,%.6f,%.6f,%.6f\n", k, o.truth[k].norm(), e.force[k].norm(), o.truth[k].y(), e.force[k].y());
      std::fclose(f);
    }
  }
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
      for (const auto& [integrator_name, integrator] :
           {std::pair{"", SpringIntegrator::backward_euler}, std::pair{"BDF2", SpringIntegrator::bdf2}})
        for (int hz : {50, 100, 250})
          benchmark::RegisterBenchmark((std::string("BM_ContactRender/") + organ_name + "/" + method_name +
                                        integrator_name + "/" + std::to_string(hz) + "Hz")
                                           .c_str(),
                                       [radius, method, hz, integrator,
                                        file = std::string(organ_name) + "_" + method_name + integrator_name + "_" +
                                               std::to_string(hz) + "Hz"](benchmark::State& s) {
                                         render(s, radius, method, hz, integrator, file);
                                       })
              ->Iterations(1)
              ->Unit(benchmark::kMillisecond);
  return true;
}();

}  // namespace
