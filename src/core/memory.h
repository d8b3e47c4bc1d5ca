// memory.h — how much memory this process may use, for the load-time estimates that refuse what
// cannot fit (a patch, a mesh, a predictor, a scene's waypoints) before it is built.
#pragma once

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cstdlib>
#include <cstring>
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

}  // namespace palpate
