// bench_haptics.cpp — cost of one haptic tick (direct, virtual coupling, multi-rate render), of the
// lock-free exchanges, and a realtime run's period statistics (p99 period, deadline misses).
#include <palpate/device.h>
#include <palpate/haptics.h>
#include <palpate/tissue.h>

#include "haptics/recorder.h"
#include "haptics/triple_buffer.h"

#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>

namespace {

// A floor at y = 0 (N/m · penetration): the simplest tissue, so the loop's own cost shows.
class BenchFloor final : public palpate::Tissue {
 public:
  const std::string& name() const override { return name_; }
  palpate::Vec3 step(const palpate::ToolState& tool, double) noexcept override {
    force_ = 500.0 * std::max(0.0, tool.radius - tool.tip.y());
    return palpate::Vec3(0, force_, 0);
  }
  std::span<const std::string> figure_names() const override { return names_; }
  void figures(std::span<double> out) const noexcept override { out[0] = force_; }
  size_t drain_events(std::span<palpate::TissueEvent>) noexcept override { return 0; }
  void snapshot(palpate::TissueSnapshot&) const override {}
  void reset() noexcept override { force_ = 0; }

 private:
  double force_ = 0;
  std::string name_ = "floor";
  std::vector<std::string> names_ = {"force_N"};
};

std::vector<palpate::Waypoint> press() {
  // Down into the floor and back up, over and over (10 s of waypoints).
  std::vector<palpate::Waypoint> w;
  for (int i = 0; i <= 100; ++i) w.push_back({i * 0.1, palpate::Vec3(0, (i % 2) ? -0.002 : 0.002, 0)});
  return w;
}

void tick_bench(benchmark::State& state, palpate::Coupling coupling, double physics_dt, bool time_stages = true) {
  BenchFloor floor;
  palpate::ScriptedDevice dev(press(), {}, palpate::Vec3(0, -1, 0));
  palpate::LoopSettings s;
  s.realtime = false;
  s.coupling = coupling;
  s.time_stages = time_stages;
  auto loop = palpate::HapticLoop::create(dev, {{&floor, physics_dt}}, s);
  if (!loop) {
    state.SkipWithError(loop.error().message.c_str());
    return;
  }
  for (auto _ : state) (*loop)->run_headless(1);
  benchmark::DoNotOptimize(dev.last_force());
}

}  // namespace

// One tick on the haptic thread: device read, tissue step, safety filter, device write.
static void BM_HapticTickDirect(benchmark::State& state) { tick_bench(state, palpate::Coupling::direct, 0); }
BENCHMARK(BM_HapticTickDirect);

// The same without timing the tick's seven stages (LoopSettings::time_stages = false): the
// difference from BM_HapticTickDirect is what the stage timing costs a tick (eight time-stamp
// counter reads and seven histogram entries; issue 34 asks for ≤ 100 ns).
static void BM_HapticTickDirectStagesUntimed(benchmark::State& state) {
  tick_bench(state, palpate::Coupling::direct, 0, false);
}
BENCHMARK(BM_HapticTickDirectStagesUntimed);

// The same with the virtual coupling's implicit proxy step (a 3x3 solve) and the secant estimate.
static void BM_HapticTickVirtualCoupling(benchmark::State& state) {
  tick_bench(state, palpate::Coupling::virtual_, 0);
}
BENCHMARK(BM_HapticTickVirtualCoupling);

// Multi-rate rendering (inline: the floor steps every 10th tick, F0 + J·(x − x0) in between).
static void BM_HapticTickMultiRateRender(benchmark::State& state) {
  tick_bench(state, palpate::Coupling::direct, 0.010);
}
BENCHMARK(BM_HapticTickMultiRateRender);

// Publish and take one 120-byte value through the triple buffer (one thread: the exchange's cost).
static void BM_TripleBufferPublishRead(benchmark::State& state) {
  palpate::TripleBuffer<palpate::DeviceState> tb;
  palpate::DeviceState s;
  for (auto _ : state) {
    s.time += 1;
    tb.write_slot() = s;
    tb.publish();
    tb.update();
    benchmark::DoNotOptimize(tb.read().time);
  }
}
BENCHMARK(BM_TripleBufferPublishRead);

// Push one 16-column row into the recorder's ring (the haptic thread's cost; the writer drains).
static void BM_RecorderPush(benchmark::State& state) {
  const auto csv = std::filesystem::temp_directory_path() / "palpate_bench_recorder" / "run.csv";
  std::vector<std::string> cols(16, "c");
  auto rec = palpate::Recorder::open(csv, cols, {});
  if (!rec) {
    state.SkipWithError(rec.error().message.c_str());
    return;
  }
  std::vector<double> row(16, 0.25);
  for (auto _ : state) {
    row[0] += 1;
    (*rec)->push_wait(row);
  }
  (void)(*rec)->close();
}
BENCHMARK(BM_RecorderPush);

// A realtime run of the loop at 1 kHz (floor tissue, scripted device, every tick recorded), for
// PALPATE_REALTIME_SECONDS seconds (default 2; docs/benchmarks/haptics.md uses 60). Reports the
// period's median / p99 / max (ms), the step's p99 (µs), deadline misses and dropped rows.
static void BM_RealtimeLoop(benchmark::State& state) {
  const char* env = std::getenv("PALPATE_REALTIME_SECONDS");
  const double seconds = env ? std::max(0.1, std::atof(env)) : 2.0;
  for (auto _ : state) {
    BenchFloor floor;
    palpate::ScriptedDevice dev(press(), {}, palpate::Vec3(0, -1, 0));
    palpate::LoopSettings s;
    s.realtime = true;
    s.max_ticks = static_cast<std::uint64_t>(seconds * 1000);
    s.csv = std::filesystem::temp_directory_path() / "palpate_bench_realtime" / "run.csv";
    s.try_realtime_priority = state.range(0) != 0;
    auto loop = palpate::HapticLoop::create(dev, {{&floor, 0.0}}, s);
    if (!loop || !(*loop)->start()) {
      state.SkipWithError("could not start the loop");
      return;
    }
    (*loop)->wait();
    (void)(*loop)->finish_recording();
    const palpate::LoopStats st = (*loop)->stats();
    state.SetIterationTime(double(st.ticks) * s.dt);
    state.counters["ticks"] = double(st.ticks);
    state.counters["period_median_ms"] = st.period.median * 1e3;
    state.counters["period_p99_ms"] = st.period.p99 * 1e3;
    state.counters["period_max_ms"] = st.period.max * 1e3;
    state.counters["step_p99_us"] = st.step.p99 * 1e6;
    state.counters["deadline_misses"] = double(st.deadline_misses);
    state.counters["overruns"] = double(st.safety.overrun);
    state.counters["dropped"] = double(st.recorder_dropped);
    state.counters["sched_fifo"] = st.realtime_priority ? 1 : 0;
  }
}
BENCHMARK(BM_RealtimeLoop)->Arg(0)->Arg(1)->ArgName("fifo")->Iterations(1)->UseManualTime()->Unit(benchmark::kMillisecond);
