// script_player.cpp — ScriptPlayer (script_player.h).
#include "script_player.h"

#include <algorithm>

namespace palpate::view {

namespace {

bool playable(const DeviceDef& d) { return d.kind == "scripted" || d.kind == "replay"; }

}  // namespace

ScriptPlayer::ScriptPlayer(const SceneDef& scene) : duration_(std::max(0.0, scene.duration)) {
  stop_ = duration_;
  if (playable(scene.device)) {
    auto made = make_device(scene.device, scene.tool.axis.normalized(), scene.file.string(), "device");
    if (made) tool_ = std::move(*made);
    else error_ = made.error().message;
  }
  if (scene.probe && playable(scene.probe->device)) {
    auto made = make_device(scene.probe->device, scene.probe->axis.normalized(), scene.file.string(), "probe.device");
    if (made) probe_ = std::move(*made);
    else error_ = error_.empty() ? made.error().message : error_ + "; " + made.error().message;
  }
}

void ScriptPlayer::play() {
  if (!has_script()) return;
  if (time_ >= duration_) time_ = 0, moved_ = true;
  stop_ = duration_;
  playing_ = true;
}

void ScriptPlayer::step(double seconds) {
  if (!has_script()) return;
  playing_ = false;
  const double t = std::clamp(time_ + seconds, 0.0, duration_);
  moved_ = moved_ || t != time_;
  time_ = t;
}

void ScriptPlayer::play_to(double t) {
  if (!has_script()) return;
  stop_ = std::clamp(t, 0.0, duration_);
  if (stop_ < time_) time_ = 0, moved_ = true;
  playing_ = stop_ > time_;
}

void ScriptPlayer::advance(double wall_seconds) {
  if (!playing_ || !(wall_seconds > 0)) return;
  time_ = std::min(stop_, time_ + wall_seconds);
  moved_ = true;
  if (time_ >= stop_) playing_ = false;
}

bool ScriptPlayer::moved() {
  const bool m = moved_;
  moved_ = false;
  return m;
}

bool ScriptPlayer::tool_pose(DeviceState& out) { return tool_ && tool_->read(time_, out); }
bool ScriptPlayer::probe_pose(DeviceState& out) { return probe_ && probe_->read(time_, out); }

}  // namespace palpate::view
