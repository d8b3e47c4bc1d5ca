// bench_memory.cpp — what one core of this machine reads per second from each level of its cache
// hierarchy: the roofline the solvers' figures are read against (docs/benchmarks/spring.md, "The
// 10k tick against the machine"). A buffer of the given size is summed again and again with
// 512-bit loads (256-bit without AVX-512), so it sits in L1/L2 when small and in L3 when larger
// than L2; bytes_per_second is the read rate. Not palpate code: a reference for its numbers.
#include "core/memory.h"  // CacheLineAllocator

#include <benchmark/benchmark.h>

#include <cstddef>
#include <cstdint>
#include <vector>

#include <immintrin.h>

namespace {

#pragma GCC diagnostic push  // GCC 12's AVX-512 intrinsics warn about their own uninitialised locals
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
// Four independent sums, one 64-byte line per load pair or load: bound by the loads, not the adds.
__attribute__((target("avx512f"))) float sum_avx512(const float* a, size_t n) noexcept {
  __m512 s0 = _mm512_setzero_ps(), s1 = s0, s2 = s0, s3 = s0;
  for (size_t i = 0; i < n; i += 64) {
    s0 = _mm512_add_ps(s0, _mm512_load_ps(a + i));
    s1 = _mm512_add_ps(s1, _mm512_load_ps(a + i + 16));
    s2 = _mm512_add_ps(s2, _mm512_load_ps(a + i + 32));
    s3 = _mm512_add_ps(s3, _mm512_load_ps(a + i + 48));
  }
  return _mm512_reduce_add_ps(_mm512_add_ps(_mm512_add_ps(s0, s1), _mm512_add_ps(s2, s3)));
}
#pragma GCC diagnostic pop

__attribute__((target("avx"))) float sum_avx(const float* a, size_t n) noexcept {
  __m256 s0 = _mm256_setzero_ps(), s1 = s0, s2 = s0, s3 = s0;
  for (size_t i = 0; i < n; i += 64) {
    s0 = _mm256_add_ps(s0, _mm256_add_ps(_mm256_load_ps(a + i), _mm256_load_ps(a + i + 8)));
    s1 = _mm256_add_ps(s1, _mm256_add_ps(_mm256_load_ps(a + i + 16), _mm256_load_ps(a + i + 24)));
    s2 = _mm256_add_ps(s2, _mm256_add_ps(_mm256_load_ps(a + i + 32), _mm256_load_ps(a + i + 40)));
    s3 = _mm256_add_ps(s3, _mm256_add_ps(_mm256_load_ps(a + i + 48), _mm256_load_ps(a + i + 56)));
  }
  float out[8];
  _mm256_storeu_ps(out, _mm256_add_ps(_mm256_add_ps(s0, s1), _mm256_add_ps(s2, s3)));
  return out[0] + out[1] + out[2] + out[3] + out[4] + out[5] + out[6] + out[7];
}

// state.range(0): the buffer in KiB.
void BM_MemoryRead(benchmark::State& state) {
  const size_t bytes = static_cast<size_t>(state.range(0)) * 1024;
  const size_t n = bytes / sizeof(float) / 64 * 64;
  std::vector<float, palpate::CacheLineAllocator<float>> a(n);  // aligned loads need 64-byte lines
  for (size_t i = 0; i < n; ++i) a[i] = static_cast<float>(i & 7);
  const bool avx512 = __builtin_cpu_supports("avx512f");
  if (!avx512 && !__builtin_cpu_supports("avx")) {
    state.SkipWithError("needs AVX");
    return;
  }
  for (auto _ : state) benchmark::DoNotOptimize(avx512 ? sum_avx512(a.data(), n) : sum_avx(a.data(), n));
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * static_cast<int64_t>(n * sizeof(float)));
  state.counters["KiB"] = static_cast<double>(state.range(0));
}
// 512 KiB (L2), 1.5 MiB (L2, near full), 4 and 16 MiB (L3), 64 MiB (L3 on this machine).
BENCHMARK(BM_MemoryRead)->Arg(512)->Arg(1536)->Arg(4096)->Arg(16384)->Arg(65536)->Unit(benchmark::kMicrosecond);

}  // namespace
