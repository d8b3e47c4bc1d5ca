// palpate/render.h — off-screen (headless) images: shaded surfaces, particles, lines, the tool and
// the force arrow, drawn by software OpenGL (OSMesa) into memory or a PNG file. Never called from
// the physics: it reads plain arrays that a snapshot filled.
#pragma once

#include <palpate/core.h>
#include <palpate/image.h>
#include <palpate/scene_def.h>

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace palpate {

// A triangle surface, e.g. a SurfaceBuffers' arrays. The spans refer to the caller's memory,
// which must outlive the render call.
struct RenderSurface {
  std::span<const float> positions;     // (#P x 3) m
  std::span<const float> normals;       // (#P x 3) unit; empty: area-weighted from the triangles
  std::span<const uint32_t> triangles;  // (#T x 3) counter-clockwise seen from the front
  Vec3f color = Vec3f(0.86f, 0.47f, 0.45f);  // RGB in [0, 1]; the default is tissue pink
  bool wireframe = false;               // also draw the triangles' edges, darker
  float opacity = 1.0f;                 // in (0, 1]; below 1 the surface is see-through: drawn after
                                        // everything opaque and the tool, back to front, blended
};

// Particles or masses as round dots of a fixed size on screen.
struct RenderPoints {
  std::span<const Vec3f> points;        // m
  Vec3f color = Vec3f(0.15f, 0.35f, 0.9f);
  float size = 4.0f;                    // pixels (of the final image)
};

// Line segments between points: a control grid, springs, neighbour links.
struct RenderLines {
  std::span<const Vec3f> points;                // m
  std::span<const std::array<int, 2>> segments; // indices into points
  Vec3f color = Vec3f(0.2f, 0.2f, 0.25f);
  float width = 1.0f;                           // pixels (of the final image)
};

// The tool: a sphere around `tip`; a needle, a cylinder from tip − length·axis to tip; or a blade,
// a thin flat blade whose cutting edge runs from tip − length·axis to tip, its back `blade_depth`
// behind the edge, with a handle beyond the heel.
struct RenderTool {
  std::string kind = "sphere";          // sphere | needle | blade, as ToolDef::kind
  Vec3 tip = Vec3::Zero();              // m, the HIP
  Vec3 axis = Vec3(0, -1, 0);           // unit, handle to tip (needle, blade)
  double radius = 0.001;                // m, a blade's half thickness
  double length = 0.08;                 // m, needle shaft length, or a blade's edge length
  Vec3f color = Vec3f(0.72f, 0.74f, 0.78f);  // steel
};

// The force on the tool as an arrow from `origin` along `force`, drawn over everything else so
// it is never hidden inside the tissue.
struct RenderArrow {
  Vec3 origin = Vec3::Zero();           // m, usually the tool's tip
  Vec3 force = Vec3::Zero();            // N
  double length_per_newton = 0.01;      // m/N, drawn length = |force| · this
  Vec3f color = Vec3f(1.0f, 0.8f, 0.1f);
};

// --- Stereo: two eyes, off-axis (asymmetric) frusta, never toed-in (docs/viewer.md, "Stereo").
// Each eye sits ±separation/2 along the camera's right axis and looks the same way as the camera;
// its frustum is shifted sideways so that both frusta frame the same rectangle on the plane at the
// convergence distance. Toeing the eyes in instead (both aimed at the convergence point) tilts their
// image planes against each other: a point off the image's centre lands at different heights in the
// two eyes (vertical parallax), which the eyes cannot fuse comfortably.
enum class StereoMode {
  mono,          // one eye, the camera's (no stereo)
  anaglyph,      // one image: the left eye's red channel, the right eye's green and blue (red–cyan glasses)
  side_by_side,  // one image, the left eye on the left half, the right eye on the right half
  top_bottom,    // one image, the left eye on the top half, the right eye on the bottom half
  quad_buffer,   // left and right back buffers of a stereo OpenGL context (a window only, where offered)
};

// The modes a user may name, as the flags and the errors spell them.
inline constexpr const char* kStereoModeNames = "anaglyph, side-by-side, top-bottom or quad-buffer";

// "anaglyph" → StereoMode::anaglyph, ...; anything else is an error naming the text and the modes
// (kStereoModeNames). "mono" is not a user's mode: leaving the flag out is.
Result<StereoMode> parse_stereo_mode(const std::string& text);
const char* stereo_mode_name(StereoMode mode);  // "anaglyph", ...; "mono"

inline constexpr double kDefaultEyeSeparation = 0.063;  // m, an adult's mean interpupillary distance

struct StereoOptions {
  StereoMode mode = StereoMode::mono;
  double eye_separation = kDefaultEyeSeparation;  // m, between the two eyes' centres of projection, ≥ 0
  double convergence = 0;  // m along the view where the eyes' images coincide (zero disparity);
                           // 0: the camera's distance to its target
};

// Fails naming the field on a separation outside [0, 1] m or a convergence negative or not finite.
Status check_stereo(const StereoOptions& stereo);

enum class Eye { left = -1, right = 1 };

// One eye's OpenGL matrices (column-major, as glLoadMatrixd / glUniformMatrix4 want them).
struct EyeMatrices {
  Vec3 position = Vec3::Zero();                          // m, the eye's centre of projection
  Eigen::Matrix4d view = Eigen::Matrix4d::Identity();    // world → eye
  Eigen::Matrix4d projection = Eigen::Matrix4d::Identity();
};

// The off-axis eye of a camera at `position` with the orthonormal frame right, up, forward (unit),
// a vertical field of view `fov` (degrees), `aspect` = width / height of the eye's image, near and
// far planes (m, 0 < near < far): the eye at position + e·separation/2·right (e = −1 left, +1 right),
// the view direction unchanged, and the projection's x shifted by
//   Δx_ndc = −e · (focal / aspect) · separation / (2 · convergence),   focal = 1 / tan(fov / 2),
// which brings a point at depth `convergence` back to where the centre camera draws it. With
// separation 0 it is the plain perspective camera. Pure math; no OpenGL.
EyeMatrices stereo_eye_matrices(const Vec3& position, const Vec3& right, const Vec3& up, const Vec3& forward,
                                double fov, double aspect, double near, double far, double separation,
                                double convergence, Eye eye);

// The convergence distance in use: stereo.convergence, or |camera.target − camera.position| for 0.
double stereo_convergence(const CameraDef& camera, const StereoOptions& stereo);

// The horizontal disparity, in pixels of one eye's image (camera.width × camera.height), of a point
// at depth z (m along the camera's view) between its right and left eye images, x_right − x_left:
//   d = f_px · s · (1/D − 1/z),   f_px = (height / 2) / tan(fov / 2),
// s the eye separation, D the convergence distance. Zero at z = D; positive (uncrossed: behind the
// screen) beyond it, negative (crossed: in front) nearer; tending to f_px · s / D far away. It holds
// for any point at that depth, on the axis or off it, and no point has vertical disparity.
double stereo_disparity_px(const CameraDef& camera, const StereoOptions& stereo, double z);

// Where a point lands in one eye's image (as project_to_pixel does for the camera): pixels from the
// top-left corner of that eye's camera.width × camera.height image; nothing behind the eye.
std::optional<Eigen::Vector2d> project_to_pixel(const CameraDef& camera, const StereoOptions& stereo, Eye eye,
                                                const Vec3& point);

// Everything one image shows. Lit by a light above-left of the camera, fixed to it.
struct RenderScene {
  CameraDef camera;                     // position, target, vertical fov (deg), width, height (px)
  std::vector<RenderSurface> surfaces;
  std::vector<RenderPoints> points;
  std::vector<RenderLines> lines;
  std::optional<RenderTool> tool;
  std::optional<RenderArrow> force;
  Vec3f background = Vec3f(0.12f, 0.13f, 0.16f);
  int supersample = 2;                  // render at k x k the size and average down (anti-aliasing), 1..4
  // Mono draws the camera's image. anaglyph: one camera-sized image; side_by_side: 2·width ×
  // height, each eye at the camera's full size; top_bottom: width × 2·height; quad_buffer is a
  // window's (palpate view) and refused off-screen: an OSMesa context has no stereo buffers.
  StereoOptions stereo;
};


// The largest image side off-screen drawing makes (render_rgba, frames of `palpate run --frames`).
inline constexpr int kMaxOffscreenSide = 4096;  // pixels

// Draw the scene off-screen (no window, no GPU), both eyes of a stereo scene composed into one
// image as scene.stereo.mode says. Fails, naming the element and what was expected, on a bad
// stereo (check_stereo; quad_buffer off-screen), a bad camera (size outside 1..4096 pixels, fov outside (0, 180) degrees, position
// equal to target, non-finite values), a span whose size is not a multiple of 3, normals not
// matching positions, an index out of range, an unknown tool kind; or when OpenGL is unavailable
// (a build without OSMesa, PALPATE_WITH_OSMESA=OFF: the scene is checked, then refused naming it).
Result<Image> render_rgba(const RenderScene& scene);

// render_rgba, then write_png (palpate/image.h).
Status render_png(const RenderScene& scene, const std::filesystem::path& file);


// Where a point lands in the camera's image: x to the right, y down, in pixels from the image's
// top-left corner (a pixel's centre is at +0.5); nothing for a point behind the camera. The same
// projection render_rgba uses.
std::optional<Eigen::Vector2d> project_to_pixel(const CameraDef& camera, const Vec3& point);

// Segments joining each control point of a rows x cols row-major grid to its right and lower
// neighbours: the control net drawn as lines.
std::vector<std::array<int, 2>> grid_lines(int rows, int cols);


// --- Frames of a scene: tissue snapshots drawn as their smooth surfaces, the tool, the force.
struct TissueSnapshot;

struct FrameOptions {
  bool particles = false;   // the particles / masses as points
  bool links = false;       // neighbour links or springs as lines
  int resolution = 6;       // Bézier segments per patch edge (grids) / PN level (meshes)
  bool translucent_cover = true;  // skin and fat (roles skin, fat) see-through, showing the needle
                                  // and the vessels under them, the vessels nearly opaque (the tip
                                  // shows in the lumen); false: every surface opaque
  StereoOptions stereo;           // the frame in stereo (RenderScene::stereo); mono by default
};

// The ultrasound probe in a frame: a box of its footprint (width along the array × thickness)
// standing `height` tall on its face, and the outline of the image plane under it (width × depth).
struct FrameProbe {
  ProbeDef def;                          // footprint, axis, lateral, depth
  Vec3 position = Vec3::Zero();          // m, the centre of its face
  Quat orientation = Quat::Identity();   // unit, its device's (identity: facing def.axis)
  double height = 0.03;                  // m
};

// A second tool drawn as a sphere (the grasper in the other hand: the scene's `grasper`).
struct FrameSphere {
  Vec3 center = Vec3::Zero();  // m
  double radius = 0.003;       // m
  bool closed = false;         // its jaws closed (grasping): drawn darker
};

// Draw one frame: each tissue's surface (a grid snapshot as the seed's Bézier patches, a
// triangle snapshot smoothed with PN triangles) coloured by its role when `tissues` are the
// scene's, in order (scene.tissues[i].role: skin, fat, muscle, vein, artery; other roles get the
// layer palette by position, as before roles existed), the tool at `tip` (a needle along `tool_axis`,
// unit, as it pointed at that tick; none = the scene's tool.axis), the force arrow, from the
// scene's camera (or a camera framing every snapshot when the scene has none), and the probe with
// its image plane when `probe` is given, and `spheres` (the grasper). Allocates: call it off the
// haptic thread, from copied snapshots.
Result<RenderScene> frame_scene(const SceneDef& scene, std::span<const TissueSnapshot> tissues,
                                const Vec3& tip, const Vec3& force, const FrameOptions& options,
                                std::vector<std::vector<float>>& storage,
                                std::vector<std::vector<uint32_t>>& index_storage,
                                const std::optional<Vec3>& tool_axis = std::nullopt,
                                const FrameProbe* probe = nullptr, std::span<const FrameSphere> spheres = {});
// How deep the drawn walls of tissue `tissue`'s wound are (GridDrawing, SurfaceTessellator::cut), m:
// its thickness where the scene lists it as a charged-particle layer, the default layer's where the
// scene does not list it as one. Frames and the viewer both draw a wound this deep.
double wound_wall_depth(const SceneDef& scene, size_t tissue);
Status render_frame_png(const SceneDef& scene, std::span<const TissueSnapshot> tissues,
                        const Vec3& tip, const Vec3& force, const std::filesystem::path& file,
                        const FrameOptions& options = {}, const std::optional<Vec3>& tool_axis = std::nullopt,
                        const FrameProbe* probe = nullptr, std::span<const FrameSphere> spheres = {});

}  // namespace palpate
