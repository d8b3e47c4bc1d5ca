// viewer.cpp — the `palpate view` window: scene drawing from the haptic thread's snapshots, the
// mouse as a virtual haptic device, ImGui panels (display toggles, material edits applied by a
// hand-over, loop timing, live force plot) and screenshots.
#include "viewer.h"

#include "camera.h"
#include "gl_draw.h"
#include "pose_feeder.h"
#include "screenshot.h"
#include "tool_tilt.h"
#include "ultrasound_feed.h"
#include "view_setup.h"
#include <palpate/snapshot_tissue.h>

#include <palpate/device.h>
#include <palpate/haptics.h>
#include <palpate/outcome.h>
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

namespace palpate::view {

namespace {

using Clock = std::chrono::steady_clock;

const Vec3f kBackground(0.12f, 0.13f, 0.16f);
const Vec3f kToolColor(0.72f, 0.74f, 0.78f);
const Vec3f kArrowColor(1.0f, 0.8f, 0.1f);
const Vec3f kParticleColor(0.15f, 0.35f, 0.9f);
const Vec3f kGridColor(0.2f, 0.9f, 0.4f);
const Vec3f kLinkColor(0.85f, 0.85f, 0.9f);
const Vec3f kProbeColor(0.55f, 0.62f, 0.72f);   // the transducer's grey-blue plastic
const Vec3f kPlaneColor(0.3f, 0.95f, 0.85f);    // cyan: the image plane's outline

// The probe as a box: its footprint (width along the array × thickness) standing `height` on its
// face, flat-shaded (four vertices per side).
void append_probe_box(TriangleMesh& mesh, const Vec3& face_centre, const Vec3& beam, const Vec3& lateral,
                      double width, double thickness, double height) {
  const Vec3 elevation = beam.cross(lateral).normalized();
  const Vec3 hx = 0.5 * width * lateral, hz = 0.5 * thickness * elevation, up = -height * beam;
  auto corner = [&](int i) {
    return Vec3(face_centre + ((i & 1) ? hx : -hx) + ((i & 2) ? hz : -hz) + ((i & 4) ? up : Vec3(Vec3::Zero())));
  };
  static const int kFaces[6][4] = {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1},
                                   {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}};
  for (const auto& f : kFaces) {
    const Vec3 a = corner(f[0]), b = corner(f[1]), d = corner(f[2]);
    const Vec3 n = (b - a).cross(d - a).normalized();
    const auto base = static_cast<std::uint32_t>(mesh.positions.size() / 3);
    for (int k = 0; k < 4; ++k) {
      const Vec3 v = corner(f[k]);
      mesh.positions.insert(mesh.positions.end(), {float(v.x()), float(v.y()), float(v.z())});
      mesh.normals.insert(mesh.normals.end(), {float(n.x()), float(n.y()), float(n.z())});
    }
    mesh.triangles.insert(mesh.triangles.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
  }
}
// Tissue colours by position in the scene: skin, fat, vessel wall, organ, ...
const Vec3f kTissueColors[] = {{0.86f, 0.56f, 0.50f}, {0.95f, 0.84f, 0.45f}, {0.72f, 0.18f, 0.20f},
                               {0.55f, 0.22f, 0.16f}, {0.60f, 0.45f, 0.70f}, {0.45f, 0.65f, 0.60f}};

// What is drawn of one tissue, rebuilt from its latest snapshot each frame. The tessellators are
// built when the grid or mesh changes size (rarely), then reused allocation-free.
struct TissueView {
  std::optional<SurfaceTessellator> grid;  // rows_cols snapshots: Bézier patches over the particles
  std::optional<PnTessellator> pn;         // triangle snapshots: PN triangles over the mesh
  size_t mesh_triangles = 0;               // triangle count the PN tessellator was built for
  std::vector<float> positions, normals;   // (#P x 3) the drawn surface, m and unit
  std::vector<Vec3f> vertex_normals;       // (#points) area-weighted, PN input
  std::vector<std::array<int, 2>> grid_links;  // the control net's segments
  int rows = 0, cols = 0;
  std::span<const std::uint32_t> triangles() const {
    if (grid) return grid->triangles();
    if (pn) return pn->triangles();
    return {};
  }
};

// Area-weighted vertex normals of a triangle mesh (a zero normal where no triangle touches).
void vertex_normals(const TissueSnapshot& s, std::vector<Vec3f>& out) {
  out.assign(s.points.size(), Vec3f::Zero());
  const auto n = static_cast<int>(s.points.size());
  for (const auto& t : s.triangles) {
    if (t[0] < 0 || t[1] < 0 || t[2] < 0 || t[0] >= n || t[1] >= n || t[2] >= n) continue;
    const Vec3f& a = s.points[static_cast<size_t>(t[0])];
    const Vec3f face = (s.points[static_cast<size_t>(t[1])] - a).cross(s.points[static_cast<size_t>(t[2])] - a);
    for (int k : t) out[static_cast<size_t>(k)] += face;
  }
}

// Bring `view` up to date with snapshot `s`; false when it has nothing to draw as a surface.
bool update_view(TissueView& view, const TissueSnapshot& s, int resolution) {
  const size_t n = s.points.size();
  if (s.rows_cols.size() == 2 && s.rows_cols[0] >= 2 && s.rows_cols[1] >= 2 &&
      static_cast<size_t>(s.rows_cols[0]) * static_cast<size_t>(s.rows_cols[1]) == n) {
    if (!view.grid || view.rows != s.rows_cols[0] || view.cols != s.rows_cols[1]) {
      SurfaceDef def;
      def.scheme = SurfaceScheme::bezier;
      def.resolution = resolution;
      auto built = SurfaceTessellator::build(s.rows_cols[0], s.rows_cols[1], def);
      if (!built) return false;
      view.grid.emplace(std::move(*built));
      view.pn.reset();
      view.rows = s.rows_cols[0];
      view.cols = s.rows_cols[1];
      view.grid_links.clear();
      for (int r = 0; r < view.rows; ++r)
        for (int c = 0; c < view.cols; ++c) {
          const int i = r * view.cols + c;
          if (c + 1 < view.cols) view.grid_links.push_back({i, i + 1});
          if (r + 1 < view.rows) view.grid_links.push_back({i, i + view.cols});
        }
      view.positions.resize(view.grid->point_count() * 3);
      view.normals.resize(view.grid->point_count() * 3);
    }
    return view.grid->tessellate(s.points, view.positions, view.normals);
  }
  view.grid.reset();
  view.rows = view.cols = 0;
  view.grid_links.clear();
  if (s.triangles.empty()) {
    view.pn.reset();
    return false;
  }
  if (!view.pn || view.pn->vertex_count() != static_cast<int>(n) || view.mesh_triangles != s.triangles.size()) {
    auto built = PnTessellator::build(static_cast<int>(n), s.triangles, 3);
    if (!built) {
      view.pn.reset();
      return false;
    }
    view.pn.emplace(std::move(*built));
    view.mesh_triangles = s.triangles.size();
    view.positions.resize(view.pn->point_count() * 3);
    view.normals.resize(view.pn->point_count() * 3);
  }
  vertex_normals(s, view.vertex_normals);
  return view.pn->tessellate(s.points, view.vertex_normals, view.positions, view.normals);
}

// The edit panel's fields for one material struct, from its parameter table.
template <class Def>
bool edit_params(Def& def) {
  bool changed = false;
  for (const Param<Def>& p : param_table(static_cast<const Def*>(nullptr))) {
    ImGui::PushID(p.key);
    if (auto* d = std::get_if<double Def::*>(&p.field)) {
      double& v = def.*(*d);
      if (ImGui::InputDouble(p.key, &v, 0, 0, "%.6g")) {
        v = std::clamp(v, p.min, p.max);
        changed = true;
      }
    } else if (auto* i = std::get_if<int Def::*>(&p.field)) {
      int& v = def.*(*i);
      if (ImGui::InputInt(p.key, &v)) {
        v = static_cast<int>(std::clamp(static_cast<double>(v), p.min, p.max));
        changed = true;
      }
    } else if (auto* b = std::get_if<bool Def::*>(&p.field)) {
      changed |= ImGui::Checkbox(p.key, &(def.*(*b)));
    } else if (auto* s = std::get_if<std::string Def::*>(&p.field)) {
      std::string& v = def.*(*s);
      const std::string choices = p.choices;
      if (!choices.empty() && ImGui::BeginCombo(p.key, v.c_str())) {
        size_t start = 0;
        while (start <= choices.size()) {
          const size_t bar = std::min(choices.find('|', start), choices.size());
          const std::string choice = choices.substr(start, bar - start);
          if (ImGui::Selectable(choice.c_str(), choice == v)) {
            v = choice;
            changed = true;
          }
          start = bar + 1;
        }
        ImGui::EndCombo();
      }
    }
    if (ImGui::IsItemHovered() && (*p.doc || *p.unit))
      ImGui::SetTooltip("%s%s%s%s", p.doc, *p.unit ? " (" : "", p.unit, *p.unit ? ")" : "");
    ImGui::PopID();
  }
  return changed;
}

class Viewer {
 public:
  Viewer(const SceneDef& scene, const ViewerOptions& options) : scene_(scene), options_(options) {}
  ~Viewer();
  int run();

