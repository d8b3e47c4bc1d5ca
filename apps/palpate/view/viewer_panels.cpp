// viewer_panels.cpp — the `palpate view` window's ImGui panels: display toggles, material edits
// (applied by rebuilding the tissue off the GUI thread and handing it over), loop timing and
// stages, the outcome, the live force plot, and the ultrasound image.
#include "viewer_impl.h"
#include <cfloat>

namespace palpate::view::detail {
namespace {

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

}  // namespace

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
              probe_force().norm());
  if (us_feed_)
    ImGui::Text("%s  %.1f ms per image", us_image_.in_contact ? "on the skin" : "not touching",
                1e3 * us_feed_->last_render_seconds());
  // What the image is: its depth and scale (burnt into the image's right edge), which end is which
  // (the square marks the probe's -lateral end), and the view the probe gives of the needle.
  if (us_image_.width > 0)
    ImGui::Text("depth %.0f mm, a tick per 5 mm; square: marked end", 1e3 * us_image_.height * us_image_.pixel_depth);
  if (scene_.tool.kind == "needle")
    ImGui::Text("%s", probe_in_plane() ? "in-plane: the whole shaft in view" : "out-of-plane: the shaft as a dot");
  ImGui::TextDisabled("shift + right drag: move it, wheel: press");
  ImGui::TextDisabled("shift + ctrl + left drag: tilt it");
  ImGui::TextDisabled("V: turn it 90 deg (in/out of plane)");
  ImGui::End();
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

void Viewer::draw_script_panel() {
  // The scene's scripted tools, played in the window (Space, N; a press or tilt with the mouse
  // pauses the script and the hand takes over from where it left the tools).
  if (!ImGui::CollapsingHeader("Script", ImGuiTreeNodeFlags_DefaultOpen)) return;
  ImGui::Text("t %.2f / %.2f s  %s", player_->time(), player_->duration(), player_->playing() ? "playing" : "paused");
  if (ImGui::Button(player_->playing() ? "Pause" : "Play")) player_->toggle();
  ImGui::SameLine();
  if (ImGui::Button("Step 0.1 s")) player_->step(ScriptPlayer::kStep);
  ImGui::SameLine();
  if (ImGui::Button("To start")) player_->step(-player_->time());
  ImGui::SameLine();
  ImGui::TextDisabled("Space, N");
  ImGui::ProgressBar(player_->duration() > 0 ? float(player_->time() / player_->duration()) : 0.f, ImVec2(-FLT_MIN, 0), "");
}

