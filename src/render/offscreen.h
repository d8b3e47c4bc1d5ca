// offscreen.h — internal: the off-screen renderer's two sides. offscreen.cpp checks the scene and
// holds the camera's math (shared with project_to_pixel); the drawing is OSMesa's
// (offscreen_osmesa.cpp), or, built without OSMesa (PALPATE_WITH_OSMESA=OFF), a refusal
// (offscreen_none.cpp).
#pragma once

#include <palpate/render.h>

#include <optional>

namespace palpate::render {

inline constexpr double kPi = 3.14159265358979323846;

// The camera's orthonormal frame: right, up, forward (towards the target). y is up in the world;
// looking straight up or down, the image's up is −z (down) or +z (up) instead.
struct CameraFrame {
  Vec3 eye, right, up, forward;
  double focal = 1;   // 1 / tan(fov/2)
  double aspect = 1;  // width / height
};

CameraFrame camera_frame(const CameraDef& c);

// Draws a scene render_rgba checked (check_scene) into an image of the camera's size: from the
// camera, or from one of its stereo eyes (scene.stereo's separation and convergence;
// stereo_eye_matrices).
Result<Image> draw_offscreen(const RenderScene& scene, std::optional<Eye> eye = std::nullopt);

// Two eyes' images of one size as one (anaglyph, side_by_side or top_bottom; RenderScene::stereo).
Image compose_stereo(StereoMode mode, const Image& left, const Image& right);

}  // namespace palpate::render