 private:
  int build_simulation();  // the mouse's devices, then the scene's Simulation over them
  Status start_loop();
  void stop_loop();
  Vec3 start_position() const;
  bool init_window(std::string& error);
  void frame_input(int width, int height);
  void update_views();
  void draw_scene(int fb_width, int fb_height);
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
  // The needle's direction in the device frame (the scene's tool.axis), unit.
  Vec3 scene_axis() const { return scene_.tool.axis.normalized(); }
  static constexpr double kTiltRadiansPerPixel = 0.5 * M_PI / 180;

  static void on_scroll(GLFWwindow* window, double dx, double dy);
  static void on_key(GLFWwindow* window, int key, int scancode, int action, int mods);

  SceneDef scene_;
  ViewerOptions options_;
  // Destruction order matters: the loop stops first, then the feeders, then the Simulation (its
  // tissues and loop), then the devices it was handed.
  std::unique_ptr<VirtualDevice> device_;
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
  double press_depth_ = 0;     // m, the HIP's depth beyond that surface (wheel changes it)
  double last_x_ = 0, last_y_ = 0;
  double scroll_ = 0;          // wheel notches since the last frame
  bool screenshot_key_ = false;
  bool untilt_key_ = false;    // R: the needle back to the scene's tool.axis
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
  Clock::time_point start_ = Clock::now();
  double fps_ = 0;

