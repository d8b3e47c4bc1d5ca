// viewer.cpp — the `palpate view` window: its life (simulation, loop, window), the mouse as a
// virtual haptic device (tool and probe), the scripted probe of --probe, and the frame loop.
// What is drawn: viewer_scene.cpp; the ImGui panels: viewer_panels.cpp.
#include "viewer_impl.h"

#include "../exit_codes.h"

namespace palpate::view {
namespace detail {

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
    return cli::kExitFailed;
  }
  device_ = std::make_unique<VirtualDevice>(device_limits(scene_.device));
  if (scene_.probe && scene_.anatomy) probe_device_ = std::make_unique<VirtualDevice>(device_limits(scene_.probe->device));
  // A tool on a haptic device is driven by that device (several at once, any mix of backends:
  // docs/haptics.md, "Several devices"); the mouse drives the others.
  const auto hardware = [](const DeviceDef& d) { return d.kind == "openhaptics" || d.kind == "forcedimension"; };
  hardware_tool_ = hardware(scene_.device);
  hardware_probe_ = probe_device_ && hardware(scene_.probe->device);
  auto sim = Simulation::build(scene_, view_simulation_options(options_, hardware_tool_ ? nullptr : device_.get(),
                                                               hardware_probe_ ? nullptr : probe_device_.get()));
  if (!sim) {
    fmt::print(stderr, "palpate view: {}\n", sim.error().message);
    return cli::kExitFailed;
  }
  sim_ = std::move(*sim);
  if (const SimulationTool* probe = sim_->tool("probe")) probe_loop_index_ = probe->loop_index;
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
  begin_attempt();
  return {};
}

void Viewer::stop_loop() {
  if (loop_) loop_->stop();
  end_attempt();  // its metrics are the stopped loop's last
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
  const bool quad_buffer = options_.stereo.mode == StereoMode::quad_buffer;
  if (quad_buffer) glfwWindowHint(GLFW_STEREO, GLFW_TRUE);  // a hard constraint: no stereo, no window
  const CameraDef cam = scene_.camera.value_or(CameraDef{});
  const int width = options_.width > 0 ? options_.width : cam.width;
  const int height = options_.height > 0 ? options_.height : cam.height;
  const std::string title = "palpate — " + scene_.name;
  window_ = glfwCreateWindow(width, height, title.c_str(), nullptr, nullptr);
  if (!window_ && quad_buffer) {
    error = kNoQuadBuffer;
    return false;
  }
  if (!window_) {
    error = "cannot open a " + std::to_string(width) + "x" + std::to_string(height) +
            " window with OpenGL 3.3 core (no display, or a driver without 3.3; under xvfb-run set "
            "LIBGL_ALWAYS_SOFTWARE=1)";
    return false;
  }
  glfwMakeContextCurrent(window_);
  if (quad_buffer) {  // a driver may hand out a context without the buffers it was asked for
    GLboolean stereo = GL_FALSE;
    glGetBooleanv(GL_STEREO, &stereo);
    if (!stereo) {
      error = kNoQuadBuffer;
      return false;
    }
  }
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
  if (key == GLFW_KEY_ESCAPE) glfwSetWindowShouldClose(window, GLFW_TRUE);
  else v->handle_key(key);
}

int Viewer::glfw_key(char c) {
  if (c == ' ') return GLFW_KEY_SPACE;
  if (c >= 'a' && c <= 'z') return GLFW_KEY_A + (c - 'a');
  if (c >= 'A' && c <= 'Z') return GLFW_KEY_A + (c - 'A');
  if (c >= '0' && c <= '9') return GLFW_KEY_0 + (c - '0');
  return 0;
}

void Viewer::handle_key(int key) {
  switch (key) {
    case GLFW_KEY_F12:
    case GLFW_KEY_S:
      screenshot_key_ = true;
      break;
    case GLFW_KEY_R: {  // the needle (blade) back to the scene's tool.axis, about the skin hole once in
      const std::optional<Vec3> hole = axial_tool() ? skin_hole() : std::nullopt;
      feeder_->set_orientation_target(Quat::Identity());
      if (hole) feeder_->set_pivot(*hole, (feeder_->position() - *hole).norm(), scene_axis());
      break;
    }
    case GLFW_KEY_SPACE:
      if (player_) player_->toggle();
      break;
    case GLFW_KEY_N:
      if (player_) player_->step(ScriptPlayer::kStep);
      break;
    case GLFW_KEY_V:
      turn_probe();
      break;
    case GLFW_KEY_A:
      if (scene_.tool.kind == "needle") new_attempt();
      break;
    default:
      break;
  }
}

