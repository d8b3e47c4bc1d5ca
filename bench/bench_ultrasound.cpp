// Ultrasound benchmarks (docs/ultrasound.md, docs/BENCHMARKS.md): one B-mode image of the neck, the
// probe resting and pressed, with the needle in the plane; and the probe's force, which the haptic
// thread computes every tick.
#include <palpate/anatomy.h>
#include <palpate/ultrasound.h>

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <vector>

namespace {

using namespace palpate;

ProbePose over_vein(const NeckDef& neck, double press) {
  ProbePose pose;
  const double x = neck_vein(neck).axis_point.x();
  pose.position = Vec3(x, neck_skin_height(neck, x) - press, 0);
  return pose;
}

// Args: image side in pixels, indentation in tenths of a millimetre.
void BM_Ultrasound(benchmark::State& bs) {
  const NeckDef neck;
  ProbeDef probe;
  probe.image_width = probe.image_height = int(bs.range(0));
  UltrasoundImager us(neck, probe);
  const ProbePose pose = over_vein(neck, 1e-4 * double(bs.range(1)));
  NeedlePose needle;
  needle.present = true;
  needle.tip = Vec3(0.004, -0.012, 0);
  needle.axis = Vec3(-0.8, -0.6, 0);
  UltrasoundImage img;
  us.render(pose, needle, 0, img);  // buffers allocated once
  double t = 0;
  std::vector<double> ms;
  ms.reserve(100000);
  for (auto _ : bs) {
    const auto t0 = std::chrono::steady_clock::now();
    us.render(pose, needle, t, img);
    benchmark::DoNotOptimize(img.grey.data());
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    t += 0.033;
  }
  bs.counters["force_N"] = us.neck().probe_force(pose).norm();
  // Per image: the median and the 99th percentile of the wall time (one core).
  std::sort(ms.begin(), ms.end());
  bs.counters["median_ms"] = ms[ms.size() / 2];
  bs.counters["p99_ms"] = ms[std::min(ms.size() - 1, size_t(0.99 * double(ms.size())))];
}

void BM_UltrasoundProbeForce(benchmark::State& bs) {
  const NeckDef neck;
  const ProbeDef probe;
  NeckCompression model(neck, probe);
  ProbePose pose = over_vein(neck, 0.004);
  double t = 0;
  for (auto _ : bs) {
    pose.position.y() += 1e-9;
    benchmark::DoNotOptimize(model.force(pose.position, pose.orientation, t));
    t += 0.001;
  }
}

}  // namespace

BENCHMARK(BM_Ultrasound)->Args({256, 5})->Args({256, 60})->Args({512, 60})->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_UltrasoundProbeForce)->Unit(benchmark::kMicrosecond);
