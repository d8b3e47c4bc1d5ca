// memory.h — how much memory this process may use, for the load-time estimates that refuse what
// cannot fit (a patch, a mesh, a predictor, a scene's waypoints) before it is built; and the
// cache-line allocator of the solvers' aligned layouts.
#pragma once

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cstdlib>
#include <cstddef>
#include <cstring>
#include <new>
#include <string>
#include <unistd.h>

namespace palpate {

// Bytes this process may plan to use: the machine's physical memory, or less where the
// environment's PALPATE_MEMORY_LIMIT (bytes, e.g. 8e9: a share of a machine that runs other work
// too) says so. 0 when unknown. (An address-space limit, `ulimit -v`, is not read: what slips past
// these estimates is caught as std::bad_alloc by the command, and tested so.)
inline double usable_memory_bytes() noexcept {
  double m = double(::sysconf(_SC_PHYS_PAGES)) * double(::sysconf(_SC_PAGE_SIZE));
  if (const char* env = std::getenv("PALPATE_MEMORY_LIMIT")) {
    double v = 0;
    const char* end = env + std::strlen(env);
    if (auto [p, ec] = std::from_chars(env, end, v); ec == std::errc() && p == end && v > 0) m = std::min(m, v);
  }
  return m > 0 ? m : 0;
}

// "3.5 GB", "120 MB", "5.83 kB": a byte count for a message.
inline std::string memory_text(double bytes) {
  if (bytes >= 1e9) return fmt::format("{:.3g} GB", bytes * 1e-9);
  if (bytes >= 1e6) return fmt::format("{:.3g} MB", bytes * 1e-6);
  return fmt::format("{:.3g} kB", bytes * 1e-3);
}

// std::allocator's job on 64-byte boundaries (a cache line, an AVX-512 register), so that blocks of
// values laid out on multiples of eight doubles are aligned loads.
template <typename T>
struct CacheLineAllocator {
  using value_type = T;
  CacheLineAllocator() noexcept = default;
  template <typename U>
  CacheLineAllocator(const CacheLineAllocator<U>&) noexcept {}  // NOLINT(google-explicit-constructor)
  T* allocate(std::size_t count) { return static_cast<T*>(::operator new(count * sizeof(T), std::align_val_t{64})); }
  // The unsized aligned delete: the sized one needs -fsized-deallocation, which clang leaves off.
  void deallocate(T* p, std::size_t) noexcept { ::operator delete(p, std::align_val_t{64}); }
  friend bool operator==(const CacheLineAllocator&, const CacheLineAllocator&) noexcept { return true; }
};

}  // namespace palpate
