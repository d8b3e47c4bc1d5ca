// test_simulation.cpp — Simulation: a scene compiled once, what `palpate run` and `palpate view` both
// build. Each shipped scene gives the viewer the loop settings it gives a run; tools are addressed
// by name and role; a device handed in replaces the scene's; a tissue replaced keeps the stack.
#include <palpate/run.h>
#include <palpate/scene.h>
#include <palpate/simulation.h>
#include <palpate/tissue_files.h>

// The viewer's choice of options lives in the app (GUI-free, public headers only): compiled in here.
#include "../apps/palpate/view/view_setup.cpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>

using namespace palpate;
namespace fs = std::filesystem;

namespace {

std::vector<fs::path> shipped_scenes() {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(PALPATE_SOURCE_DIR "/data/scenes"))
    if (e.path().extension() == ".yaml") out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

// Every setting the loop takes from the scene, equal between two builds. The ones a front end
// chooses by what it is are left out: realtime and its priority (a window is always realtime), the
// tick budget (a window runs until it is closed) and the recording (open_loop's).
void expect_same_scene_settings(const LoopSettings& a, const LoopSettings& b, const std::string& what) {
  EXPECT_EQ(a.dt, b.dt) << what;
  EXPECT_EQ(a.spin, b.spin) << what;
  EXPECT_EQ(a.ramp_in, b.ramp_in) << what;
  EXPECT_EQ(a.coupling, b.coupling) << what;
  EXPECT_EQ(a.proxy_mass, b.proxy_mass) << what;
  EXPECT_EQ(a.coupling_stiffness, b.coupling_stiffness) << what;
  EXPECT_EQ(a.watchdog.overrun_margin, b.watchdog.overrun_margin) << what;
  EXPECT_EQ(a.watchdog.stall_timeout, b.watchdog.stall_timeout) << what;
  EXPECT_EQ(a.tool.kind, b.tool.kind) << what;
  EXPECT_EQ(a.tool.radius, b.tool.radius) << what;
  EXPECT_EQ(a.tool.length, b.tool.length) << what;
  EXPECT_EQ(a.tool.axis, b.tool.axis) << what;
  EXPECT_EQ(a.recorder_capacity, b.recorder_capacity) << what;
  ASSERT_EQ(a.outcome.tissues.size(), b.outcome.tissues.size()) << what;
  EXPECT_EQ(a.outcome.skin, b.outcome.skin) << what;
  EXPECT_EQ(a.outcome.pass_distance, b.outcome.pass_distance) << what;
  for (size_t i = 0; i < a.outcome.tissues.size(); ++i) {
    EXPECT_EQ(a.outcome.tissues[i].role, b.outcome.tissues[i].role) << what << " tissue " << i;
    EXPECT_EQ(a.outcome.tissues[i].shape, b.outcome.tissues[i].shape) << what << " tissue " << i;
    EXPECT_EQ(a.outcome.tissues[i].center, b.outcome.tissues[i].center) << what << " tissue " << i;
  }
}

}  // namespace

TEST(Simulation, TheViewerGetsTheLoopSettingsARunGetsForEveryShippedScene) {
  int compared = 0;
  for (const fs::path& file : shipped_scenes()) {
    auto scene = load_scene(file);
    ASSERT_TRUE(scene.ok()) << scene.error().message;
    VirtualDevice mouse, probe_mouse;
    auto run = scene_loop_settings(*scene, run_simulation_options(*scene, RunOptions{}));
    auto view = scene_loop_settings(*scene, view::view_simulation_options(view::ViewerOptions{}, &mouse,
                                                                          scene->probe ? &probe_mouse : nullptr));
    ASSERT_TRUE(run.ok()) << run.error().message;
    ASSERT_TRUE(view.ok()) << view.error().message;
    expect_same_scene_settings(*run, *view, file.filename().string());
    EXPECT_EQ(run->max_ticks, std::uint64_t(std::llround(scene->duration / scene->dt))) << file;
    EXPECT_EQ(view->max_ticks, 0u) << file;  // the window runs until it is closed
    ++compared;
  }
  EXPECT_GE(compared, 10);
}

// What the viewer used to drop: a scene's virtual coupling, proxy mass and watchdog reach its loop.
TEST(Simulation, TheViewerKeepsTheScenesCouplingProxyAndWatchdog) {
  auto scene = load_scene(PALPATE_DATA_DIR "/scenes/default.yaml");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  scene->device.coupling = "virtual";
  scene->device.proxy_mass = 0.004;
  scene->device.stall_timeout = 0.2;
  scene->device.overrun_margin = 0.0008;
  VirtualDevice mouse;
  auto view = scene_loop_settings(*scene, view::view_simulation_options(view::ViewerOptions{}, &mouse, nullptr));
  ASSERT_TRUE(view.ok()) << view.error().message;
  EXPECT_EQ(view->coupling, Coupling::virtual_);
  EXPECT_EQ(view->proxy_mass, 0.004);
  EXPECT_EQ(view->watchdog.stall_timeout, 0.2);
  EXPECT_EQ(view->watchdog.overrun_margin, 0.0008);
  view::ViewerOptions o;
  o.overrun_margin = 0.002;  // `palpate view --overrun-margin` still wins
  EXPECT_EQ(scene_loop_settings(*scene, view::view_simulation_options(o, &mouse, nullptr))->watchdog.overrun_margin, 0.002);
  scene->device.coupling = "springy";
  auto bad = scene_loop_settings(*scene, {});
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("device.coupling 'springy' is not one of direct | virtual"), std::string::npos)
      << bad.error().message;
}