  // Material edits and the tissue rebuilt from them off the GUI thread.
  std::vector<TissueDef> edits_;
  int rebuilding_ = -1;
  std::future<Result<std::unique_ptr<Tissue>>> rebuild_;
  std::string rebuild_message_;
};

Viewer::~Viewer() {
  stop_loop();
  us_feed_.reset();  // its thread reads the feeders
  probe_feeder_.reset();
  feeder_.reset();
  if (us_texture_ && window_) glDeleteTextures(1, &us_texture_);
  if (imgui_ready_) {
    ImGui_ImplOpenGL3_Shutdown();
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
  }
  gl_.reset();  // needs the context: before the window goes
  if (window_) glfwDestroyWindow(window_);
  glfwTerminate();
  if (rebuild_.valid()) rebuild_.wait();
}

int Viewer::build_simulation() {
  if (scene_.tissues.empty() && !scene_.anatomy) {
    fmt::print(stderr, "palpate view: {}: the scene has no tissues to show\n", scene_.file.string());
    return 2;
  }
  device_ = std::make_unique<VirtualDevice>(device_limits(scene_.device));
  if (scene_.probe && scene_.anatomy) probe_device_ = std::make_unique<VirtualDevice>(device_limits(scene_.probe->device));
  auto sim = Simulation::build(scene_, view_simulation_options(options_, device_.get(), probe_device_.get()));
  if (!sim) {
    fmt::print(stderr, "palpate view: {}\n", sim.error().message);
    return 2;
  }
  sim_ = std::move(*sim);
  scene_ = sim_->scene();  // with the anatomy's layers generated: the panels edit every tissue
  for (size_t i = 0; i < sim_->tissue_count(); ++i) tissues_.push_back(sim_->snapshot(i));
  views_.resize(tissues_.size());
  drawn_.assign(tissues_.size(), false);
  edits_ = scene_.tissues;
  return 0;
}

Status Viewer::start_loop() {
  auto loop = sim_->open_loop();
  if (!loop) return loop.error();
  if (Status started = (*loop)->start(); !started) return started;
  loop_ = *loop;
  return {};
}

void Viewer::stop_loop() {
  if (loop_) loop_->stop();
  loop_ = nullptr;
}

Vec3 Viewer::start_position() const {
  if (!scene_.device.waypoints.empty()) return scene_.device.waypoints.front().position;
  const Vec3 target = scene_.camera ? scene_.camera->target : Vec3::Zero();
  return target + Vec3(0, 0.3 * scene_size_, 0);
}

bool Viewer::init_window(std::string& error) {
  glfwSetErrorCallback([](int code, const char* text) { fmt::print(stderr, "palpate view: GLFW error {}: {}\n", code, text); });
  if (!glfwInit()) {
    error = "cannot start GLFW (no display? set DISPLAY, or run under xvfb-run)";
    return false;
  }
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_DEPTH_BITS, 24);
  const CameraDef cam = scene_.camera.value_or(CameraDef{});
  const int width = options_.width > 0 ? options_.width : cam.width;
  const int height = options_.height > 0 ? options_.height : cam.height;
  const std::string title = "palpate — " + scene_.name;
  window_ = glfwCreateWindow(width, height, title.c_str(), nullptr, nullptr);
  if (!window_) {
    error = "cannot open a " + std::to_string(width) + "x" + std::to_string(height) +
            " window with OpenGL 3.3 core (no display, or a driver without 3.3; under xvfb-run set "
            "LIBGL_ALWAYS_SOFTWARE=1)";
    return false;
  }
  glfwMakeContextCurrent(window_);
  glfwSwapInterval(options_.exit_after ? 0 : 1);
  glfwSetWindowUserPointer(window_, this);
  // Ours first: ImGui's backend chains to callbacks installed before it.
  glfwSetScrollCallback(window_, on_scroll);
  glfwSetKeyCallback(window_, on_key);
  gl_ = std::make_unique<GlDraw>();
  if (!gl_->init(error)) return false;
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini left in the working directory
  ImGui::StyleColorsDark();
  ImGui_ImplGlfw_InitForOpenGL(window_, true);
  ImGui_ImplOpenGL3_Init("#version 330 core");
  imgui_ready_ = true;
  return true;
}

void Viewer::on_scroll(GLFWwindow* window, double, double dy) {
  auto* v = static_cast<Viewer*>(glfwGetWindowUserPointer(window));
  if (v && !(v->imgui_ready_ && ImGui::GetIO().WantCaptureMouse)) v->scroll_ += dy;
}

void Viewer::on_key(GLFWwindow* window, int key, int, int action, int) {
  auto* v = static_cast<Viewer*>(glfwGetWindowUserPointer(window));
  if (!v || action != GLFW_PRESS || (v->imgui_ready_ && ImGui::GetIO().WantCaptureKeyboard)) return;
  if (key == GLFW_KEY_F12 || key == GLFW_KEY_S) v->screenshot_key_ = true;
  if (key == GLFW_KEY_R) v->untilt_key_ = true;
  if (key == GLFW_KEY_ESCAPE) glfwSetWindowShouldClose(window, GLFW_TRUE);
}

std::optional<double> Viewer::pick_surface(const Vec3& origin, const Vec3& dir) const {
  std::optional<double> best;
  for (size_t i = 0; i < views_.size(); ++i) {
    if (!drawn_[i]) continue;
    const auto t = pick(origin, dir, views_[i].positions, views_[i].triangles());
    if (t && (!best || *t < *best)) best = t;
  }
  return best;
}

void Viewer::frame_input(int width, int height) {
  double x = 0, y = 0;
  glfwGetCursorPos(window_, &x, &y);
  const double dx = x - last_x_, dy = y - last_y_;
  last_x_ = x;
  last_y_ = y;
  const double notches = scroll_;
  scroll_ = 0;
  if (options_.exit_after) return;  // a scripted run ignores whatever the pointer does
  const bool ui = imgui_ready_ && ImGui::GetIO().WantCaptureMouse;
  const bool left = glfwGetMouseButton(window_, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS;
  const bool middle = glfwGetMouseButton(window_, GLFW_MOUSE_BUTTON_MIDDLE) == GLFW_PRESS;
  const bool right = glfwGetMouseButton(window_, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS;
  const bool shift = glfwGetKey(window_, GLFW_KEY_LEFT_SHIFT) == GLFW_PRESS ||
                     glfwGetKey(window_, GLFW_KEY_RIGHT_SHIFT) == GLFW_PRESS;
  const bool ctrl = glfwGetKey(window_, GLFW_KEY_LEFT_CONTROL) == GLFW_PRESS ||
                    glfwGetKey(window_, GLFW_KEY_RIGHT_CONTROL) == GLFW_PRESS;
  if (untilt_key_) {
    untilt_key_ = false;
    feeder_->set_orientation_target(Quat::Identity());
  }
  if (probe_feeder_ && probe_input(x, y, dx, dy, width, height, notches, right, left, shift, ctrl, ui)) return;
  if (!ui) {
    if (left && ctrl) {
      // Tilt the needle about its tip: its handle follows the pointer, 0.5 degree per pixel. The
      // device (and so the loop's tool.axis) turns towards it at the feeder's bounded rate.
      const Quat target = feeder_->orientation_target();
      const Vec3 handle = -needle_axis(scene_axis(), target);
      feeder_->set_orientation_target(
          tilt_by_drag(target, handle, dx, dy, camera_.right(), camera_.up(), kTiltRadiansPerPixel));
    } else if ((left && shift) || middle) {
      camera_.pan(dx, dy, height);
    } else if (left) {
      camera_.orbit(dx, dy);
    }
  }
  const Vec3 eye = camera_.eye();
  const Vec3 dir = camera_.ray_direction(x, y, width, height);
  if (right && !pressing_ && !ui) {
    // Press: touch the surface under the cursor (or, off the tissue, the plane through the
    // camera's target facing it), starting 1 mm past touching.
    pressing_ = true;
    const auto hit = pick_surface(eye, dir);
    press_distance_ = hit ? *hit : (camera_.target - eye).dot(camera_.forward()) / dir.dot(camera_.forward());
    press_depth_ = -tool_radius() + 0.001;
  } else if (!right && pressing_) {
    // Release: back out along the ray to just above the surface.
    pressing_ = false;
    feeder_->set_target(eye + dir * (press_distance_ - tool_radius() - 0.003));
    return;
  }
  if (pressing_) {
    press_depth_ += notches * 0.0005;  // 0.5 mm per wheel notch, forward = deeper
    feeder_->set_target(eye + dir * (press_distance_ + press_depth_));
  } else if (!ui && notches != 0) {
    camera_.zoom(notches);
  }
}

void Viewer::restart_settle() {
  settle_start_ = Clock::now();
  const LoopStats st = loop_ ? loop_->stats() : LoopStats{};
  settle_tick_ = st.ticks;
  settle_zeroed_ = st.safety.zeroed();
}

bool Viewer::scripted_probe_step(int width, int height) {
  switch (stage_) {
    case ProbeStage::pick: {
      const ProbeRequest& p = *options_.probe;
      const Vec3 eye = camera_.eye();
      const Vec3 dir = camera_.ray_direction(p.x, p.y, width, height);
      const auto hit = pick_surface(eye, dir);
      if (!hit) {
        fmt::print(stderr, "palpate view: --probe {},{}: no tissue surface under that pixel of the {}x{} window\n",
                   p.x, p.y, width, height);
        return false;
      }
      probe_final_ = eye + dir * (*hit + p.depth);
      feeder_->set_target(eye + dir * (*hit - tool_radius() - 0.003));
      stage_ = ProbeStage::approach;
      break;
    }
    case ProbeStage::approach:
      if (feeder_->arrived()) {
        feeder_->set_target(probe_final_);
        stage_ = ProbeStage::press;
      }
      break;
    case ProbeStage::press:
      if (feeder_->arrived()) {
        restart_settle();
        stage_ = ProbeStage::settle;
      }
      break;
    case ProbeStage::settle: {
      // Held still for `settle` seconds of wall time and of simulated time (a loop that cannot keep
      // up, as under a sanitizer, runs fewer ticks than the clock says), with no tick zeroed by the
      // safety filter meanwhile: a zeroed tick restarts the force's ramp, and the exit screenshot
      // and force would show that ramp instead of the pressed tissue's force. One restarts the wait.
      const LoopStats st = loop_ ? loop_->stats() : LoopStats{};
      if (st.safety.zeroed() != settle_zeroed_) {
        restart_settle();
        break;
      }
      const double wall = std::chrono::duration<double>(Clock::now() - settle_start_).count();
      const double simulated = loop_ ? double(st.ticks - settle_tick_) * scene_.dt : wall;
      if (wall >= options_.settle && simulated >= options_.settle) stage_ = ProbeStage::done;
      break;
    }
    case ProbeStage::none:
    case ProbeStage::done:
      break;
  }
  return true;
}

bool Viewer::probe_input(double x, double y, double dx, double dy, int width, int height, double notches,
                         bool right, bool left, bool shift, bool ctrl, bool ui) {
  if (left && shift && ctrl && !ui) {
    // Tilt the probe about its face: its top follows the pointer, as the needle's handle does.
    const Quat target = probe_feeder_->orientation_target();
    const Vec3 top = -(target * scene_.probe->axis).normalized();
    probe_feeder_->set_orientation_target(
        tilt_by_drag(target, top, dx, dy, camera_.right(), camera_.up(), kTiltRadiansPerPixel));
    return true;
  }
  if (right && shift && !pressing_ && !moving_probe_ && !ui) moving_probe_ = true;
  if (!moving_probe_) return false;
  if (!right) {
    moving_probe_ = false;  // let go: the probe stays where it is, resting on the skin
    return true;
  }
  // The face's centre on the skin under the cursor, `probe_press_` in along the beam; wheel:
  // 0.5 mm per notch, forward = firmer.
  probe_press_ = std::clamp(probe_press_ + notches * 0.0005, 0.0, 0.02);
  const Vec3 eye = camera_.eye();
  const Vec3 dir = camera_.ray_direction(x, y, width, height);
  if (const auto hit = pick_surface(eye, dir)) probe_feeder_->set_target(eye + dir * *hit + probe_press_ * probe_beam());
  return true;
}

void Viewer::start_probe() {
  const ProbeDef& p = *scene_.probe;
  // It starts where its scripted device would (its first waypoint), or on the skin at the origin.
  Vec3 start = Vec3::Zero();
  Quat facing = Quat::Identity();
  if (!p.device.waypoints.empty()) {
    const Waypoint& w = p.device.waypoints.front();
    start = w.position;
    if (w.direction.allFinite() && w.direction.norm() > 0) facing = orientation_towards(p.axis, w.direction);
  }
  probe_feeder_ = std::make_unique<PoseFeeder>(*probe_device_, start, options_.tool_speed);
  probe_feeder_->set_orientation_target(facing);
  probe_press_ = std::max(0.0, -start.y());
  for (size_t i = 0; i < scene_.tissues.size() && i < tissues_.size() && vein_ < 0; ++i)
    if (scene_.tissues[i].role == "vein") vein_ = int(i);
  if (vein_ >= 0) vein_rest_ = tissues_[size_t(vein_)]->current().points;  // built, not yet stepped
  const bool needle = scene_.tool.kind == "needle";
  const Vec3 axis = scene_axis();
  const double radius = scene_.tool.radius, length = scene_.tool.length;
  PoseFeeder* hand = feeder_.get();
  PoseFeeder* probe = probe_feeder_.get();
  us_feed_ = std::make_unique<UltrasoundFeed>(
      *scene_.anatomy, p,
      [=](ProbePose& pp, NeedlePose& np) {
        pp.position = probe->position();
        pp.orientation = probe->orientation();
        np.present = needle;
        np.tip = hand->position();
        np.axis = needle_axis(axis, hand->orientation());
        np.radius = radius;
        np.length = length;
      },
      25.0);
}

void Viewer::update_ultrasound() {
  if (!us_feed_) return;
  // The vein's wall as update_views() just took it from the haptic thread.
  if (vein_ >= 0 && size_t(vein_) < tissues_.size()) {
    const std::vector<Vec3f>& now = tissues_[size_t(vein_)]->current().points;
    if (now.size() == vein_rest_.size()) us_feed_->set_vein_wall(vein_rest_, now);
  }
  if (!us_feed_->take(us_image_) || us_image_.width <= 0) return;
  const size_t n = size_t(us_image_.width) * size_t(us_image_.height);
  us_rgba_.resize(n * 4);
  for (size_t i = 0; i < n; ++i) {
    const std::uint8_t g = us_image_.grey[i];
    us_rgba_[i * 4] = us_rgba_[i * 4 + 1] = us_rgba_[i * 4 + 2] = g;
    us_rgba_[i * 4 + 3] = 255;
  }
  if (!us_texture_) {
    glGenTextures(1, &us_texture_);
    glBindTexture(GL_TEXTURE_2D, us_texture_);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  }
  glBindTexture(GL_TEXTURE_2D, us_texture_);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, us_image_.width, us_image_.height, 0, GL_RGBA, GL_UNSIGNED_BYTE,
               us_rgba_.data());
  glBindTexture(GL_TEXTURE_2D, 0);
  ++us_shown_;
}

void Viewer::draw_ultrasound_panel() {
  if (!probe_feeder_) return;
  const ImVec2 display = ImGui::GetIO().DisplaySize;
  const float side = std::clamp(0.4f * display.y, 160.0f, 512.0f);
  ImGui::SetNextWindowPos(ImVec2(display.x - side - 24, 8), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(side + 16, 0), ImGuiCond_FirstUseEver);
  ImGui::Begin("Ultrasound");
  ImGui::Checkbox("image", &show_ultrasound_);
  ImGui::SameLine();
  ImGui::Checkbox("plane in 3-D", &show_plane_);
  if (show_ultrasound_ && us_texture_) {
    const float w = ImGui::GetContentRegionAvail().x;
    const float h = us_image_.width > 0 ? w * float(us_image_.height * us_image_.pixel_depth) /
                                              float(us_image_.width * us_image_.pixel_width)
                                        : w;
    ImGui::Image(reinterpret_cast<ImTextureID>(static_cast<std::intptr_t>(us_texture_)), ImVec2(w, h));
  }
  const Vec3 p = probe_feeder_->position();
  ImGui::Text("probe %.1f, %.1f, %.1f mm  |F| %.2f N", 1e3 * p.x(), 1e3 * p.y(), 1e3 * p.z(),
              probe_device_->force().norm());
  if (us_feed_)
    ImGui::Text("%s  %.1f ms per image", us_image_.in_contact ? "on the skin" : "not touching",
                1e3 * us_feed_->last_render_seconds());
  ImGui::TextDisabled("shift + right drag: move the probe, wheel: press");
  ImGui::TextDisabled("shift + ctrl + left drag: tilt it");
  ImGui::End();
}

void Viewer::update_views() {
  for (size_t i = 0; i < tissues_.size(); ++i) {
    const TissueSnapshot& s = tissues_[i]->latest();
    drawn_[i] = update_view(views_[i], s, options_.resolution);
    tissues_[i]->request();  // the next step copies a fresh one for the next frame
  }
}

void Viewer::draw_scene(int fb_width, int fb_height) {
  gl_->clear(kBackground, fb_width, fb_height);
  const double aspect = fb_height > 0 ? static_cast<double>(fb_width) / fb_height : 1.0;
  gl_->set_camera(camera_.projection_matrix(aspect) * camera_.view_matrix(), camera_.eye());
  for (size_t i = 0; i < tissues_.size(); ++i) {
    const TissueSnapshot& s = tissues_[i]->current();  // the one update_views() tessellated
    const TissueView& v = views_[i];
    const Vec3f color = kTissueColors[i % std::size(kTissueColors)];
    const bool surface = show_surface_ && drawn_[i];
    if (surface) gl_->triangles(v.positions, v.normals, v.triangles(), color);
    if (show_grid_ && !v.grid_links.empty()) gl_->lines(s.points, v.grid_links, kGridColor);
    if (show_links_ || (!drawn_[i] && !s.links.empty())) gl_->lines(s.points, s.links, kLinkColor);
    // Particles are drawn when asked, or when nothing else shows the tissue.
    if (show_particles_ || (!drawn_[i] && s.links.empty())) gl_->points(s.points, kParticleColor, 4.0f);
  }
  const Vec3 tip = feeder_->position();
  TriangleMesh mesh;
  if (show_tool_) {
    if (scene_.tool.kind == "needle") {
      const Vec3 axis = needle_axis(scene_axis(), feeder_->orientation());
      append_cylinder(mesh, tip - scene_.tool.length * axis, tip, scene_.tool.radius, scene_.tool.radius);
      append_sphere(mesh, tip, scene_.tool.radius, 10, 6);
    } else {
      append_sphere(mesh, tip, scene_.tool.radius);
    }
    gl_->triangles(mesh, kToolColor);
  }
  if (probe_feeder_) {
    const ProbeDef& p = *scene_.probe;
    const Quat q = probe_feeder_->orientation();
    const Vec3 c = probe_feeder_->position(), beam = probe_beam(), lateral = (q * p.lateral).normalized();
    mesh.clear();
    append_probe_box(mesh, c, beam, lateral, p.width, p.thickness, 0.03);
    gl_->triangles(mesh, kProbeColor);
    if (show_plane_) {
      const double w = 0.5 * p.width;
      const Vec3 corners[4] = {c - w * lateral, c + w * lateral, c + w * lateral + p.depth * beam,
                               c - w * lateral + p.depth * beam};
      Vec3f pts[4];
      for (int k = 0; k < 4; ++k) pts[k] = corners[k].cast<float>();
      static const std::array<int, 2> kOutline[4] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}};
      gl_->lines(pts, kOutline, kPlaneColor);
    }
  }
  if (show_arrow_ && force_.norm() > 1e-4) {
    mesh.clear();
    // Length ∝ √|F|, so 0.05 N still shows and the device's 3.3 N stays on screen.
    const double length = arrow_metres_per_newton_ * std::sqrt(force_.norm());
    append_arrow(mesh, tip, force_.normalized() * length, 0.004 * scene_size_);
    gl_->triangles(mesh, kArrowColor, /*on_top=*/true);
  }
}

