// bench_charged_cut.cpp — the charged-particle tick with a cut in progress (issue 37: ≤ 50 µs): a
// blade (edge 8 mm, upright) pressed 3 mm under a flat patch's rest surface (1.3 N, past the 1 N
// cutting force) and drawn 20 mm across it at 20 mm/s, 1,000 ticks, each of them cutting; every
// tick timed alone. Patches of 1 mm spacing, 10k and 100k particles (BM_ChargedCutTick).
#include <palpate/charged.h>

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

namespace {

using namespace palpate;

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, size_t(q * double(v.size())))];
}

void BM_ChargedCutTick(benchmark::State& bs) {
  const ChargedMaterialDef mat;
  PatchDef p;
  p.spacing = 0.001;
  p.width = p.height = std::sqrt(double(bs.range(0)) * p.spacing * p.spacing * std::sqrt(3.0) / 2);
  const ChargedModel model = *build_charged_patch(p, mat);
  ChargedHip hip;
  hip.blade = true, hip.sharp = false, hip.edge_length = 0.008, hip.radius = 0.0005;
  const double depth = -0.003, x0 = -0.01, z = 0.00025;
  // Pressed in at x0 (a slow press, as a hand would), not yet cutting: the start of every stroke.
  ChargedState pressed = make_charged_state(model);
  for (int t = 0; t <= 350; ++t) {
    hip.position = Vec3(x0, 0.004 + (depth - 0.004) * std::min(1.0, t / 300.0), z);
    step(model, pressed, hip, 0.001);
  }
  constexpr int kTicks = 1000;  // 20 mm at 20 µm a tick
  std::vector<double> ns;
  ns.reserve(size_t(kTicks) * 64);
  ChargedState s = pressed;
  long links = 0;
  int cutting = 0;
  double worst = 0, worst_at = 0;
  for (auto _ : bs) {
    bs.PauseTiming();
    s = pressed;  // same sizes: no allocation
    bs.ResumeTiming();
    for (int t = 1; t <= kTicks; ++t) {
      hip.position = Vec3(x0 + 0.00002 * t, depth, z);
      const auto t0 = std::chrono::steady_clock::now();
      const Vec3 f = step(model, s, hip, 0.001);
      const auto t1 = std::chrono::steady_clock::now();
      benchmark::DoNotOptimize(f);
      ns.push_back(double(std::chrono::duration_cast<std::chrono::nanoseconds>(t1 - t0).count()));
      if (ns.back() > worst) worst = ns.back(), worst_at = t;
      cutting += s.stats.cutting;
    }
    links = s.cut_link_count;
  }
  bs.counters["particles"] = double(model.size());
  bs.counters["links_cut_per_stroke"] = double(links);
  bs.counters["cutting_share"] = double(cutting) / double(ns.size());
  bs.counters["wound_particles"] = double(s.wound_count);
  bs.counters["tick_median_us"] = 1e-3 * percentile(ns, 0.5);
  bs.counters["tick_p99_us"] = 1e-3 * percentile(ns, 0.99);
  bs.counters["tick_max_us"] = 1e-3 * worst;
  bs.counters["tick_max_at"] = worst_at;  // the stroke's tick (1 .. 1000)
}
BENCHMARK(BM_ChargedCutTick)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond);

}  // namespace
