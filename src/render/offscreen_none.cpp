// offscreen_none.cpp — off-screen drawing in a build without OSMesa (PALPATE_WITH_OSMESA=OFF;
// src/CMakeLists.txt): render_rgba checked the scene, and nothing here can draw it.
#include "core/components.h"
#include "render/offscreen.h"

namespace palpate::render {

Result<Image> draw_offscreen(const RenderScene&, std::optional<Eye>) {
  return built_without("render", "OSMesa", "OSMESA", "cannot draw off-screen (frames, images)");
}

}  // namespace palpate::render