void Viewer::finish_rebuild() {
  if (rebuilding_ < 0 || !rebuild_.valid() ||
      rebuild_.wait_for(std::chrono::seconds(0)) != std::future_status::ready)
    return;
  const int i = rebuilding_;
  rebuilding_ = -1;
  auto built = rebuild_.get();
  if (!built) {
    rebuild_message_ = built.error().message;
    return;
  }
  // The hand-over: the haptic thread is stopped (joined) before the old tissue goes, so it never
  // steps a tissue being replaced; forces ramp in again from zero when the loop restarts.
  stop_loop();
  // The layers below held the old one: the Simulation relinks them to press from the new one.
  if (Status replaced = sim_->replace_tissue(static_cast<size_t>(i), std::move(*built), edits_[static_cast<size_t>(i)]); !replaced) {
    rebuild_message_ = replaced.error().message;
    return;
  }
  tissues_[static_cast<size_t>(i)] = sim_->snapshot(static_cast<size_t>(i));
  views_[static_cast<size_t>(i)] = TissueView{};
  scene_.tissues[static_cast<size_t>(i)] = edits_[static_cast<size_t>(i)];
  Status started = start_loop();
  rebuild_message_ = started ? "applied to " + scene_.tissues[static_cast<size_t>(i)].name
                             : "haptic loop did not restart: " + started.error().message;
  if (!started) loop_error_ = started.error().message;
}

