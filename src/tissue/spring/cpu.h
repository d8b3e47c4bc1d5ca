// cpu.h — which instruction sets this processor runs, for the kernels' dispatch (internal).
#pragma once

namespace palpate::spring {

// Whether this processor runs the AVX2 + FMA kernels (the vectorised passes fall back otherwise).
bool has_avx2_fma() noexcept;

// Whether this processor runs the AVX-512 kernels (AVX-512 F and VL, with AVX2 + FMA).
bool has_avx512() noexcept;

// The x86-64 micro-architecture levels the sparse and dense solves are built for (solve.cpp):
// v3 (AVX2, FMA, BMI1/2, …) and v4 (v3 and AVX-512 F, BW, CD, DQ, VL).
bool has_x86_64_v3() noexcept;
bool has_x86_64_v4() noexcept;

}  // namespace palpate::spring

// A function compiled twice: for x86-64-v3 (AVX2 + FMA; name_v3) and for any x86-64 (name_base),
// chosen per call by has_x86_64_v3() (a load of a global set by libgcc's constructor). Not
// target_clones: its ifunc resolvers run during relocation, before a sanitizer's runtime is up,
// and crash ThreadSanitizer builds at start.
#define PALPATE_TWICE(name, params, body)                                       \
  __attribute__((target("arch=x86-64-v3"))) void name##_v3 params noexcept body \
  void name##_base params noexcept body
