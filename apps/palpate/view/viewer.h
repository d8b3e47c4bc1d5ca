// viewer.h — `palpate view`: the interactive window (GLFW + OpenGL 3.3 + Dear ImGui) over a scene
// whose tissues run in a realtime HapticLoop driven by the mouse as a virtual haptic device.
#pragma once

#include <palpate/core.h>
#include <palpate/render.h>
#include <palpate/scene_def.h>

#include <filesystem>
#include <array>
#include <optional>
#include <string>

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
  // The scene's scripted tools (the needle's device and the probe's, scripted or replay) played in
  // the window: `play` from the start at open; `play_to` ≥ 0 plays to that time (s) and pauses there
  // (with exit_after, the exit waits for it and for the tools to arrive). Space plays / pauses, N
  // steps 0.1 s; a press or tilt with the mouse pauses it and the hand takes over.
  bool play = false;
  double play_to = -1;
  // Keys pressed at open, one per frame from the second (the key handler's own path): e.g. "v" turns
  // the probe 90°, " " plays, "n" steps. Letters, digits and space.
  std::string keys;
  // With exit_after: once everything else is done, tilt the needle as a ctrl + left drag of
  // (dx, dy) pixels would (about the skin hole once it is through the skin), then settle.
  std::optional<std::array<double, 2>> tilt;
  // A needle scene writes report.html on exit (docs/cvc.md, "The report"): each attempt of the
  // session — from the start, and from each "New attempt" (A) or reset to rest — side by side.
  // "" = report.html in the scene's output folder; no_report: none.
  std::filesystem::path report;
  bool no_report = false;
  // --stereo (docs/viewer.md, "Stereo"): anaglyph, side by side, top and bottom (each eye in its
  // half of the window, at that half's aspect), or quad-buffer (a stereo OpenGL context: refused,
  // exit 1, where the display offers none). convergence 0: the orbit camera's distance to its target,
  // following the zoom.
  StereoOptions stereo;
};

// Open the window and run until it is closed (or, with exit_after, until done). Returns the
// process exit code: 0 fine, 1 a runtime failure (screenshot, probe missed, timeout), 2 the scene's
// tissues could not be built, 3 no window or OpenGL 3.3. Messages go to stderr; on exit it prints
// `frames:`, `force_N:` and `force:` lines to stdout, and the Outcome panel's last figures
// (`outcome:`, `skin_punctures:`, `passes:`, `deepest_depth_m:`); docs/viewer.md lists them all.
int run_viewer(const SceneDef& scene, const ViewerOptions& options);

}  // namespace palpate::view
