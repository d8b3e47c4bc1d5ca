// cmd_view.cpp — `palpate view SCENE`: the interactive viewer's command line.
#include <palpate/palpate.h>

#include "commands.h"
#include "view/viewer.h"

#include <fmt/core.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>

namespace palpate::cli {

namespace {

struct ViewArgs {
  std::string scene;
  bool verbose = false;
  std::string probe;  // "x,y,depth"
  std::string tilt;   // "dx,dy"
  view::ViewerOptions options;
};

// "x,y,depth" → ProbeRequest; the error names the flag and the expected form.
Result<view::ProbeRequest> parse_probe(const std::string& text) {
  view::ProbeRequest p;
  std::istringstream in(text);
  char c1 = 0, c2 = 0;
  if (!(in >> p.x >> c1 >> p.y >> c2 >> p.depth) || c1 != ',' || c2 != ',' || !(in >> std::ws).eof())
    return Error{"--probe '" + text + "': expected x,y,depth (window pixels and metres, e.g. 400,300,0.003)"};
  if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.depth) || p.depth < -0.1 || p.depth > 0.1)
    return Error{"--probe '" + text + "': depth must be finite and within [-0.1, 0.1] m"};
  return p;
}

// "dx,dy" → a drag in pixels; the error names the flag and the expected form.
Result<std::array<double, 2>> parse_tilt(const std::string& text) {
  std::array<double, 2> d{};
  std::istringstream in(text);
  char c = 0;
  if (!(in >> d[0] >> c >> d[1]) || c != ',' || !(in >> std::ws).eof() || !std::isfinite(d[0]) ||
      !std::isfinite(d[1]) || std::abs(d[0]) > 1000 || std::abs(d[1]) > 1000)
    return Error{"--tilt '" + text + "': expected dx,dy (a drag in window pixels, each within ±1000, e.g. 20,0)"};
  return d;
}

int view_command(ViewArgs& args) {
  auto scene = load_scene(args.scene);
  if (!scene) {
    fmt::print(stderr, "palpate view: {}\n", scene.error().message);
    return kExitFailed;
  }
  if (!args.options.quiet)
    for (const std::string& w : scene->warnings) fmt::print(stderr, "palpate view: warning: {}\n", w);
  if (args.verbose) print_scene_inputs(*scene, args.options.cache);
  if (!args.probe.empty()) {
    auto p = parse_probe(args.probe);
    if (!p) {
      fmt::print(stderr, "palpate view: {}\n", p.error().message);
      return kExitUsage;
    }
    args.options.probe = *p;
  }
  if (!args.tilt.empty()) {
    auto d = parse_tilt(args.tilt);
    if (!d) {
      fmt::print(stderr, "palpate view: {}\n", d.error().message);
      return kExitUsage;
    }
    args.options.tilt = *d;
  }
  if (args.options.exit_after && args.options.frames < 1) args.options.frames = 1;
  prepare_realtime_process();  // the viewer runs a realtime haptic loop beside its GL thread
  return view::run_viewer(*scene, args.options);
}

}  // namespace

void add_view_command(CLI::App& app) {
  auto args = std::make_shared<ViewArgs>();
  CLI::App* view = app.add_subcommand(
      "view", "Open a window on a scene: the mouse drives the tool as a virtual haptic device");
  view->add_option("scene", args->scene, "Scene file (YAML, see docs/scene-format.md)")
      ->required()->check(CLI::ExistingFile);
  view->add_option("--frames", args->options.frames, "With --exit: frames to draw before exiting")
      ->check(CLI::NonNegativeNumber);
  view->add_flag("--exit", args->options.exit_after,
                 "Exit by itself after --frames frames (and a --probe settled); ignores the mouse");
  view->add_option("--cache", args->options.cache, "Folder for the predictors a scene does not name (default: $XDG_CACHE_HOME/palpate/predictors or ~/.cache/palpate/predictors)");
  view->add_option("--screenshot", args->options.screenshot,
                   "PNG written on exit (and by the F12 / S key); written atomically");
  view->add_option("--probe", args->probe,
                   "Press the tool in at start: x,y (window pixels) and depth (m) past the surface there "
                   "(a needle along its own shaft, a sphere along the eye's ray)");
  view->add_option("--width", args->options.width, "Window width in pixels (default: the scene camera's)")
      ->check(CLI::Range(0, 8192));
  view->add_option("--height", args->options.height, "Window height in pixels (default: the scene camera's)")
      ->check(CLI::Range(0, 8192));
  view->add_option("--resolution", args->options.resolution, "Drawn surface: segments per Bézier patch edge")
      ->check(CLI::Range(1, 32));
  view->add_option("--tool-speed", args->options.tool_speed, "Fastest the mouse moves the tool, m/s")
      ->check(CLI::Range(1e-4, 10.0));
  view->add_option("--overrun-margin", args->options.overrun_margin,
                   "Haptic watchdog: s past a tick's deadline before force goes to zero (default: the library's)")
      ->check(CLI::Range(0.0, 1.0));
  view->add_option("--settle", args->options.settle, "With --probe and --exit: s to hold still (wall and simulated time, no tick zeroed by the safety filter) before the screenshot")
      ->check(CLI::Range(0.0, 60.0));
  view->add_flag("--play", args->options.play,
                 "Play the scene's scripted tools (the needle's and the probe's device) from the start; Space pauses");
  view->add_option("--play-to", args->options.play_to,
                   "Play the scene's scripted tools to this time (s) and pause there; with --exit, exit once there")
      ->check(CLI::Range(0.0, 1e6));
  view->add_option("--keys", args->options.keys,
                   "Keys pressed at open, one a frame: v turns the probe 90 deg, space plays, n steps 0.1 s, r untilts, a starts a new attempt")
      ->check([](const std::string& k) {
        return k.find_first_not_of(" abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789") == std::string::npos
                   ? std::string()
                   : std::string("letters, digits and spaces only");
      });
  view->add_option("--tilt", args->tilt,
                   "With --exit: after the press / the script, tilt the needle as a ctrl + left drag of dx,dy pixels "
                   "(about the skin hole once it is in), then settle");
  view->add_option("--report", args->options.report,
                   "report.html of the session's attempts, written on exit (default: report.html in the scene's output folder)");
  view->add_flag("--no-report", args->options.no_report, "Write no report.html on exit");
  // A callback, not "!--no-panels" bound to the bool: CLI11 would print that one's value ({false}) in --help.
  view->add_flag_callback("--no-panels", [args] { args->options.panels = false; }, "Hide the ImGui panels");
  view->add_flag_callback("--screenshot-panels", [args] { args->options.screenshot_panels = true; },
                          "Take the exit --screenshot with the panels drawn (as the trainee sees the window)");
  add_stereo_flags(view, args->options.stereo, "Draw the window");
  add_output_flags(view, args->options.quiet, args->verbose);
  view->callback([args] { throw CLI::RuntimeError(view_command(*args)); });
}

}  // namespace palpate::cli
