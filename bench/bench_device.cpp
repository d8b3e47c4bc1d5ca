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

#if defined(PALPATE_FAKE_HD) && defined(PALPATE_FAKE_DHD)
#include <palpate/run.h>

#include "haptics/two_families.h"

#include <cstdlib>
#include <filesystem>

// Issue 38's bench (docs/BENCHMARKS.md, "Two device families"): the realtime CVC scene with the
// needle on a Touch (the fake libHD) and the probe on an omega.7 (the fake libdhd), both backends'
// servo threads and the haptic thread in one process, for PALPATE_REALTIME_SECONDS (default 2; the
// figure in the docs is a 60 s run). Reports the haptic period's median / p99 / max (ms), deadline
// misses, the step's p99 (µs) and each device's failed ticks.
static void BM_TwoDeviceFamiliesCvc(benchmark::State& state) {
  const char* env = std::getenv("PALPATE_REALTIME_SECONDS");
  const double seconds = env ? std::max(0.5, std::atof(env)) : 2.0;
  for (auto _ : state) {
    palpate::test::FakeHd hd;
    palpate::test::FakeDhd dhd;
    palpate::SceneDef scene;
    if (const std::string e = palpate::test::two_families_cvc(scene, hd, dhd, seconds); !e.empty()) {
      state.SkipWithError(e.c_str());
      return;
    }
    palpate::RunOptions o;
    o.out = std::filesystem::temp_directory_path() / "palpate_bench_two_families";
    o.plots = false;
    o.realtime = true;
    o.realtime_priority = state.range(0) != 0;
    auto r = palpate::run_scene(scene, o);
    if (!r) {
      state.SkipWithError(r.error().message.c_str());
      return;
    }
    state.SetIterationTime(double(r->ticks) * r->dt);
    state.counters["ticks"] = double(r->ticks);
    state.counters["period_median_ms"] = r->period.median * 1e3;
    state.counters["period_p99_ms"] = r->period.p99 * 1e3;
    state.counters["period_max_ms"] = r->period.max * 1e3;
    state.counters["step_p99_us"] = r->step_p99 * 1e6;
    state.counters["deadline_misses"] = double(r->deadline_misses);
    state.counters["needle_device_failed"] = double(r->safety.device_failed);
    state.counters["probe_device_failed"] = r->tools.empty() ? -1.0 : double(r->tools[0].safety.device_failed);
    std::error_code ec;
    std::filesystem::remove_all(o.out, ec);
  }
}
BENCHMARK(BM_TwoDeviceFamiliesCvc)->Arg(0)->Arg(1)->ArgName("fifo")->Iterations(1)->UseManualTime()->Unit(benchmark::kMillisecond);
#endif
