// stereo_sheet.h — the scene the stereo tests look at (tests/apps/test_stereo_cli.cpp,
// test_view_stereo.cpp): a 40 x 40 mm sheet at y = 0 (its corners held, no gravity), the 3 mm
// sphere held still 10 mm over its centre (never touching it: no force arrow), and the camera level
// with the sphere, 60 mm in front of it, looking past it at a target 100 mm away (the default
// convergence distance): the sphere is in front of the convergence plane, seen against the background.
#pragma once

#include <filesystem>
#include <fstream>
#include <string>

namespace palpate::test {

inline void write_stereo_sheet(const std::filesystem::path& file, const std::string& name, double duration,
                               int width, int height) {
  std::ofstream(file) << "name: " << name << "\nduration: " << duration << "\ndt: 0.001\noutput: out\n"
                      << "tool: {kind: sphere, radius: 0.003}\n"
                         "device:\n  kind: scripted\n  waypoints:\n    - {t: 0, position: [0, 0.01, 0]}\n"
                         "camera: {position: [0, 0.01, 0.06], target: [0, 0.01, -0.04], fov: 40, width: "
                      << width << ", height: " << height
                      << "}\n"
                         "tissues:\n  - name: sheet\n    model: mass_spring\n"
                         "    patch: {shape: flat, width: 0.04, height: 0.04, spacing: 0.004}\n"
                         "    material: {topology: edges, solver: desbrun, stiffness: 200, gravity: false}\n"
                         "    anchors: [0, 10, 110, 120]\n";
}

}  // namespace palpate::test
