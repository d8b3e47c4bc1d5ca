// fuzz_csv.cpp — the device CSVs through io::CsvRows: a scripted device's trajectory
// (load_trajectory_csv, FUZZ_RECORDING=0) or a replay's recording (load_recording_csv, 1).
#include <palpate/device.h>

#include "fuzz_common.h"

#include <cmath>

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, size_t size) {
  using namespace palpate;
  const auto file = fuzz::save_input("input.csv", data, size);
  fuzz::no_throw([&] {
#if FUZZ_RECORDING
    Result<std::vector<RecordedSample>> rows = load_recording_csv(file);
    fuzz::check(rows, file.string());
    if (rows)
      for (const RecordedSample& s : *rows)  // a replay's device state is finite
        if (!std::isfinite(s.t) || !s.position.allFinite() || !s.orientation.coeffs().allFinite()) std::abort();
#else
    Result<std::vector<Waypoint>> rows = load_trajectory_csv(file);
    fuzz::check(rows, file.string());
    if (rows)
      for (const Waypoint& w : *rows)
        if (!std::isfinite(w.t) || !w.position.allFinite() || !w.direction.allFinite()) std::abort();
#endif
  });
  return 0;
}
