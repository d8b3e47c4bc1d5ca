// viewer.h — `palpate view`: the interactive window (GLFW + OpenGL 3.3 + Dear ImGui) over a scene
// whose tissues run in a realtime HapticLoop driven by the mouse as a virtual haptic device.
#pragma once

#include <palpate/core.h>
#include <palpate/scene_def.h>

#include <filesystem>
#include <optional>

namespace palpate::view {

// A scripted press: the virtual device goes to the surface under window pixel (x, y), then `depth`
// metres beyond it along the ray from the eye (the HIP's depth below the picked surface point).
struct ProbeRequest {
  double x = 0, y = 0;  // pixels, top-left origin
  double depth = 0;     // m
};

struct ViewerOptions {
  int frames = 0;                    // with exit_after: draw at least this many frames
  bool exit_after = false;           // exit by itself after `frames` (and a scripted probe settled)
  std::filesystem::path screenshot;  // written when exiting; also the F12 / S key's file
  std::filesystem::path cache;       // predictor cache; "" = default_predictor_cache()
  std::optional<ProbeRequest> probe; // press the tool in at start
  int width = 0, height = 0;         // window size in pixels; 0 = the scene camera's
  bool quiet = false;                // print nothing but errors (no exit report)
  double overrun_margin = -1;        // s, the haptic watchdog's margin; < 0 = the scene's device.overrun_margin
  double tool_speed = 0.05;          // m/s, fastest the mouse moves the virtual device
  int resolution = 6;                // drawn surface: segments per Bézier patch edge
  double settle = 0.5;               // s a scripted probe holds still before the exit screenshot
  double timeout = 60;               // s of wall time an exit_after run may take before it fails
  bool panels = true;                // draw the ImGui panels
  bool screenshot_panels = false;    // the exit screenshot with the panels drawn over the scene
};

// Open the window and run until it is closed (or, with exit_after, until done). Returns the
// process exit code: 0 fine, 1 a runtime failure (screenshot, probe missed, timeout), 2 the scene's
// tissues could not be built, 3 no window or OpenGL 3.3. Messages go to stderr; on exit it prints
// `frames:`, `force_N:` and `force:` lines to stdout, and the Outcome panel's last figures
// (`outcome:`, `skin_punctures:`, `passes:`, `deepest_depth_m:`).
int run_viewer(const SceneDef& scene, const ViewerOptions& options);

}  // namespace palpate::view