void Viewer::draw_panels() {
  // Wide enough for its longest line (410 px), never taller than the window (it scrolls): at the
  // default 800 x 600 nothing is cut off and it stays left of the ultrasound panel.
  const ImVec2 display = ImGui::GetIO().DisplaySize;
  ImGui::SetNextWindowPos(ImVec2(8, 8), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(410, 0), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSizeConstraints(ImVec2(200, 100), ImVec2(std::max(200.0f, display.x - 16), std::max(100.0f, display.y - 16)));
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
    if (scene_.tool.kind == "needle") ImGui::TextDisabled("ctrl + left drag: tilt the needle about the hole");
    if (blade()) {
      ImGui::TextDisabled("blade: in point first; move while pressed to cut along");
      ImGui::TextDisabled("ctrl + left drag: tilt the blade about where it went in");
    }
    ImGui::TextDisabled("R: untilt  F12 or S: screenshot  Esc: quit");
  }
  if (player_) draw_script_panel();
  if (ImGui::CollapsingHeader("Force", ImGuiTreeNodeFlags_DefaultOpen)) {
    const Vec3 tip = feeder_->position();
    ImGui::Text("|F| %.3f N  (%.3f, %.3f, %.3f)", force_.norm(), force_.x(), force_.y(), force_.z());
    ImGui::Text("tool %.1f, %.1f, %.1f mm", 1e3 * tip.x(), 1e3 * tip.y(), 1e3 * tip.z());
    if (pressing_) ImGui::Text("depth past the surface %.1f mm", 1e3 * press_depth_);
    if (blade()) {
      // The edge (heel → tip) and whether the loop has had to stop it cutting (docs/haptics.md).
      const Vec3 a = needle_axis(scene_axis(), feeder_->orientation());
      ImGui::Text("blade %.0f mm (%.2f, %.2f, %.2f), tilted %.1f deg", 1e3 * scene_.tool.length, a.x(),
                  a.y(), a.z(), std::acos(std::clamp(a.dot(scene_axis()), -1.0, 1.0)) * 180 / M_PI);
      if (loop_) {
        const std::uint64_t jumps = loop_->stats().safety.blade_teleport;
        if (jumps > 0) ImGui::TextColored(ImVec4(1.0f, 0.6f, 0.2f, 1.0f), "blade jumped %llu ticks: pressed, not cut",
                                          static_cast<unsigned long long>(jumps));
      }
    }
    if (scene_.tool.kind == "needle") {
      const Vec3 a = needle_axis(scene_axis(), feeder_->orientation());
      ImGui::Text("needle (%.2f, %.2f, %.2f), %.1f deg from tool.axis", a.x(), a.y(), a.z(),
                  std::acos(std::clamp(a.dot(scene_axis()), -1.0, 1.0)) * 180 / M_PI);
    }
    // |F| over the last 5 s, resampled to fixed bins (frames are not evenly spaced); the probe's
    // too, in a scene with one (what the other hand presses with).
    constexpr int kBins = 150;
    constexpr double kSpan = 5.0;
    const double now = std::chrono::duration<double>(Clock::now() - start_).count();
    auto plot = [&](const char* id, const char* label, const std::deque<std::pair<double, float>>& history) {
      float bins[kBins] = {};
      size_t k = 0;
      float last = 0;
      for (int b = 0; b < kBins; ++b) {
        const double t = now - kSpan + kSpan * (b + 1) / kBins;
        while (k < history.size() && history[k].first <= t) last = history[k++].second;
        bins[b] = last;
      }
      const float top = std::max(0.5f, *std::max_element(bins, bins + kBins) * 1.1f);
      // The width given, not -1: this ImGui's PlotLines takes a negative width literally (the trace
      // was a 2 px sliver).
      ImGui::PlotLines(id, bins, kBins, 0, label, 0.0f, top, ImVec2(std::max(50.0f, ImGui::GetContentRegionAvail().x), 80));
    };
    plot("##force", "|F| (N), last 5 s", force_history_);
    if (probe_device_) {
      ImGui::Text("probe |F| %.3f N", probe_history_.empty() ? 0.0 : double(probe_history_.back().second));
      plot("##probe_force", "probe |F| (N), last 5 s", probe_history_);
    }
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
      if (m.arterial_flashback)  // the carotid: pulsatile, bright red
        ImGui::TextColored(ImVec4(1.0f, 0.25f, 0.2f, 1.0f), "ARTERIAL flashback at %.2f s: pulsatile, bright red",
                           m.arterial_flashback_time);
      ImGui::Text("deepest %.1f mm below the skin  peak |F| %.2f N", 1e3 * m.deepest_depth, m.peak_force);
      // Each attempt goes into report.html on exit; a new one starts from the tissues at rest.
      if (ImGui::Button("New attempt")) new_attempt();
      ImGui::SameLine();
      ImGui::TextDisabled("A  (%zu before this one)", attempts_.size());
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
          rebuild_ = std::async(std::launch::async, [edited, i, cache = options_.cache] {
            return make_tissue(edited, static_cast<int>(i),
                               file_tissue_services(cache.empty() ? default_predictor_cache() : cache));
          });
        }
        ImGui::SameLine();
        if (ImGui::Button("Revert")) def = scene_.tissues[i];
        if (busy) ImGui::EndDisabled();
        ImGui::TreePop();
      }
      ImGui::PopID();
    }
    if (ImGui::Button("Reset all to rest")) new_attempt();
    if (!rebuild_message_.empty()) ImGui::TextWrapped("%s", rebuild_message_.c_str());
  }
  ImGui::End();
}

}  // namespace palpate::view::detail
