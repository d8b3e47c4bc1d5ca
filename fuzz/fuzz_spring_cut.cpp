// fuzz_spring_cut.cpp — blade paths from the fuzzer's bytes through a mass-spring block (issue 37
// item 8; the driver tests/spring_cut_paths.h shares with test_spring_cut_paths.cpp). A finding is a
// crash, a sanitizer report, a non-finite value, an open drawn surface, a tetrahedron the cut inverted, or a
// step no longer exact to the cut network (every 16th input: the corrected solve's relative residual
// on the cut network's matrix over 1e-14, or the step over 1e-9 from a from-scratch predictor's).
#include "../tests/spring_cut_paths.h"

#include <cstdio>
#include <cstdlib>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, size_t size) {
  static const palpate::SpringModel base = palpate::cut_paths::block_model();
  static unsigned count = 0;
  if (size > 8 * 64) size = 8 * 64;  // (a path of 64 segments is long enough)
  const bool exact = (count++ % 16) == 0;
  const auto r = palpate::cut_paths::run_blade_path(base, data, size, exact);
  // An inverted tetrahedron is a finding only when the cut made it: the same path with a blade that
  // never cuts (the contact alone can push a vertex of the coarse block through a face) has none.
  const bool cut_inverted =
      r.inverted != 0 && palpate::cut_paths::run_blade_path(base, data, size, false, 1e9).inverted == 0;
  if (!r.finite || r.open_edges != 0 || cut_inverted || (exact && !(r.backward <= 1e-14 && r.residual <= 1e-9))) {
    std::fprintf(stderr, "fuzz_spring_cut: finite %d, open edges %d, inverted %d, residual %g\n", r.finite,
                 r.open_edges, r.inverted, r.residual);
    std::abort();
  }
  return 0;
}