void Viewer::draw_panels() {
  ImGui::SetNextWindowPos(ImVec2(8, 8), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(340, 0), ImGuiCond_FirstUseEver);
  ImGui::Begin("palpate");
  ImGui::Text("%s  %.0f fps", scene_.name.c_str(), fps_);
  if (ImGui::CollapsingHeader("View", ImGuiTreeNodeFlags_DefaultOpen)) {
    ImGui::Checkbox("surface", &show_surface_);
    ImGui::SameLine();
    ImGui::Checkbox("particles", &show_particles_);
    ImGui::SameLine();
    ImGui::Checkbox("control grid", &show_grid_);
    ImGui::Checkbox("springs/links", &show_links_);
    ImGui::SameLine();
    ImGui::Checkbox("tool", &show_tool_);
    ImGui::SameLine();
    ImGui::Checkbox("force arrow", &show_arrow_);
    ImGui::TextDisabled("left drag: orbit  shift/middle: pan  wheel: zoom");
    ImGui::TextDisabled("right drag: press the tool in, wheel: depth");
    if (scene_.tool.kind == "needle") ImGui::TextDisabled("ctrl + left drag: tilt the needle  R: untilt");
    ImGui::TextDisabled("F12 or S: screenshot  Esc: quit");
  }
  if (ImGui::CollapsingHeader("Force", ImGuiTreeNodeFlags_DefaultOpen)) {
    const Vec3 tip = feeder_->position();
    ImGui::Text("|F| %.3f N  (%.3f, %.3f, %.3f)", force_.norm(), force_.x(), force_.y(), force_.z());
    ImGui::Text("tool %.1f, %.1f, %.1f mm", 1e3 * tip.x(), 1e3 * tip.y(), 1e3 * tip.z());
    if (pressing_) ImGui::Text("depth past the surface %.1f mm", 1e3 * press_depth_);
    if (scene_.tool.kind == "needle") {
      const Vec3 a = needle_axis(scene_axis(), feeder_->orientation());
      ImGui::Text("needle (%.2f, %.2f, %.2f), %.1f deg from tool.axis", a.x(), a.y(), a.z(),
                  std::acos(std::clamp(a.dot(scene_axis()), -1.0, 1.0)) * 180 / M_PI);
    }
    // |F| over the last 5 s, resampled to fixed bins (frames are not evenly spaced).
    constexpr int kBins = 150;
    constexpr double kSpan = 5.0;
    float bins[kBins] = {};
    const double now = std::chrono::duration<double>(Clock::now() - start_).count();
    size_t k = 0;
    float last = 0;
    for (int b = 0; b < kBins; ++b) {
      const double t = now - kSpan + kSpan * (b + 1) / kBins;
      while (k < force_history_.size() && force_history_[k].first <= t) last = force_history_[k++].second;
      bins[b] = last;
    }
    const float top = std::max(0.5f, *std::max_element(bins, bins + kBins) * 1.1f);
    ImGui::PlotLines("##force", bins, kBins, 0, "|F| (N), last 5 s", 0.0f, top, ImVec2(-1, 80));
  }
  if (scene_.tool.kind == "needle" && ImGui::CollapsingHeader("Outcome", ImGuiTreeNodeFlags_DefaultOpen)) {
    // Live from the haptic loop's relaxed counters (docs/cvc.md, "Outcome and metrics"); a tissue
    // rebuilt from the edit panel restarts the loop and these with it.
    if (loop_) {
      const TrainingMetrics m = loop_->stats().metrics;
      ImGui::Text("outcome %s", outcome_name(m.outcome));
      ImGui::Text("skin punctures %d  passes %d  redirections %d", m.skin_punctures, m.passes, m.redirections);
      if (m.flashback)
        ImGui::Text("flashback %.2f s after the skin puncture", m.time_to_flashback);
      else
        ImGui::TextDisabled("no flashback yet");
      ImGui::Text("deepest %.1f mm below the skin  peak |F| %.2f N", 1e3 * m.deepest_depth, m.peak_force);
    }
  }
  if (ImGui::CollapsingHeader("Haptic loop", ImGuiTreeNodeFlags_DefaultOpen)) {
    if (loop_) {
      const LoopStats st = loop_->stats();
      ImGui::Text("ticks %llu  %s", static_cast<unsigned long long>(st.ticks),
                  st.realtime_priority ? "SCHED_FIFO" : "normal priority");
      ImGui::Text("period  med %.0f  p99 %.0f  max %.0f us", 1e6 * st.period.median, 1e6 * st.period.p99, 1e6 * st.period.max);
      ImGui::Text("step    med %.1f  p99 %.1f  max %.1f us", 1e6 * st.step.median, 1e6 * st.step.p99, 1e6 * st.step.max);
      // Where the millisecond goes: each stage of the tick (TickStage), median and p99.
      for (size_t i = 0; i < kTickStageCount; ++i)
        ImGui::Text("  %-16s med %6.1f  p99 %6.1f us", tick_stage_name(TickStage(i)), 1e6 * st.stages[i].median,
                    1e6 * st.stages[i].p99);
      ImGui::Text("deadline misses %llu  resyncs %llu", static_cast<unsigned long long>(st.deadline_misses),
                  static_cast<unsigned long long>(st.resyncs));
      ImGui::Text("zeroed: overrun %llu  stalled %llu  failed %llu",
                  static_cast<unsigned long long>(st.safety.overrun), static_cast<unsigned long long>(st.safety.stalled),
                  static_cast<unsigned long long>(st.safety.step_failed + st.safety.device_failed + st.safety.non_finite));
      ImGui::Text("clamped %llu  rate-limited %llu  max |F| %.2f N", static_cast<unsigned long long>(st.safety.clamped),
                  static_cast<unsigned long long>(st.safety.rate_limited), st.max_force);
    } else {
      ImGui::TextColored(ImVec4(1, 0.4f, 0.4f, 1), "not running: %s", loop_error_.c_str());
    }
    std::uint64_t published = 0, growths = 0;
    for (const auto& t : tissues_) {
      published += t->published();
      growths += t->capacity_growths();
    }
    ImGui::Text("snapshots %llu  (grown on the haptic thread: %llu)", static_cast<unsigned long long>(published),
                static_cast<unsigned long long>(growths));
  }
  if (ImGui::CollapsingHeader("Tissues")) {
    for (size_t i = 0; i < edits_.size(); ++i) {
      TissueDef& def = edits_[i];
      ImGui::PushID(static_cast<int>(i));
      if (ImGui::TreeNode(def.name.empty() ? "tissue" : def.name.c_str())) {
        ImGui::TextDisabled("%s", def.model.c_str());
        if (def.model == "charged_particles") edit_params(def.charged);
        else if (def.model == "mass_spring") edit_params(def.spring);
        const bool busy = rebuilding_ >= 0;
        if (busy) ImGui::BeginDisabled();
        if (ImGui::Button("Apply")) {
          // Build the new tissue off the GUI thread; finish_rebuild() hands it over.
          SceneDef edited = scene_;
          edited.tissues[i] = def;
          rebuilding_ = static_cast<int>(i);
          rebuild_message_ = "building " + def.name + "...";
          rebuild_ = std::async(std::launch::async, [edited, i] { return make_tissue(edited, static_cast<int>(i)); });
        }
        ImGui::SameLine();
        if (ImGui::Button("Revert")) def = scene_.tissues[i];
        if (busy) ImGui::EndDisabled();
        ImGui::TreePop();
      }
      ImGui::PopID();
    }
    if (ImGui::Button("Reset all to rest")) {
      stop_loop();
      for (auto& t : tissues_) {
        t->reset();
        t->publish_now();
      }
      Status started = start_loop();
      if (!started) loop_error_ = started.error().message;
    }
    if (!rebuild_message_.empty()) ImGui::TextWrapped("%s", rebuild_message_.c_str());
  }
  ImGui::End();
}

