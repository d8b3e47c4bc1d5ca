// viewer_impl.h — internal to `palpate view`: the Viewer class and what its files share
// (viewer.cpp: the window, input, the scripted probe and the frame loop; viewer_scene.cpp: what is
// drawn; viewer_panels.cpp: the ImGui panels).
#pragma once

#include "viewer.h"

#include "camera.h"
#include "gl_draw.h"
#include "pose_feeder.h"
#include "screenshot.h"
#include "script_player.h"
#include "tissue_view.h"
#include "tool_tilt.h"
#include "ultrasound_feed.h"
#include "view_setup.h"
#include <palpate/snapshot_tissue.h>

#include <palpate/device.h>
#include <palpate/haptics.h>
#include <palpate/outcome.h>
#include <palpate/render.h>
#include <palpate/report.h>
#include <palpate/simulation.h>
#include <palpate/surface.h>
#include <palpate/tissue.h>
#include <palpate/ultrasound.h>
#include <palpate/tissue_files.h>

#include <epoxy/gl.h>
// GLFW after epoxy: epoxy provides the GL declarations, GLFW must not include its own.
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>

#include <fmt/core.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <deque>
#include <future>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace palpate::view::detail {

using Clock = std::chrono::steady_clock;

inline const Vec3f kBackground(0.12f, 0.13f, 0.16f);
inline const Vec3f kToolColor(0.72f, 0.74f, 0.78f);
inline const Vec3f kArrowColor(1.0f, 0.8f, 0.1f);
inline const Vec3f kBladeEdgeColor(0.35f, 0.95f, 1.0f);  // a blade's cutting edge: bright cyan on the steel
inline const Vec3f kParticleColor(0.15f, 0.35f, 0.9f);
inline const Vec3f kGridColor(0.2f, 0.9f, 0.4f);
inline const Vec3f kLinkColor(0.85f, 0.85f, 0.9f);
inline const Vec3f kProbeColor(0.55f, 0.62f, 0.72f);   // the transducer's grey-blue plastic
inline const Vec3f kPlaneColor(0.3f, 0.95f, 0.85f);    // cyan: the image plane's outline

// --stereo quad-buffer where the display's OpenGL offers no stereo context (a virtual X server, most
// desktop drivers unless stereo is enabled in their settings).
inline constexpr const char* kNoQuadBuffer =
    "--stereo quad-buffer: the display offers no stereo OpenGL context (no framebuffer with left and right "
    "back buffers, GLFW_STEREO); quad-buffered stereo needs a GPU and driver with stereo enabled and a "
    "stereo display; use anaglyph, side-by-side or top-bottom";

// The probe as a box (viewer_scene.cpp).
void append_probe_box(TriangleMesh& mesh, const Vec3& face_centre, const Vec3& beam, const Vec3& lateral,
                      double width, double thickness, double height);

// Tissue colours by position in the scene: skin, fat, vessel wall, organ, ...
inline const Vec3f kTissueColors[] = {{0.86f, 0.56f, 0.50f}, {0.95f, 0.84f, 0.45f}, {0.72f, 0.18f, 0.20f},
                               {0.55f, 0.22f, 0.16f}, {0.60f, 0.45f, 0.70f}, {0.45f, 0.65f, 0.60f}};

class Viewer {
 public:
  Viewer(const SceneDef& scene, const ViewerOptions& options) : scene_(scene), options_(options) {}
  ~Viewer();
  int run();
  void report_exit(int frames);  // the exit report on standard output (with --exit)

