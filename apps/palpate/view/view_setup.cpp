// view_setup.cpp — the Simulation options of `palpate view` (view_setup.h).
#include "view_setup.h"

namespace palpate::view {

SimulationOptions view_simulation_options(const ViewerOptions& options, Device* tool_device, Device* probe_device) {
  SimulationOptions so;
  so.realtime = true;
  so.snapshots = true;
  so.stop_after_duration = false;  // the window decides when it ends
  so.cache = options.cache;
  so.overrun_margin = options.overrun_margin;  // < 0: the scene's device.overrun_margin
  if (tool_device) so.devices.push_back({"tool", tool_device});
  if (probe_device) so.devices.push_back({"probe", probe_device});
  return so;
}

}  // namespace palpate::view