// The CVC scene's tools by name and role; the devices handed in are the ones the loop drives.
TEST(Simulation, ToolsByNameAndRoleWithTheDevicesHandedIn) {
  auto scene = load_scene(PALPATE_DATA_DIR "/scenes/cvc.yaml");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  VirtualDevice mouse, probe_mouse;
  auto sim = Simulation::build(*scene, view::view_simulation_options(view::ViewerOptions{}, &mouse, &probe_mouse));
  ASSERT_TRUE(sim.ok()) << sim.error().message;
  Simulation& s = **sim;
  ASSERT_EQ(s.tools().size(), 2u);
  const SimulationTool* needle = s.tool(ToolRole::needle);
  const SimulationTool* probe = s.tool("probe");
  ASSERT_TRUE(needle && probe);
  EXPECT_EQ(needle->name, "tool");
  EXPECT_EQ(needle->device, &mouse);
  EXPECT_EQ(probe->role, ToolRole::ultrasound_probe);
  EXPECT_EQ(probe->device, &probe_mouse);
  EXPECT_NE(probe->model, nullptr);
  EXPECT_EQ(s.tool(ToolRole::sphere), nullptr);
  EXPECT_EQ(s.tool("grasper"), nullptr);
  EXPECT_EQ(std::string(tool_role_name(probe->role)), "ultrasound_probe");
  EXPECT_EQ(s.tissue_count(), 4u);  // the neck's layers, generated by the build
  EXPECT_EQ(s.scene().tissues.size(), 4u);
  EXPECT_GE(s.tissue_with_role("vein"), 0);
  for (size_t i = 0; i < s.tissue_count(); ++i) EXPECT_NE(s.snapshot(i), nullptr);  // the viewer draws them

  // The loop ticks both tools: the probe pushed into the neck feels the neck, on its own device.
  auto loop = s.open_loop();
  ASSERT_TRUE(loop.ok()) << loop.error().message;
  EXPECT_EQ((*loop)->tool_count(), 2u);
  DeviceState pressed, above;
  pressed.position = Vec3(0, -0.004, 0);  // 4 mm into the neck
  above.position = Vec3(0.02, 0.03, 0.0);
  probe_mouse.set_pose(pressed);
  mouse.set_pose(above);
  // Realtime loops tick on their own thread; run a second headless simulation for a deterministic check.
  SimulationOptions headless;
  headless.devices = {{"tool", &mouse}, {"probe", &probe_mouse}};
  auto h = Simulation::build(*scene, headless);
  ASSERT_TRUE(h.ok()) << h.error().message;
  auto hl = (*h)->open_loop();
  ASSERT_TRUE(hl.ok()) << hl.error().message;
  (*hl)->run_headless(300);  // past the 0.1 s ramp-in
  EXPECT_GT(probe_mouse.force().norm(), 0.1);
  EXPECT_GT((*hl)->tool_sample(probe->loop_index).force.norm(), 0.1);
  EXPECT_EQ(mouse.force().norm(), 0.0);  // the needle is above the skin
}

TEST(Simulation, ADeviceForAToolTheSceneDoesNotHaveIsRefused) {
  auto scene = load_scene(PALPATE_DATA_DIR "/scenes/default.yaml");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  VirtualDevice d;
  SimulationOptions o;
  o.devices = {{"probe", &d}};  // default.yaml has no ultrasound probe
  auto sim = Simulation::build(*scene, o);
  ASSERT_FALSE(sim.ok());
  EXPECT_NE(sim.error().message.find("a device was handed in for tool 'probe', which the scene does not have"),
            std::string::npos)
      << sim.error().message;
  EXPECT_NE(sim.error().message.find("default.yaml"), std::string::npos) << sim.error().message;
}

// Replacing a tissue (the viewer's Apply) keeps the others, relinks the stack and takes the new
// definition: the rebuilt loop steps the new tissue.
TEST(Simulation, ReplacingATissueTakesItsNewDefinition) {
  auto scene = load_scene(PALPATE_DATA_DIR "/scenes/default.yaml");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  SimulationOptions o;
  o.snapshots = true;
  auto sim = Simulation::build(*scene, o);
  ASSERT_TRUE(sim.ok()) << sim.error().message;
  Simulation& s = **sim;
  ASSERT_TRUE(s.open_loop().ok());
  s.loop()->run_headless(2000);
  const double before = s.loop()->stats().max_force;
  EXPECT_GT(before, 0.1);

  TissueDef stiffer = scene->tissues[0];
  stiffer.name = "stiffer";
  SceneDef edited = *scene;
  edited.tissues[0] = stiffer;
  auto t = make_tissue(edited, 0);
  ASSERT_TRUE(t.ok()) << t.error().message;
  ASSERT_TRUE(s.replace_tissue(0, std::move(*t), stiffer).ok());
  EXPECT_EQ(s.loop(), nullptr);  // closed: open it again to go on
  EXPECT_EQ(s.tissue(0).name(), "stiffer");
  EXPECT_EQ(s.scene().tissues[0].name, "stiffer");
  ASSERT_NE(s.snapshot(0), nullptr);
  auto l = s.open_loop();
  ASSERT_TRUE(l.ok()) << l.error().message;
  const auto& cols = (*l)->columns();  // the new tissue's figures are recorded
  EXPECT_TRUE(std::any_of(cols.begin(), cols.end(), [](const std::string& c) { return c.rfind("stiffer.", 0) == 0; }));
  EXPECT_FALSE(s.replace_tissue(7, nullptr, stiffer).ok());
}