 private:
  int build_simulation();  // the mouse's devices, then the scene's Simulation over them
  Status start_loop();
  void stop_loop();
  Vec3 start_position() const;
  bool init_window(std::string& error);
  void frame_input(int width, int height);
  void update_views();
  void draw_scene(int fb_width, int fb_height);
  // The world as the camera (or one stereo eye) sees it, into the current viewport.
  void draw_world(const Eigen::Matrix4f& projection_view, const Vec3& eye);
  // The matrices of one eye of a viewport aspect (width / height): off-axis (render.h, "Stereo").
  EyeMatrices eye_matrices(Eye eye, double aspect) const;
  // A window point (pixels, top-left origin) into the view under it: side by side or top and bottom,
  // the eye's half of the window it lies in (x, y within the half; width, height the half's).
  void pointer_view(double& x, double& y, int& width, int& height) const;
  void draw_panels();
  void finish_rebuild();
  std::optional<double> pick_surface(const Vec3& origin, const Vec3& dir) const;
  bool scripted_probe_step(int width, int height);
  void restart_settle();
  bool take_screenshot(const std::filesystem::path& file, int fb_width, int fb_height);
  void start_probe();          // the probe's device, feeder, force law and ultrasound feed
  // Shift + right drag / wheel, shift + ctrl + left drag; true when the probe took the input.
  bool probe_input(double x, double y, double dx, double dy, int width, int height, double notches,
                   bool right, bool left, bool shift, bool ctrl, bool ui);
  void update_ultrasound();    // the newest image into the panel's texture
  void draw_ultrasound_panel();
  Vec3 probe_beam() const {    // unit, the probe's beam for its current orientation
    return (probe_feeder_->orientation() * scene_.probe->axis).normalized();
  }
  double tool_radius() const { return scene_.tool.radius; }
  // A tool with a direction the mouse presses along and tilts (a needle, a blade): not a sphere.
  bool axial_tool() const { return scene_.tool.kind == "needle" || scene_.tool.kind == "blade"; }
  bool blade() const { return scene_.tool.kind == "blade"; }
  // The needle's (or blade's) direction in the device frame (the scene's tool.axis), unit.
  Vec3 scene_axis() const { return scene_.tool.axis.normalized(); }
  // Which way a press moves the tool: a needle along its own shaft, a blade point first along its
  // edge (as the device has it turned), a sphere along the eye's ray through the cursor.
  Vec3 press_direction(const Vec3& ray) const;
  static constexpr double kTiltRadiansPerPixel = 0.5 * M_PI / 180;

  // A key's action (on_key's, and --keys'): screenshot, untilt, play / pause, step, turn the probe.
  void handle_key(int key);
  // The needle's handle dragged (dx, dy) pixels (ctrl + left drag, --tilt): about the skin hole
  // when the shaft is through the skin (found at the drag's start), about the tip when not.
  void tilt_needle(double dx, double dy);
  std::optional<Vec3> skin_hole() const;  // where the shaft crosses the drawn skin, handle side
  void turn_probe();                      // V: 90° about its beam (in-plane ↔ out-of-plane)
  bool probe_in_plane() const;            // the needle's shaft within 20° of the image plane
  void play_script(double frame_seconds); // the player's clock into the feeders' targets
  Quat probe_turn() const;                // the quarter turn V put on the probe (about its beam)
  void draw_script_panel();
  // The report's attempts: one begins when the loop starts, ends when it stops (a reset, a
  // rebuilt tissue, the exit); each frame adds the forces, the events (the live metrics' changes)
  // and, at the first skin puncture and the flashback, the 3-D view and the ultrasound image.
  void begin_attempt();
  void record_attempt(int fb_width, int fb_height);
  void end_attempt();
  void new_attempt();  // A, "New attempt": the tissues back to rest, a new attempt begun
  bool write_report();

  static void on_scroll(GLFWwindow* window, double dx, double dy);
  static void on_key(GLFWwindow* window, int key, int scancode, int action, int mods);
  static int glfw_key(char c);  // a --keys character's GLFW key; 0 if none

  SceneDef scene_;
  ViewerOptions options_;
  // Destruction order matters: the loop stops first, then the feeders, then the Simulation (its
  // tissues and loop), then the devices it was handed.
  std::unique_ptr<VirtualDevice> device_;
  // A tool the scene puts on a haptic device (openhaptics, forcedimension) is that device's, not the
  // mouse's: the Simulation opens it, and each frame its feeder follows the loop's sample of it.
  bool hardware_tool_ = false, hardware_probe_ = false;
  size_t probe_loop_index_ = 0;  // HapticLoop::tool_sample index of the probe
  void follow_hardware();        // the hardware tools' feeders to their devices' poses (each frame)
  Vec3 probe_force() const;      // N, the force the probe's device was last sent
  Vec3 tool_force() const;       // N, the force the tool's device was last sent
  std::vector<SnapshotTissue*> tissues_;  // the Simulation's, each handing its drawn state over
  std::vector<TissueView> views_;
  std::vector<bool> drawn_;  // per tissue: whether its surface was drawn this frame
  std::unique_ptr<PoseFeeder> feeder_;
  HapticLoop* loop_ = nullptr;  // the Simulation's, while it runs
  std::string loop_error_;