std::optional<Vec3> Viewer::skin_hole() const {
  // From the handle along the shaft to the first drawn tissue surface: the skin it went in through.
  const Vec3 tip = feeder_->position();
  const Vec3 axis = needle_axis(scene_axis(), feeder_->orientation());
  const Vec3 handle = tip - scene_.tool.length * axis;
  const auto hit = pick_surface(handle, axis);
  // Through the skin: the surface crossed at least a millimetre before the tip.
  if (!hit || *hit > scene_.tool.length - 0.001) return std::nullopt;
  return handle + *hit * axis;
}

void Viewer::tilt_needle(double dx, double dy) {
  if (!tilting_) {
    tilting_ = true;
    tilt_pivot_ = skin_hole();
    tilt_beyond_ = tilt_pivot_ ? (feeder_->position() - *tilt_pivot_).norm() : 0;
    if (player_) player_->pause();
  }
  const Quat target = feeder_->orientation_target();
  const Vec3 handle = -needle_axis(scene_axis(), target);
  feeder_->set_orientation_target(
      tilt_by_drag(target, handle, dx, dy, camera_.right(), camera_.up(), kTiltRadiansPerPixel));
  // Inside the skin the hole stays where it is: the tip swings the other way from the handle.
  if (tilt_pivot_) feeder_->set_pivot(*tilt_pivot_, tilt_beyond_, scene_axis());
}

Quat Viewer::probe_turn() const {
  if (!probe_turned_ || !scene_.probe) return Quat::Identity();
  return Quat(Eigen::AngleAxisd(0.5 * M_PI, scene_.probe->axis.normalized()));
}

void Viewer::turn_probe() {
  if (!probe_feeder_) return;
  // A quarter turn about the beam, in the probe's own frame (applied after its orientation): the
  // transverse (out-of-plane) view becomes the longitudinal (in-plane) one, and back.
  const Quat undo = probe_turn().conjugate();
  probe_turned_ = !probe_turned_;
  probe_feeder_->set_orientation_target((probe_feeder_->orientation_target() * undo * probe_turn()).normalized());
}

bool Viewer::probe_in_plane() const {
  if (!probe_feeder_ || scene_.tool.kind != "needle") return false;
  const Quat q = probe_feeder_->orientation();
  const Vec3 beam = (q * scene_.probe->axis).normalized();
  const Vec3 lateral = (q * scene_.probe->lateral).normalized();
  const Vec3 elevation = beam.cross(lateral).normalized();
  const Vec3 needle = needle_axis(scene_axis(), feeder_->orientation());
  return std::abs(needle.dot(elevation)) < std::sin(20.0 * M_PI / 180);
}

void Viewer::play_script(double frame_seconds) {
  if (!player_) return;
  player_->advance(frame_seconds);
  if (!player_->moved()) return;
  DeviceState s;
  if (player_->tool_pose(s)) {
    feeder_->set_target(s.position);
    feeder_->set_orientation_target(s.orientation);
  }
  if (probe_feeder_ && player_->probe_pose(s)) {
    probe_feeder_->set_target(s.position);
    probe_feeder_->set_orientation_target((s.orientation * probe_turn()).normalized());
  }
}