bool Viewer::take_screenshot(const std::filesystem::path& file, int fb_width, int fb_height) {
  const auto rgba = read_framebuffer(fb_width, fb_height);
  Status st = write_png_atomic(file, fb_width, fb_height, rgba);
  if (!st) {
    fmt::print(stderr, "palpate view: screenshot: {}\n", st.error().message);
    return false;
  }
  fmt::print("screenshot: {}\n", file.string());
  std::fflush(stdout);
  return true;
}

int Viewer::run() {
  if (int code = build_simulation()) return code;
  const CameraDef cam = scene_.camera.value_or(CameraDef{});
  camera_ = OrbitCamera::from(cam);
  scene_size_ = camera_.distance;
  arrow_metres_per_newton_ = static_cast<float>(0.25 * scene_size_);  // m per √N

  feeder_ = std::make_unique<PoseFeeder>(*device_, start_position(), options_.tool_speed);
  if (scene_.probe && scene_.anatomy) start_probe();

  std::string error;
  if (!init_window(error)) {
    fmt::print(stderr, "palpate view: {}\n", error);
    return 3;
  }
  if (Status st = start_loop(); !st) {
    fmt::print(stderr, "palpate view: the haptic loop did not start: {}\n", st.error().message);
    return 1;
  }
  if (options_.probe) stage_ = ProbeStage::pick;

  int frames = 0;
  int code = 0;
  auto last_frame = Clock::now();
  while (!glfwWindowShouldClose(window_)) {
    glfwPollEvents();
    const auto now = Clock::now();
    const double frame_dt = std::chrono::duration<double>(now - last_frame).count();
    last_frame = now;
    if (frame_dt > 0) fps_ = fps_ > 0 ? 0.9 * fps_ + 0.1 / frame_dt : 1.0 / frame_dt;
    finish_rebuild();
    int width = 0, height = 0, fb_width = 0, fb_height = 0;
    glfwGetWindowSize(window_, &width, &height);
    glfwGetFramebufferSize(window_, &fb_width, &fb_height);

    update_views();
    update_ultrasound();
    if (frames > 0 && !scripted_probe_step(width, height)) {
      code = 1;
      break;
    }
    force_ = device_->force();
    const double t = std::chrono::duration<double>(now - start_).count();
    force_history_.emplace_back(t, static_cast<float>(force_.norm()));
    while (!force_history_.empty() && force_history_.front().first < t - 6.0) force_history_.pop_front();

    if (imgui_ready_) {
      ImGui_ImplOpenGL3_NewFrame();
      ImGui_ImplGlfw_NewFrame();
      ImGui::NewFrame();
    }
    frame_input(width, height);
    draw_scene(fb_width, fb_height);

    // Screenshots show the scene without the panels: taken before ImGui draws over it.
    const bool probe_done = stage_ == ProbeStage::none || stage_ == ProbeStage::done;
    const bool last = options_.exit_after && frames + 1 >= options_.frames && probe_done;
    bool shot_taken = false;
    if (screenshot_key_) {
      screenshot_key_ = false;
      const std::filesystem::path file = !options_.screenshot.empty() && screenshot_count_ == 0
                                             ? options_.screenshot
                                             : std::filesystem::path(fmt::format("palpate-{}-{}.png", scene_.name, screenshot_count_ + 1));
      ++screenshot_count_;
      shot_taken = take_screenshot(file, fb_width, fb_height) && file == options_.screenshot;
    }
    if (last && !options_.screenshot.empty() && !shot_taken && !take_screenshot(options_.screenshot, fb_width, fb_height))
      code = 1;
    if (imgui_ready_) {
      if (options_.panels) {
        draw_panels();
        draw_ultrasound_panel();
      }
      ImGui::Render();
      ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    }
    glfwSwapBuffers(window_);
    ++frames;
    // A scripted run has no vsync to pace it: cap it near 60 fps so software GL does not take the
    // CPU the haptic thread needs.
    if (options_.exit_after) std::this_thread::sleep_until(now + std::chrono::milliseconds(16));
    if (last) break;
    if (options_.exit_after && t > options_.timeout) {
      fmt::print(stderr, "palpate view: gave up after {:.0f} s ({} frames drawn, probe {})\n", t, frames,
                 probe_done ? "done" : "still moving");
      code = 1;
      break;
    }
  }
  force_ = device_->force();
  fmt::print("frames: {}\n", frames);
  fmt::print("force_N: {:.6f}\n", force_.norm());
  fmt::print("force: {:.6f} {:.6f} {:.6f}\n", force_.x(), force_.y(), force_.z());
  const Vec3 tip = feeder_->position();
  fmt::print("tool: {:.6f} {:.6f} {:.6f}\n", tip.x(), tip.y(), tip.z());
  if (loop_) {
    const LoopStats st = loop_->stats();
    fmt::print("haptic_ticks: {}\n", st.ticks);
    fmt::print("deadline_misses: {}\n", st.deadline_misses);
    fmt::print("zeroed_ticks: {} (overrun {}, stalled {}, step_failed {}, device_failed {}, non_finite {})\n",
               st.safety.zeroed(), st.safety.overrun, st.safety.stalled, st.safety.step_failed,
               st.safety.device_failed, st.safety.non_finite);
    // What the Outcome panel showed last (docs/cvc.md): the loop's live metrics.
    const TrainingMetrics& m = st.metrics;
    fmt::print("outcome: {}\n", outcome_name(m.outcome));
    fmt::print("skin_punctures: {}\npasses: {}\ndeepest_depth_m: {:.6f}\n", m.skin_punctures, m.passes,
               m.deepest_depth);
    for (const LoopToolStats& t : st.tools) fmt::print("{}_max_force_N: {:.6f}\n", t.name, t.max_force);
  }
  if (probe_feeder_) {
    const Vec3 p = probe_feeder_->position();
    fmt::print("probe: {:.6f} {:.6f} {:.6f}\n", p.x(), p.y(), p.z());
    fmt::print("probe_force_N: {:.6f}\n", probe_device_->force().norm());
    fmt::print("ultrasound_images: {} rendered, {} shown\n", us_feed_ ? us_feed_->rendered() : 0, us_shown_);
  }
  std::fflush(stdout);
  stop_loop();
  return code;
}

}  // namespace

int run_viewer(const SceneDef& scene, const ViewerOptions& options) {
  Viewer viewer(scene, options);
  return viewer.run();
}

}  // namespace palpate::view
