// stereo_flags.cpp — --stereo, --eye-separation and --convergence, shared by `palpate view` and
// `palpate run --frames` (docs/viewer.md, "Stereo").
#include "commands.h"

#include <cmath>
#include <string>

namespace palpate::cli {

void add_stereo_flags(CLI::App* command, StereoOptions& stereo, const std::string& what) {
  command
      ->add_option_function<std::string>(
          "--stereo",
          [&stereo](const std::string& text) {
            // Checked below: parse_stereo_mode accepts it here.
            if (auto mode = parse_stereo_mode(text)) stereo.mode = *mode;
          },
          what + " in stereo: anaglyph (red-cyan glasses), side-by-side, top-bottom, or quad-buffer "
                 "(a stereo OpenGL context, where the display offers one)")
      ->type_name("MODE")
      ->check(CLI::Validator(
          [](std::string& text) -> std::string {
            auto mode = parse_stereo_mode(text);
            return mode ? std::string() : mode.error().message;
          },
          "MODE"));
  command
      ->add_option_function<double>(
          "--eye-separation", [&stereo](double mm) { stereo.eye_separation = mm * 1e-3; },
          "Stereo: distance between the eyes, mm (default 63)")
      ->type_name("MM")
      ->check(CLI::Range(0.0, 1000.0));
  command
      ->add_option_function<double>(
          "--convergence", [&stereo](double m) { stereo.convergence = m; },
          "Stereo: distance from the camera, m, of the plane both eyes see alike (zero disparity; "
          "default: the camera's distance to its target)")
      ->type_name("M")
      ->check(CLI::Validator(
          [](std::string& text) -> std::string {
            double m = 0;
            try {
              m = std::stod(text);
            } catch (...) {
              return "expected a distance in m, not '" + text + "'";
            }
            return std::isfinite(m) && m > 0 ? std::string() : "expected a distance > 0 m, not " + text;
          },
          "M > 0"));
}

}  // namespace palpate::cli
