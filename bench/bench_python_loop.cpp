// bench_python_loop.cpp — the C++ side of the step_many comparison (docs/BENCHMARKS.md, "Python"):
// the loop palpate.Simulation.step_many runs, written in C++ — default.yaml built with a
// VirtualDevice in the needle's place, then per tick the pose set (velocity by difference), one
// headless tick and the force sent read back — over 10,000 ticks of a press in and out of the skin
// (never through it, so every iteration starts where the last ended). bench/python_step_many.py
// times step_many over the same poses and reports the ratio.
#include <palpate/palpate.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include <benchmark/benchmark.h>

namespace {

// The poses bench/python_step_many.py gives step_many: y = 0.003 − 0.004·(1 − cos(2π t / 2 s))/2.
std::vector<palpate::Vec3> press_poses(size_t n) {
  std::vector<palpate::Vec3> p(n);
  for (size_t i = 0; i < n; ++i)
    p[i] = palpate::Vec3(0, 0.003 - 0.004 * 0.5 * (1 - std::cos(2 * M_PI * double(i) * 0.001 / 2.0)), 0);
  return p;
}

void BM_StepManyLoopInCpp(benchmark::State& state) {
  auto scene = palpate::load_scene(PALPATE_DATA_DIR "/scenes/default.yaml");
  if (!scene) {
    state.SkipWithError(scene.error().message.c_str());
    return;
  }
  palpate::VirtualDevice device(palpate::device_limits(scene->device));
  palpate::SimulationOptions o;
  o.stop_after_duration = false;
  o.devices.push_back({"tool", &device});
  auto sim = palpate::Simulation::build(*scene, o);
  if (!sim) {
    state.SkipWithError(sim.error().message.c_str());
    return;
  }
  auto loop = (*sim)->open_loop();  // no recording: as Simulation(record=False)
  if (!loop) {
    state.SkipWithError(loop.error().message.c_str());
    return;
  }
  const size_t n = size_t(state.range(0));
  const std::vector<palpate::Vec3> poses = press_poses(n);
  std::vector<double> forces(3 * n);
  const double dt = scene->dt;
  palpate::Vec3 last = poses[0];
  for (auto _ : state) {
    for (size_t i = 0; i < n; ++i) {
      palpate::DeviceState s;
      s.position = poses[i];
      s.velocity = (poses[i] - last) / dt;
      last = poses[i];
      device.set_pose(s);
      (*loop)->run_headless(1);
      const palpate::Vec3 f = (*loop)->tool_sample(0).force;
      forces[3 * i] = f.x(), forces[3 * i + 1] = f.y(), forces[3 * i + 2] = f.z();
    }
    benchmark::DoNotOptimize(forces.data());
  }
  state.SetItemsProcessed(std::int64_t(state.iterations()) * std::int64_t(n));
}
BENCHMARK(BM_StepManyLoopInCpp)->Arg(10000)->Unit(benchmark::kMillisecond);

}  // namespace
