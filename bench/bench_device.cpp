// bench_device.cpp — cost of reading the scripted device once per tick (with and without a
// turning needle).
#include <palpate/device.h>
#include <palpate/safety.h>

#include <cmath>

#include <benchmark/benchmark.h>

// Reads of a scripted device over its waypoints, one tick apart, wrapping after 10 s.
static void scripted_reads(benchmark::State& state, const std::vector<palpate::Waypoint>& w) {
  palpate::ScriptedDevice dev(w, {}, palpate::Vec3(0, -1, 0));
  palpate::DeviceState s;
  double t = 0;
  for (auto _ : state) {
    dev.read(t, s);
    benchmark::DoNotOptimize(s.position);
    benchmark::DoNotOptimize(s.orientation);
    t += 0.001;
    if (t > 10) t = 0;
  }
}

static void BM_ScriptedDeviceRead(benchmark::State& state) {
  std::vector<palpate::Waypoint> w;
  for (int i = 0; i < 100; ++i) w.push_back({i * 0.1, palpate::Vec3(0, -0.001 * i, 0)});
  scripted_reads(state, w);
}
BENCHMARK(BM_ScriptedDeviceRead);

// The same with a needle direction at every waypoint: the orientation is slerped each read.
static void BM_ScriptedDeviceReadTurning(benchmark::State& state) {
  std::vector<palpate::Waypoint> w;
  for (int i = 0; i < 100; ++i)
    w.push_back({i * 0.1, palpate::Vec3(0, -0.001 * i, 0),
                 palpate::Vec3(0.3 * std::sin(0.5 * i), -1, 0.3 * std::cos(0.5 * i)).normalized()});
  scripted_reads(state, w);
}
BENCHMARK(BM_ScriptedDeviceReadTurning);

// Cost of the safety filter every force passes through once per tick.
static void BM_ForceSafetyFilter(benchmark::State& state) {
  palpate::ForceSafety safety(palpate::DeviceLimits{}, 0.1);
  double phase = 0;
  for (auto _ : state) {
    phase += 0.37;
    const palpate::Vec3 f = safety.filter(palpate::Vec3(std::sin(phase), 4.0 * std::cos(phase), 0.1), 0.001, true);
    benchmark::DoNotOptimize(f);
  }
}
BENCHMARK(BM_ForceSafetyFilter);
