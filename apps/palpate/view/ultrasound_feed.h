// ultrasound_feed.h — UltrasoundFeed: the viewer's live B-mode image, rendered on its own thread at
// a fixed rate from the probe's and the needle's poses (never on the haptic thread), handed to the
// GUI thread as the newest complete image. No OpenGL here: the viewer uploads it to a texture.
#pragma once

#include <palpate/scene_def.h>
#include <palpate/ultrasound.h>

#include <atomic>
#include <cstdint>
#include <functional>
#include <mutex>
#include <span>
#include <thread>
#include <vector>

namespace palpate::view {

class UltrasoundFeed {
 public:
  // Fills the poses the next image shows; called on the feed's thread (it must be thread-safe
  // against the GUI: the viewer's PoseFeeders are).
  using PoseSource = std::function<void(ProbePose& probe, NeedlePose& needle)>;
  // Starts the thread: an image every 1/rate seconds of wall time; its time (the arterial pulse)
  // is the wall time since construction.
  UltrasoundFeed(const NeckDef& neck, const ProbeDef& probe, PoseSource source, double rate = 25.0);
  ~UltrasoundFeed();
  UltrasoundFeed(const UltrasoundFeed&) = delete;
  UltrasoundFeed& operator=(const UltrasoundFeed&) = delete;

  // GUI thread: copy the newest image into `out` when there is one not taken yet; true if so.
  // The lock is held only between this thread and the feed's, for one copy.
  bool take(UltrasoundImage& out);
  // GUI thread: the vein's wall as the needle's tissue has it now (its particles at rest and now,
  // point for point); the next image shows it tented (UltrasoundImager::set_vein_wall).
  void set_vein_wall(std::span<const Vec3f> rest, std::span<const Vec3f> now);
  std::uint64_t rendered() const { return rendered_.load(std::memory_order_relaxed); }
  double last_render_seconds() const { return render_s_.load(std::memory_order_relaxed); }

 private:
  void run();

  UltrasoundImager imager_;
  PoseSource source_;
  double period_;
  UltrasoundImage work_;       // the feed thread's
  std::mutex mutex_;
  UltrasoundImage shared_;     // under mutex_
  bool fresh_ = false;         // under mutex_
  std::vector<Vec3f> wall_rest_, wall_now_;  // under mutex_: the GUI's newest vein wall
  bool wall_fresh_ = false;                  // under mutex_
  std::vector<Vec3f> work_rest_, work_now_;  // the feed thread's copies
  std::atomic<std::uint64_t> rendered_{0};
  std::atomic<double> render_s_{0};
  std::atomic<bool> quit_{false};
  std::thread thread_;
};

}  // namespace palpate::view
