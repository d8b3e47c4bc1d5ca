// bench_charged.cpp — one tick of the charged-particle model (HIP update, repulsion, propagation,
// relaxation, force) with the HIP pressed 5 mm into flat patches of 1 mm spacing, 1k to 1M particles.
#include <palpate/charged.h>

#include <benchmark/benchmark.h>

#include <cmath>

namespace {

using namespace palpate;

// A square-ish flat patch of about n particles, spacing 1 mm, and the HIP pressed 5 mm into it
// (its centre 5 mm below where it first touches: sphere of influence − 5 mm above the rest plane),
// reached by a slow press so the dimple and the active set are those of a real contact.
struct Pressed {
  ChargedModel model;
  ChargedState state;
  ChargedHip hip;
};

Pressed press_into(long n) {
  ChargedMaterialDef mat;
  mat.puncture_force = 100;  // a large force at max_displacement
  mat.max_displacement = 0.01;  // beyond the 5 mm press: no puncture
  PatchDef p;
  p.spacing = 0.001;
  const double side = std::sqrt(double(n) * p.spacing * p.spacing * std::sqrt(3.0) / 2);
  p.width = p.height = side;
  Pressed out{*build_charged_patch(p, mat), {}, {}};
  out.state = make_charged_state(out.model);
  const double R = mat.particle_radius, depth = 0.005;  // a HIP of radius 0
  for (int t = 0; t <= 500; ++t) {
    out.hip.position = Vec3(0.00025, R - depth * t / 500.0, 0);
    step(out.model, out.state, out.hip, 0.001);
  }
  return out;
}

void BM_ChargedTick(benchmark::State& bs) {
  Pressed p = press_into(bs.range(0));
  double fy = 0;
  int k = 0;
  for (auto _ : bs) {
    // A 1 µm wobble keeps every stage doing real work each tick (a held HIP still repels, relaxes).
    p.hip.position.x() = 0.00025 + 1e-6 * (k++ & 1);
    fy = step(p.model, p.state, p.hip, 0.001).y();
    benchmark::DoNotOptimize(fy);
  }
  bs.counters["particles"] = double(p.model.size());
  bs.counters["active"] = double(p.state.active_count);
  bs.counters["contacts"] = p.state.stats.contacts;
  bs.counters["force_N"] = fy;
  bs.counters["bytes_per_particle"] = double(charged_bytes_per_particle(p.model));
}

}  // namespace

BENCHMARK(BM_ChargedTick)->Arg(1000)->Arg(2500)->Arg(5000)->Arg(10000)->Arg(1000000)->Unit(benchmark::kMicrosecond);
