// test_blade_run.cpp — a blade tool from scene to run (issue 37): `palpate run` on a blade over a
// charged patch and over a mass-spring block (tests/data/scenes/blade-*.yaml) ends cleanly, builds
// the tool in its blade role, draws the blade in the frames where its edge projects, exports it in
// the glTF as a flat blade with its handle, and counts in summary.json a tick the blade teleported
// (zero on a clean path); a blade out of range is refused at load naming the key.
#include "components.h"
#include "png_read.h"
#include "scene_fixtures.h"
#include "shell_run.h"

#include <palpate/render.h>
#include <palpate/scene.h>
#include <palpate/simulation.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <tiny_gltf.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

namespace fs = std::filesystem;
using palpate::Vec3;
using palpate::test::Ran;

namespace {

const std::string kPatch = PALPATE_TEST_DATA_DIR "/scenes/blade-patch.yaml";
const std::string kBlock = PALPATE_TEST_DATA_DIR "/scenes/blade-block.yaml";

fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("palpate_test_blade_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

nlohmann::json summary_of(const fs::path& out) {
  return nlohmann::json::parse(palpate::test::read_file(out / "summary.json"));
}

// The blade's edge colour as the frames draw it (1, 0.92, 0.55): yellow, where the steel is grey
// and the lit tissue pink (green well under red: about 0.72 of it).
// Counts them, and the farthest (pixels) any lies from the segment a → b.
long edge_pixels(const palpate::test::Png& png, const Eigen::Vector2d& a, const Eigen::Vector2d& b, double& farthest) {
  long n = 0;
  farthest = 0;
  const Eigen::Vector2d e = b - a;
  for (int y = 0; y < png.height; ++y)
    for (int x = 0; x < png.width; ++x) {
      const unsigned char* p = png.at(x, y);
      if (!(p[0] > 150 && p[1] > 0.85 * p[0] && p[2] < 0.65 * p[0])) continue;
      ++n;
      const Eigen::Vector2d q(x + 0.5, y + 0.5);
      const double t = std::clamp((q - a).dot(e) / e.squaredNorm(), 0.0, 1.0);
      farthest = std::max(farthest, (a + t * e - q).norm());
    }
  return n;
}

}  // namespace

TEST(BladeRun, TheSceneBuildsItsToolAsABlade) {
  for (const std::string& file : {kPatch, kBlock}) {
    auto scene = palpate::load_scene(file);
    ASSERT_TRUE(scene.ok()) << scene.error().message;
    EXPECT_EQ(scene->tool.kind, "blade");
    const fs::path dir = fresh_dir("build");
    palpate::SimulationOptions o;
    o.cache = dir / "cache";
    auto sim = palpate::Simulation::build(*scene, o);
    ASSERT_TRUE(sim.ok()) << sim.error().message;
    const palpate::SimulationTool* blade = (*sim)->tool(palpate::ToolRole::blade);
    ASSERT_NE(blade, nullptr) << file;
    EXPECT_EQ(blade->name, "tool");
    EXPECT_STREQ(palpate::tool_role_name(blade->role), "blade");
    EXPECT_EQ((*sim)->tool(palpate::ToolRole::needle), nullptr);
    EXPECT_EQ((*sim)->loop_settings().tool.kind, "blade");
    EXPECT_EQ((*sim)->loop_settings().tool.length, scene->tool.length);
    fs::remove_all(dir);
  }
}

TEST(BladeRun, ABladeRunsEndToEndOnAPatchAndABlockDrawnInItsFramesWithNoJump) {
  PALPATE_NEEDS_CLI();
  for (const std::string& file : {kPatch, kBlock}) {
    const fs::path out = fresh_dir("run");
    const Ran r = palpate::test::run_cli("run " + file + " -q --frames 3 --export gltf --cache " +
                                         (out / "cache").string() + " -o " + out.string());
    ASSERT_EQ(r.code, 0) << r.out;
    const nlohmann::json j = summary_of(out);
    // The counters are there, and nothing had to step in on a clean path.
    ASSERT_TRUE(j["safety"].contains("blade_teleport")) << j["safety"].dump();
    EXPECT_EQ(j["safety"]["blade_teleport"], 0) << file;
    EXPECT_EQ(j["safety"]["device_failed"], 0) << file;
    EXPECT_EQ(j["safety"]["non_finite"], 0) << file;
    EXPECT_EQ(j["safety"]["step_failed"], 0) << file;
    // The middle frame is drawn mid-stroke: the edge shows in its colour (where the tissue's drawn
    // surface does not hide it), and only along where it projects.
    ASSERT_EQ(j["outputs"]["frames"].size(), 3u) << j["outputs"].dump();
    if (PALPATE_HAS_OSMESA) {
      auto scene = palpate::load_scene(file);
      ASSERT_TRUE(scene.ok());
      const double t = j["outputs"]["frames"][1]["time_s"].get<double>();
      // The scripted stroke's tip at t (both fixtures: in by 0.3 s, along at constant speed after).
      const auto& w = scene->device.waypoints;
      Vec3 tip = w.front().position;
      for (size_t k = 0; k + 1 < w.size(); ++k)
        if (t >= w[k].t && t <= w[k + 1].t) tip = w[k].position + (t - w[k].t) / (w[k + 1].t - w[k].t) * (w[k + 1].position - w[k].position);
      const Vec3 heel = tip - scene->tool.length * scene->tool.axis.normalized();
      const auto a = palpate::project_to_pixel(*scene->camera, heel), b = palpate::project_to_pixel(*scene->camera, tip);
      ASSERT_TRUE(a.has_value() && b.has_value());
      const auto png = palpate::test::load_png(out / j["outputs"]["frames"][1]["file"].get<std::string>());
      double farthest = 0;
      const long n = edge_pixels(png, *a, *b, farthest);
      EXPECT_GT(n, 10) << file << ": the edge is drawn";
      EXPECT_LT(farthest, 2.5) << file << ": an edge pixel off the edge's projection " << a->transpose() << " → "
                               << b->transpose();
    }
    // The glTF carries the blade: the tool's mesh in its own frame (tip at the origin) reaches back
    // along the axis over the edge and the handle, and is flat (a blade, not a rod or a sphere).
    tinygltf::Model m;
    tinygltf::TinyGLTF loader;
    std::string err, warn;
    ASSERT_TRUE(loader.LoadBinaryFromFile(&m, &err, &warn, (out / "run.glb").string())) << err;
    const tinygltf::Node& node = m.nodes.back();
    EXPECT_EQ(node.name, "tool");
    const tinygltf::Accessor& pos =
        m.accessors.at(size_t(m.meshes.at(size_t(node.mesh)).primitives.at(0).attributes.at("POSITION")));
    ASSERT_EQ(pos.minValues.size(), 3u);
    auto scene = palpate::load_scene(file);
    ASSERT_TRUE(scene.ok());
    const Vec3 axis = scene->tool.axis.normalized();
    const Vec3 lo(pos.minValues[0], pos.minValues[1], pos.minValues[2]), hi(pos.maxValues[0], pos.maxValues[1], pos.maxValues[2]);
    const Vec3 reach = -(axis.array() > 0).select(lo, hi);  // the far corner back along −axis
    EXPECT_GT(reach.dot(axis), scene->tool.length + 0.05) << "edge and handle: " << lo.transpose() << " .. " << hi.transpose();
    EXPECT_LT(hi.z() - lo.z(), 0.0031) << "flat: the blade and handle face ±z";
    fs::remove_all(out);
  }
}

TEST(BladeRun, ATeleportOfTheBladeIsCountedInTheSummaryAndTheRunGoesOn) {
  PALPATE_NEEDS_CLI();
  const fs::path out = fresh_dir("teleport");
  // The patch's stroke with a glitch: at 0.8 s the device reports the blade 50 mm away for good.
  std::string text = palpate::test::read_file(kPatch);
  const std::string along = "    - {t: 1.3, position: [0.01, -0.002, 0]}    # drawn 20 mm along\n";
  const size_t at = text.find(along);
  ASSERT_NE(at, std::string::npos);
  text.replace(at, along.size(),
               "    - {t: 0.8, position: [0.0, -0.002, 0]}\n"
               "    - {t: 0.801, position: [0.05, -0.002, 0]}\n"
               "    - {t: 1.3, position: [0.06, -0.002, 0]}\n");
  const fs::path file = out / "teleport.yaml";
  std::ofstream(file) << text;
  const Ran r = palpate::test::run_cli("run " + file.string() + " --no-report -o " + (out / "o").string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("blade teleported 1 ticks"), std::string::npos) << r.out;
  const nlohmann::json j = summary_of(out / "o");
  EXPECT_EQ(j["safety"]["blade_teleport"], 1) << j["safety"].dump();
  EXPECT_EQ(j["safety"]["device_failed"], 0);
  // The tick is marked in run.csv's events column.
  const std::string csv = palpate::test::read_file(out / "o" / "run.csv");
  size_t marks = 0;
  for (size_t p = csv.find("blade_teleport"); p != std::string::npos; p = csv.find("blade_teleport", p + 1)) ++marks;
  EXPECT_EQ(marks, 1u);
  fs::remove_all(out);
}

TEST(BladeScene, ABladeOutOfRangeIsRefusedAtLoadNamingTheKey) {
  using scene_test::error_of;
  using scene_test::kOneTissue;
  EXPECT_EQ(error_of(std::string("tool: {kind: blade, length: 0.6}\n") + kOneTissue),
            "s.yaml:1: tool.length: 0.6 m is out of range; expected [0, 0.5] m");
  EXPECT_EQ(error_of(std::string("tool:\n  kind: blade\n  length: 0.02\n  radius: 0.1\n") + kOneTissue),
            "s.yaml:4: tool.radius: 0.1 m is out of range; expected [1e-05, 0.05] m");
  EXPECT_EQ(error_of(std::string("tool:\n  kind: blade\n  radius: 0\n") + kOneTissue),
            "s.yaml:3: tool.radius: 0 m is out of range; expected [1e-05, 0.05] m");
  EXPECT_EQ(error_of(std::string("tool:\n  kind: blade\n  length: -0.01\n") + kOneTissue),
            "s.yaml:3: tool.length: -0.01 m is out of range; expected [0, 0.5] m");
  EXPECT_EQ(error_of(std::string("tool:\n  kind: blade\n  length: 0\n") + kOneTissue),
            "s.yaml:3: tool.length: a blade needs a length > 0 m (its cutting edge), got 0 m");
  EXPECT_EQ(error_of(std::string("tool: {kind: blade, length: 0.02, axis: [0, 0, 0]}\n") + kOneTissue),
            "s.yaml:1: tool.axis: expected a non-zero direction [x, y, z], got [0, 0, 0]");
}
