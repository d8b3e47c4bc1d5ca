// cpu.cpp — CPU detection for the spring kernels' dispatch (cpu.h).
#include "tissue/spring/cpu.h"

namespace palpate::spring {

// No function-local static: its first call would take the initialisation guard (a lock) on the
// haptic thread. libgcc fills the CPU model when it loads, so reading it is a few loads.
bool has_avx2_fma() noexcept { return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"); }

bool has_avx512() noexcept {
  return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") && has_avx2_fma();
}

#if defined(__clang__)
// clang (14) knows no "x86-64-v3"/"-v4" in __builtin_cpu_supports: the levels' defining features
// instead (the fuzz preset builds with clang).
bool has_x86_64_v3() noexcept {
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") && __builtin_cpu_supports("bmi") &&
         __builtin_cpu_supports("bmi2");  // every CPU with these has the rest (F16C, MOVBE, LZCNT)
}
bool has_x86_64_v4() noexcept {
  return has_x86_64_v3() && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
         __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512cd");
}
#else
bool has_x86_64_v3() noexcept { return __builtin_cpu_supports("x86-64-v3"); }
bool has_x86_64_v4() noexcept { return __builtin_cpu_supports("x86-64-v4"); }
#endif

}  // namespace palpate::spring