std::optional<double> Viewer::pick_surface(const Vec3& origin, const Vec3& dir) const {
  std::optional<double> best;
  for (size_t i = 0; i < views_.size(); ++i) {
    if (!drawn_[i]) continue;
    const auto t = pick(origin, dir, views_[i].positions(), views_[i].triangles());
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
  pointer_view(x, y, width, height);  // stereo: the eye's half of the window the pointer is in
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
  if (probe_feeder_ && probe_input(x, y, dx, dy, width, height, notches, right, left, shift, ctrl, ui)) return;
  if (!(left && ctrl)) tilting_ = false;
  if (!ui) {
    if (left && ctrl) {
      // Tilt the needle: its handle follows the pointer, 0.5 degree per pixel, about the skin hole
      // once it is in (about its tip before). The device (and so the loop's tool.axis) turns
      // towards it at the feeder's bounded rate.
      tilt_needle(dx, dy);
    } else if ((left && shift) || middle) {
      camera_.pan(dx, dy, height);
    } else if (left) {
      camera_.orbit(dx, dy);
    }
  }
  const Vec3 eye = camera_.eye();
  const Vec3 dir = camera_.ray_direction(x, y, width, height);  // in the view under the pointer
  if (right && !pressing_ && !ui) {
    // Press: touch the surface under the cursor (or, off the tissue, the plane through the
    // camera's target facing it), starting 1 mm past touching.
    pressing_ = true;
    if (player_) player_->pause();  // the hand takes over from the script
    const auto hit = pick_surface(eye, dir);
    press_distance_ = hit ? *hit : (camera_.target - eye).dot(camera_.forward()) / dir.dot(camera_.forward());
    press_depth_ = -tool_radius() + 0.001;
  } else if (!right && pressing_) {
    // Release: back out (along the needle's shaft, or the ray) to just above the surface.
    pressing_ = false;
    feeder_->set_target(eye + dir * press_distance_ - press_direction(dir) * (tool_radius() + 0.003));
    return;
  }
  if (pressing_) {
    // The wheel advances and withdraws a needle along its own shaft (a sphere along the ray), from
    // the surface point under the cursor.
    press_depth_ += notches * 0.0005;  // 0.5 mm per wheel notch, forward = deeper
    feeder_->set_target(eye + dir * press_distance_ + press_direction(dir) * press_depth_);
  } else if (!ui && notches != 0) {
    camera_.zoom(notches);
  }
}

Vec3 Viewer::press_direction(const Vec3& ray) const {
  if (!axial_tool()) return ray;
  return needle_axis(scene_axis(), feeder_->orientation_target());
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
      double x = p.x, y = p.y;
      int w = width, h = height;
      pointer_view(x, y, w, h);  // stereo: the eye's half of the window the pixel is in
      const Vec3 dir = camera_.ray_direction(x, y, w, h);
      const auto hit = pick_surface(eye, dir);
      if (!hit) {
        fmt::print(stderr, "palpate view: --probe {},{}: no tissue surface under that pixel of the {}x{} window\n",
                   p.x, p.y, width, height);
        return false;
      }
      // A needle goes in along its own shaft from the surface point under the pixel, a sphere along
      // the ray.
      const Vec3 along = press_direction(dir);
      probe_final_ = eye + dir * *hit + along * p.depth;
      feeder_->set_target(eye + dir * *hit - along * (tool_radius() + 0.003));
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
    if (player_) player_->pause();  // the hand takes over from the script
    // Tilt the probe about its face: its top follows the pointer, as the needle's handle does.
    const Quat target = probe_feeder_->orientation_target();
    const Vec3 top = -(target * scene_.probe->axis).normalized();
    probe_feeder_->set_orientation_target(
        tilt_by_drag(target, top, dx, dy, camera_.right(), camera_.up(), kTiltRadiansPerPixel));
    return true;
  }
  if (right && shift && !pressing_ && !moving_probe_ && !ui) {
    moving_probe_ = true;
    if (player_) player_->pause();
  }
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
    return cli::kExitFailed;
  }
  if (Status st = start_loop(); !st) {
    fmt::print(stderr, "palpate view: the haptic loop did not start: {}\n", st.error().message);
    return 1;
  }
  if (options_.probe) stage_ = ProbeStage::pick;
  player_ = std::make_unique<ScriptPlayer>(scene_);
  if (!player_->error().empty()) fmt::print(stderr, "palpate view: the script cannot be played: {}\n", player_->error());
  if (!player_->has_script()) player_.reset();
  if (player_ && options_.play_to >= 0) player_->play_to(options_.play_to);
  else if (player_ && options_.play) player_->play();
  pending_keys_ = options_.keys;
  if (options_.tilt) tilt_stage_ = TiltStage::settle;

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
    if (frames > 0 && !pending_keys_.empty()) {  // --keys: one a frame, through the key handler
      if (const int key = glfw_key(pending_keys_.front())) handle_key(key);
      pending_keys_.erase(pending_keys_.begin());
    }
    play_script(frames > 0 ? frame_dt : 0);  // the script's clock into the feeders' targets
    follow_hardware();
    force_ = tool_force();
    const double t = std::chrono::duration<double>(now - start_).count();
    force_history_.emplace_back(t, static_cast<float>(force_.norm()));
    while (!force_history_.empty() && force_history_.front().first < t - 6.0) force_history_.pop_front();
    if (probe_device_) {
      probe_history_.emplace_back(t, static_cast<float>(probe_force().norm()));
      while (!probe_history_.empty() && probe_history_.front().first < t - 6.0) probe_history_.pop_front();
    }

    if (imgui_ready_) {
      ImGui_ImplOpenGL3_NewFrame();
      ImGui_ImplGlfw_NewFrame();
      ImGui::NewFrame();
    }
    frame_input(width, height);
    draw_scene(fb_width, fb_height);
    record_attempt(fb_width, fb_height);  // the 3-D view read before the panels are drawn over it

    // Screenshots show the scene without the panels: taken before ImGui draws over it.
    // --tilt, once the press (--probe) and the script (--play-to) are done and the tools arrived:
    // the drag, then the same settle as a press.
    const bool script_done = !player_ || !player_->playing();
    const bool tools_arrived = feeder_->arrived() && (!probe_feeder_ || probe_feeder_->arrived());
    if (tilt_stage_ == TiltStage::settle && (stage_ == ProbeStage::none || stage_ == ProbeStage::done) &&
        script_done && tools_arrived) {
      tilt_needle((*options_.tilt)[0], (*options_.tilt)[1]);
      tilting_ = false;
      tilt_stage_ = TiltStage::turn;
    } else if (tilt_stage_ == TiltStage::turn && tools_arrived) {
      restart_settle();
      stage_ = ProbeStage::settle;
      tilt_stage_ = TiltStage::done;
    }
    const bool probe_done = (stage_ == ProbeStage::none || stage_ == ProbeStage::done) && script_done &&
                            (!player_ || tools_arrived) && pending_keys_.empty() &&
                            (tilt_stage_ == TiltStage::none || tilt_stage_ == TiltStage::done);
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
    const bool shot_with_panels = options_.screenshot_panels && imgui_ready_;
    if (last && !options_.screenshot.empty() && !shot_taken && !shot_with_panels &&
        !take_screenshot(options_.screenshot, fb_width, fb_height))
      code = 1;
    if (imgui_ready_) {
      if (options_.panels) {
        draw_panels();
        draw_ultrasound_panel();
      }
      ImGui::Render();
      ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
      // --screenshot-panels: the exit screenshot as the window shows it, panels and all.
      if (last && shot_with_panels && !options_.screenshot.empty() && !shot_taken &&
          !take_screenshot(options_.screenshot, fb_width, fb_height))
        code = 1;
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
  force_ = tool_force();
  end_attempt();  // the last attempt, with the loop's metrics now
  if (!write_report() && code == 0) code = 1;
  if (!options_.quiet) report_exit(frames);
  std::fflush(stdout);
  stop_loop();
  return code;
}


