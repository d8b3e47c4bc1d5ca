// view_setup.h — how `palpate view` builds its scene's Simulation: realtime, every tissue handing its
// drawn state to the window (snapshots), running until the window closes, the mouse's virtual
// devices in the tools' place. Everything else (coupling, proxy, watchdog, physics rates, the outcome
// model) is the scene's, exactly as `palpate run` builds it (tests/test_view_parts.cpp).
#pragma once

#include "viewer.h"

#include <palpate/device.h>
#include <palpate/simulation.h>

namespace palpate::view {

// `tool_device`: drives the scene's `tool`; `probe_device`: its ultrasound `probe` (null: none).
SimulationOptions view_simulation_options(const ViewerOptions& options, Device* tool_device, Device* probe_device);

}  // namespace palpate::view
