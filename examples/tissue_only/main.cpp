// main.cpp — palpate's tissue layer alone: a charged-particle patch and a mass-spring sheet built
// from Defs in code (no scene file, no mesh file), each pressed by a 3 mm sphere moved by this
// program's own loop at 1 kHz; prints the force each pushes back with. Links palpate::tissue only.
#include <palpate/tissue.h>

#include <algorithm>
#include <cstdio>
#include <memory>

namespace {

palpate::SceneDef scene_with(const palpate::TissueDef& t) {
  palpate::SceneDef scene;
  scene.file = "tissue_only";  // names the scene in messages
  scene.dt = 0.001;
  scene.tissues.push_back(t);
  return scene;
}

// Press the sphere 2 mm into the tissue at 10 mm/s, hold it, and report the force at the end.
int press(const char* label, const palpate::TissueDef& def) {
  const palpate::TissueServices none;  // patches need no files: nothing is handed in
  auto tissue = palpate::make_tissue(scene_with(def), 0, none);
  if (!tissue) {
    std::fprintf(stderr, "%s\n", tissue.error().message.c_str());
    return 1;
  }
  palpate::ToolState tool;
  tool.radius = 0.003;
  palpate::Vec3 force = palpate::Vec3::Zero();
  for (int k = 0; k < 1000; ++k) {
    tool.time = 0.001 * k;
    const double depth = std::min(0.002, 0.01 * tool.time);  // m below the surface
    tool.tip = palpate::Vec3(0, tool.radius - depth, 0);
    force = (*tissue)->step(tool, 0.001);
  }
  std::printf("%s: %.4f N up after pressing 2 mm\n", label, force.y());
  return force.y() > 0 ? 0 : 1;
}

}  // namespace

int main() {
  palpate::TissueDef skin;
  skin.name = "skin";
  skin.model = "charged_particles";
  skin.patch = palpate::PatchDef{};  // 40 x 40 mm, 1 mm spacing, at y = 0, facing up
  palpate::TissueDef sheet;
  sheet.name = "sheet";
  sheet.model = "mass_spring";
  sheet.patch = palpate::PatchDef{.spacing = 0.002};
  sheet.spring.solver = "exact";  // no predictor to keep
  sheet.spring.gravity = false;
  for (int j = 0; j < 21; ++j)  // the sheet's border held (21 x 21 vertices)
    for (int i = 0; i < 21; ++i)
      if (i == 0 || j == 0 || i == 20 || j == 20) sheet.anchors.push_back(i + 21 * j);
  return press("charged patch", skin) | press("mass-spring sheet", sheet);
}