  // The ultrasound probe (scene_.probe), the other hand: its own virtual device (its own safety
  // filter in the loop), walked by its own feeder; the neck's force law; the live image, rendered
  // on UltrasoundFeed's thread from the two feeders' poses and shown in a texture.
  std::unique_ptr<VirtualDevice> probe_device_;
  std::unique_ptr<PoseFeeder> probe_feeder_;
  std::unique_ptr<Simulation> sim_;  // after the devices it drives: destroyed before them
  std::unique_ptr<UltrasoundFeed> us_feed_;
  UltrasoundImage us_image_;
  std::vector<std::uint8_t> us_rgba_;
  unsigned us_texture_ = 0;
  std::uint64_t us_shown_ = 0;  // images uploaded to the texture
  bool moving_probe_ = false;   // shift + right drag: the probe follows the cursor over the skin
  double probe_press_ = 0.0015; // m, the face's depth below the skin under the cursor (wheel)
  bool show_ultrasound_ = true, show_plane_ = true;
  int vein_ = -1;                     // the scene's vein tissue: the image shows its wall tented
  std::vector<Vec3f> vein_rest_;      // its particles at rest

  GLFWwindow* window_ = nullptr;
  bool imgui_ready_ = false;
  std::unique_ptr<GlDraw> gl_;
  OrbitCamera camera_;
  double scene_size_ = 0.1;  // m, the initial eye-to-target distance: scales arrows and steps

  // Display toggles.
  bool show_surface_ = true, show_particles_ = false, show_grid_ = false, show_links_ = false;
  bool show_tool_ = true, show_arrow_ = true;
  float arrow_metres_per_newton_ = 0;  // m per √N: the arrow's length is this · √|F|; from the scene's size

  // Mouse as a haptic device.
  bool pressing_ = false;    // right button held: the tool follows the cursor into the tissue
  double press_distance_ = 0;  // m along the ray from the eye to the surface picked at the press
  double press_depth_ = 0;     // m, the HIP's depth beyond that surface (wheel changes it), along press_direction
  double last_x_ = 0, last_y_ = 0;
  double scroll_ = 0;          // wheel notches since the last frame
  bool screenshot_key_ = false;
  bool tilting_ = false;       // a ctrl + left drag is on: its pivot found at its start
  std::optional<Vec3> tilt_pivot_;  // the skin hole it turns about (none: about the tip)
  double tilt_beyond_ = 0;     // m, the tip's distance past the pivot along the shaft
  enum class TiltStage { none, settle, turn, done } tilt_stage_ = TiltStage::none;  // --tilt
  std::unique_ptr<ScriptPlayer> player_;  // the scene's scripted tools, played in the window
  bool probe_turned_ = false;  // V: the probe a quarter turn about its beam from the script's
  std::string pending_keys_;   // --keys not yet pressed
  // The report: the session's attempts, the one going on, its clock and the metrics last seen.
  std::vector<ReportAttempt> attempts_;
  ReportAttempt attempt_;
  bool attempt_open_ = false;
  Clock::time_point attempt_start_;
  TrainingMetrics seen_;
  std::vector<std::array<double, 2>> attempt_force_, attempt_probe_force_;
  std::filesystem::path report_written_;
  int screenshot_count_ = 0;

  // Scripted probe (--probe).
  enum class ProbeStage { none, pick, approach, press, settle, done } stage_ = ProbeStage::none;
  Vec3 probe_final_ = Vec3::Zero();
  Clock::time_point settle_start_;
  std::uint64_t settle_tick_ = 0;    // the haptic loop's tick when the settle (re)started
  std::uint64_t settle_zeroed_ = 0;  // the safety filter's zeroed ticks then

  // Live force.
  Vec3 force_ = Vec3::Zero();
  std::deque<std::pair<double, float>> force_history_;  // (s since start, |F| N), the last few seconds
  std::deque<std::pair<double, float>> probe_history_;  // the same for the ultrasound probe (a scene with one)
  Clock::time_point start_ = Clock::now();
  double fps_ = 0;

  // Material edits and the tissue rebuilt from them off the GUI thread.
  std::vector<TissueDef> edits_;
  int rebuilding_ = -1;
  std::future<Result<std::unique_ptr<Tissue>>> rebuild_;
  std::string rebuild_message_;
};

}  // namespace palpate::view::detail
