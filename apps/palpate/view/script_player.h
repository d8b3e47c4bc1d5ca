// script_player.h — the viewer's player of a scene's scripted tools: the needle's device and the
// probe's (scripted waypoints, a trajectory CSV or a recorded run to replay), read at a clock the
// trainee plays, pauses and steps. The poses it gives are targets for the viewer's PoseFeeders,
// which walk the virtual devices there at 1 kHz: the haptic loop sees the same tools as the mouse
// would drive, so the trainee can stop the script anywhere and take over with the mouse.
#pragma once

#include <palpate/device.h>
#include <palpate/scene_def.h>

#include <memory>
#include <string>

namespace palpate::view {

class ScriptPlayer {
 public:
  // The scene's devices of kind scripted or replay (an openhaptics one is a hand: not played).
  // A device that cannot be made (a trajectory file missing) is left out, its error in `error()`.
  explicit ScriptPlayer(const SceneDef& scene);
  bool has_script() const { return tool_ || probe_; }
  bool has_tool() const { return tool_ != nullptr; }
  bool has_probe() const { return probe_ != nullptr; }
  const std::string& error() const { return error_; }

  double time() const { return time_; }          // s, the script's clock
  double duration() const { return duration_; }  // s, the scene's
  bool playing() const { return playing_; }
  void play();                   // from where it is (from 0 again once at the end)
  void pause() { playing_ = false; }
  void toggle() { playing_ ? pause() : play(); }
  // Advance the clock by `seconds` and pause there: one step at a time.
  void step(double seconds);
  // Play up to `t` and pause there (clamped to the duration).
  void play_to(double t);
  // The GUI's frame: advance by the frame's wall time while playing, up to the stop.
  void advance(double wall_seconds);
  // Whether the clock moved since the last call (the feeders then take the new poses).
  bool moved();
  // The devices' poses at the clock: false where that tool has no script.
  bool tool_pose(DeviceState& out);
  bool probe_pose(DeviceState& out);

  static constexpr double kStep = 0.1;  // s, one step (N)

 private:
  std::unique_ptr<Device> tool_, probe_;
  std::string error_;
  double time_ = 0, duration_ = 0, stop_ = 0;
  bool playing_ = false, moved_ = true;
};

}  // namespace palpate::view
