// render_error.h — how far a multi-rate loop's force is from the synchronous truth (issue 24): the
// same scripted probing (press, slide, release) of a mass-spring organ run fully synchronously
// (a full step every tick) and through a PhysicsWorker stepping inline at a physics rate, with the
// force rendered between its steps by the compliance solve or the secant linearisation. Shared by
// the test (tests/haptics/test_contact_compliance.cpp) and the benchmark (bench/bench_contact_render.cpp):
// benchmark code, not the library's (the static palpate_render_error, bench/CMakeLists.txt).
#pragma once

#include <palpate/spring.h>

#include "haptics/multirate.h"

#include <vector>

namespace palpate {

// The tet-ball organs of the spring benchmarks: a ball of radius_in_spacings · 2 mm on a 2 mm grid,
// springs of 100 N/m on its tet edges, 0.5 kg, the lowest 5% of its height anchored. 13.4: the
// 11k organ (11,488 vertices); 22.9: the 54k organ (54,291).
SpringNetwork tet_ball_organ(double radius_in_spacings);

// The probing: a 4 mm sphere from 1 mm above the organ's top, pressed 5 mm in over 0.5 s, slid
// 8 mm along x over 0.5 s, lifted back over 0.5 s (each leg a smoothstep): 1.5 s, 1500 ticks of 1 ms.
struct ProbeScript {
  Vec3 top = Vec3::Zero();   // m, the organ's top (mean x, max y, mean z of its rest)
  double radius = 0.004;     // m
  double depth = 0.005;      // m, past first touch
  double slide = 0.008;      // m, along x
  double leg = 0.5;          // s, each of press, slide, release
  double dt = 0.001;         // s, the haptic tick
  long ticks() const { return static_cast<long>(3 * leg / dt + 0.5); }
  ToolState at(long tick) const;
};
ProbeScript probe_script(const SpringNetwork& network);

// The force on the tool every tick, a full step of `model` (its dt = script.dt) each tick.
std::vector<Vec3> synchronous_forces(const SpringModel& model, const ProbeScript& script);

struct RenderError {
  double rms = 0;     // sqrt(mean |F − F_truth|²) / max |F_truth|
  double max = 0;     // max |F − F_truth| / max |F_truth|
  double peak = 0;    // N, max |F_truth|
  // The rendering's own error: against the physics model's full step taken every tick from its
  // last physics state with the tool where it is that tick (what the multi-rate loop would feel
  // if the physics could step at 1 kHz), relative to the same peak. 0 unless asked for.
  double step_rms = 0, step_max = 0;
  std::uint64_t patch_ticks = 0, patch_fallbacks = 0, physics_steps = 0;
  std::vector<Vec3> force;  // N, each tick's rendered force
};

// The same script through a PhysicsWorker (threaded = false: it steps `model` inline every
// model.options.dt / script.dt ticks) rendering with `method`; errors against `truth`.
// with_step_reference: also the step_* errors (a full step of the model every tick: costly).
RenderError multirate_error(SpringModel model, MultiRateContact method, const ProbeScript& script,
                            const std::vector<Vec3>& truth, double max_stiffness = 1000.0,
                            bool with_step_reference = false);

}  // namespace palpate
