// ultrasound_feed.cpp — UltrasoundFeed: the live ultrasound image's thread and hand-over.
#include "ultrasound_feed.h"

#include <chrono>

namespace palpate::view {

UltrasoundFeed::UltrasoundFeed(const NeckDef& neck, const ProbeDef& probe, PoseSource source, double rate)
    : imager_(neck, probe), source_(std::move(source)), period_(rate > 0 ? 1.0 / rate : 0.04) {
  thread_ = std::thread([this] { run(); });
}

UltrasoundFeed::~UltrasoundFeed() {
  quit_.store(true);
  if (thread_.joinable()) thread_.join();
}

bool UltrasoundFeed::take(UltrasoundImage& out) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!fresh_) return false;
  out.width = shared_.width, out.height = shared_.height;
  out.pixel_width = shared_.pixel_width, out.pixel_depth = shared_.pixel_depth;
  out.in_contact = shared_.in_contact;
  out.grey = shared_.grey;  // the GUI needs the grey levels only
  fresh_ = false;
  return true;
}

void UltrasoundFeed::set_vein_wall(std::span<const Vec3f> rest, std::span<const Vec3f> now) {
  std::lock_guard<std::mutex> lock(mutex_);
  wall_rest_.assign(rest.begin(), rest.end());
  wall_now_.assign(now.begin(), now.end());
  wall_fresh_ = true;
}

void UltrasoundFeed::run() {
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  auto next = start;
  while (!quit_.load()) {
    ProbePose probe;
    NeedlePose needle;
    source_(probe, needle);
    bool wall = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (wall_fresh_) {
        work_rest_ = wall_rest_;
        work_now_ = wall_now_;
        wall_fresh_ = false;
        wall = true;
      }
    }
    if (wall) imager_.set_vein_wall(work_rest_, work_now_);
    const auto t0 = Clock::now();
    imager_.render(probe, needle, std::chrono::duration<double>(t0 - start).count(), work_);
    render_s_.store(std::chrono::duration<double>(Clock::now() - t0).count(), std::memory_order_relaxed);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      shared_.width = work_.width, shared_.height = work_.height;
      shared_.pixel_width = work_.pixel_width, shared_.pixel_depth = work_.pixel_depth;
      shared_.in_contact = work_.in_contact;
      shared_.grey = work_.grey;
      fresh_ = true;
    }
    rendered_.fetch_add(1, std::memory_order_relaxed);
    next += std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(period_));
    const auto now = Clock::now();
    if (next < now) next = now;  // fell behind (a slow machine): no catching up in a burst
    // Sleep in short steps so the destructor never waits a whole period.
    while (!quit_.load() && Clock::now() < next) std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
}

}  // namespace palpate::view
