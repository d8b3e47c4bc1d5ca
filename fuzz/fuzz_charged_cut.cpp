// fuzz_charged_cut.cpp — random blade paths through a charged-particle patch (issue 37, item 8):
// crossing, re-cutting, cutting pieces off, NaN and teleporting poses, zero and negative edges,
// resets. The records and what counts as a finding: tests/charged_cut_drive.h (shared with
// test_fuzz_inputs.cpp, which runs the seeds). A finding: a crash, a sanitizer report, or what the
// drive reports (a non-finite force or position, cuts lost without clear_cuts, a link cut on one
// side only).
#include "../tests/charged_cut_drive.h"

#include <cstdio>
#include <cstdlib>

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, size_t size) {
  if (const auto broke = palpate::fuzz::drive_charged_cut(data, size)) {
    std::fprintf(stderr, "fuzz_charged_cut: %s\n", broke->c_str());
    std::abort();
  }
  return 0;
}