void Viewer::follow_hardware() {
  if (!loop_) return;
  if (hardware_tool_ && feeder_)
    if (const ToolSample t = loop_->tool_sample(0); t.valid) feeder_->follow(t.position, t.orientation);
  if (hardware_probe_ && probe_feeder_)
    if (const ToolSample p = loop_->tool_sample(probe_loop_index_); p.valid)
      probe_feeder_->follow(p.position, p.orientation);
}

Vec3 Viewer::tool_force() const {
  if (hardware_tool_) return loop_ ? loop_->tool_sample(0).force : Vec3(Vec3::Zero());
  return device_->force();
}

Vec3 Viewer::probe_force() const {
  if (hardware_probe_) return loop_ ? loop_->tool_sample(probe_loop_index_).force : Vec3(Vec3::Zero());
  return probe_device_ ? probe_device_->force() : Vec3(Vec3::Zero());
}

}  // namespace detail

int run_viewer(const SceneDef& scene, const ViewerOptions& options) {
  detail::Viewer viewer(scene, options);
  return viewer.run();
}

// What the run ended with, on standard output (docs/viewer.md: the tests read these lines).
void detail::Viewer::report_exit(int frames) {
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
  if (scene_.tool.kind == "needle") {
    const Vec3 a = needle_axis(scene_axis(), feeder_->orientation());
    fmt::print("needle_axis: {:.6f} {:.6f} {:.6f}\n", a.x(), a.y(), a.z());
  }
  if (blade()) {  // the edge as the mouse left it (heel → tip), and the ticks it jumped (not cut)
    const Vec3 a = needle_axis(scene_axis(), feeder_->orientation());
    fmt::print("blade_axis: {:.6f} {:.6f} {:.6f}\n", a.x(), a.y(), a.z());
    fmt::print("blade_teleport: {}\n", loop_ ? loop_->stats().safety.blade_teleport : 0);
  }
  if (player_) fmt::print("script_time: {:.3f}\n", player_->time());
  if (probe_feeder_) {
    fmt::print("probe_view: {}\n", probe_in_plane() ? "in-plane" : "out-of-plane");
    const Vec3 p = probe_feeder_->position();
    fmt::print("probe: {:.6f} {:.6f} {:.6f}\n", p.x(), p.y(), p.z());
    fmt::print("probe_force_N: {:.6f}\n", probe_force().norm());
    fmt::print("ultrasound_images: {} rendered, {} shown\n", us_feed_ ? us_feed_->rendered() : 0, us_shown_);
  }
  if (!report_written_.empty()) fmt::print("report: {} ({} attempts)\n", report_written_.string(), attempts_.size());
}

}  // namespace palpate::view
