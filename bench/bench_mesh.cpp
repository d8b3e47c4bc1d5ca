// bench_mesh.cpp — cost of loading the shared liver meshes and of describe(): load-time work, not the 1 kHz path.
#include <palpate/mesh.h>
#include <palpate/mesh_load.h>

#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>

namespace {

std::filesystem::path shared_mesh(const char* name) {
  return std::filesystem::path(PALPATE_DATA_DIR) / "meshes" / name;
}

void BM_LoadSurfaceLiverSmoothObj(benchmark::State& state) {
  const auto file = shared_mesh("liver-smooth.obj");  // 2194 vertices, 4384 triangles
  for (auto _ : state) {
    auto m = palpate::load_surface(file);
    if (!m) state.SkipWithError(m.error().message.c_str());
    benchmark::DoNotOptimize(m);
  }
}
BENCHMARK(BM_LoadSurfaceLiverSmoothObj)->Unit(benchmark::kMillisecond);

void BM_LoadTetLiverMsh(benchmark::State& state) {
  const auto file = shared_mesh("liver.msh");  // Gmsh v1: 181 nodes, 596 tetrahedra
  for (auto _ : state) {
    auto m = palpate::load_tet(file);
    if (!m) state.SkipWithError(m.error().message.c_str());
    benchmark::DoNotOptimize(m);
  }
}
BENCHMARK(BM_LoadTetLiverMsh)->Unit(benchmark::kMillisecond);

void BM_LoadTetLiverVtk(benchmark::State& state) {
  const auto file = shared_mesh("liver_tet.vtk");  // the same mesh through the hand-written reader
  for (auto _ : state) {
    auto m = palpate::load_tet(file);
    if (!m) state.SkipWithError(m.error().message.c_str());
    benchmark::DoNotOptimize(m);
  }
}
BENCHMARK(BM_LoadTetLiverVtk)->Unit(benchmark::kMillisecond);

void BM_DescribeLiverSmooth(benchmark::State& state) {
  const auto m = palpate::load_surface(shared_mesh("liver-smooth.obj"));
  if (!m) {
    state.SkipWithError(m.error().message.c_str());
    return;
  }
  for (auto _ : state) {
    palpate::MeshInfo info = palpate::describe(*m);
    benchmark::DoNotOptimize(info);
  }
}
BENCHMARK(BM_DescribeLiverSmooth)->Unit(benchmark::kMicrosecond);

}  // namespace
