// fuzz_scene.cpp — parse_scene on the input as a YAML scene (the loader behind load_scene: YAML,
// the parameter tables of scene_params, every range and cross-key check). Relative paths resolve
// against data/scenes, as for the shipped scenes the seeds come from (the loader only checks that
// the files it names exist; it reads none).
#include <palpate/scene.h>

#include "fuzz_common.h"

#include <cmath>

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, size_t size) {
  using namespace palpate;
  const std::string text(fuzz::bytes(data, size));
  fuzz::no_throw([&] {
    Result<SceneDef> scene = parse_scene(text, "fuzz-scene.yaml", PALPATE_DATA_DIR "/scenes");
    fuzz::check(scene, "fuzz-scene.yaml");
    if (scene && !(std::isfinite(scene->dt) && scene->dt > 0)) std::abort();  // a loaded scene has a tick
  });
  return 0;
}
