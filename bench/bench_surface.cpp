// bench_surface.cpp — per-frame re-tessellation speed of grid surfaces and PN triangles.
#include <palpate/surface.h>

#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

namespace {

using palpate::SurfaceDef;
using palpate::SurfaceScheme;
using palpate::Vec3f;

// A wavy rows x cols control grid, 1 mm spacing, in the xz plane.
std::vector<Vec3f> wavy_grid(int rows, int cols) {
  std::vector<Vec3f> g(size_t(rows) * cols);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      g[size_t(r) * cols + c] = Vec3f(0.001f * c, 0.002f * std::sin(0.3f * c) * std::cos(0.2f * r), -0.001f * r);
  return g;
}

// args: rows, cols, resolution, scheme (0 Bézier, 1 B-spline).
void BM_GridSurface(benchmark::State& state) {
  const int rows = int(state.range(0)), cols = int(state.range(1)), res = int(state.range(2));
  const auto scheme = state.range(3) == 0 ? SurfaceScheme::bezier : SurfaceScheme::bspline;
  auto t = palpate::SurfaceTessellator::build(rows, cols, SurfaceDef{scheme, res});
  if (!t) {
    state.SkipWithError(t.error().message.c_str());
    return;
  }
  auto grid = wavy_grid(rows, cols);
  std::vector<float> positions(3 * t->point_count()), normals(3 * t->point_count());
  int frame = 0;
  for (auto _ : state) {
    grid[size_t(rows / 2) * cols + cols / 2].y() = -0.001f * float(frame++ % 7);  // a moving dent
    const bool ok = t->tessellate(grid, positions, normals);
    benchmark::DoNotOptimize(ok);
    benchmark::DoNotOptimize(positions.data());
    benchmark::ClobberMemory();
  }
  state.counters["points"] = double(t->point_count());
  state.counters["patches"] = double(t->patch_rows() * t->patch_cols());
  state.counters["particles"] = double(rows * cols);
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(t->point_count()));
}

// The seed paper's drawing load: 50 Bézier patches of 20 x 20 = 400 points, 20,000 points.
// (A 16 x 31 control grid: 5 x 10 patches.)
BENCHMARK(BM_GridSurface)->Name("Surface/bezier_50patches_20k")->Args({16, 31, 19, 0})->Unit(benchmark::kMicrosecond);
// 5,000 particles (70 x 72 grid, 23 x 24 = 552 patches) drawn with ~20,000 points (6 x 6 each).
BENCHMARK(BM_GridSurface)->Name("Surface/bezier_5000particles_20k")->Args({70, 72, 5, 0})->Unit(benchmark::kMicrosecond);
// The same 5,000 particles as a B-spline (69 x 71 = 4,899 spans, 3 x 3 points each: 44,091 points).
BENCHMARK(BM_GridSurface)->Name("Surface/bspline_5000particles_44k")->Args({70, 72, 2, 1})->Unit(benchmark::kMicrosecond);
// One million points: the 5,000-particle grid at 43 x 43 points per patch (1,020,648 points).
BENCHMARK(BM_GridSurface)->Name("Surface/bezier_5000particles_1M")->Args({70, 72, 42, 0})->Unit(benchmark::kMillisecond);
// ... and as a B-spline at 15 x 15 points per span (1,102,275 points).
BENCHMARK(BM_GridSurface)->Name("Surface/bspline_5000particles_1M")->Args({70, 72, 14, 1})->Unit(benchmark::kMillisecond);

// PN triangles over a 50 x 50 vertex grid mesh (4,802 triangles), level 3 (9 triangles each).
void BM_PnTriangles(benchmark::State& state) {
  const int n = 50, level = int(state.range(0));
  std::vector<Vec3f> v, normals;
  std::vector<std::array<int, 3>> f;
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) {
      const float x = 0.001f * c, z = -0.001f * r;
      v.emplace_back(x, 0.002f * std::sin(300 * x) * std::cos(200 * z), z);
      normals.emplace_back(Vec3f(-0.6f * std::cos(300 * x) * std::cos(200 * z), 1.0f,
                                 -0.4f * std::sin(300 * x) * std::sin(200 * z)).normalized());
    }
  for (int r = 0; r + 1 < n; ++r)
    for (int c = 0; c + 1 < n; ++c) {
      const int a = r * n + c;
      f.push_back({a, a + 1, a + n + 1});
      f.push_back({a, a + n + 1, a + n});
    }
  auto pn = palpate::PnTessellator::build(int(v.size()), f, level);
  if (!pn) {
    state.SkipWithError(pn.error().message.c_str());
    return;
  }
  std::vector<float> positions(3 * pn->point_count()), out_normals(3 * pn->point_count());
  for (auto _ : state) {
    const bool ok = pn->tessellate(v, normals, positions, out_normals);
    benchmark::DoNotOptimize(ok);
    benchmark::ClobberMemory();
  }
  state.counters["points"] = double(pn->point_count());
  state.counters["triangles"] = double(pn->triangle_count());
}
BENCHMARK(BM_PnTriangles)->Name("Surface/pn_triangles_4802tris")->Arg(3)->Unit(benchmark::kMicrosecond);

}  // namespace
