// palpate/snapshot_tissue.h — SnapshotTissue: a Tissue that forwards to the real one and hands its
// drawn positions (with the tool and force of that step) to a render thread through a lock-free
// triple buffer, without allocating. Used by `palpate view` and by `palpate run --frames`.
#pragma once

#include <palpate/tissue.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

namespace palpate {

// Wraps a tissue stepped by the haptic loop. The render thread never reads the inner tissue's
// state: it calls request() once per frame; the next step() (on the haptic thread, or the tissue's
// physics thread) then copies the inner snapshot into the writer's slot of a triple buffer and
// publishes it; the render thread picks up the newest published slot with latest().
//
// Why this never allocates on the haptic thread: the three slots are filled once at construction
// and reserved with headroom (2x the arrays' sizes), and the models' snapshot() only resize/assign
// within capacity. Should a model ever grow its arrays past that, the copy would allocate: that is
// counted (capacity_growths()) so the viewer can show it, never hidden.
// Only one copy per displayed frame is made (at most ~60 per second, not 1000).
// The step a published copy was taken at: the tool the tissue saw and the force it returned.
struct SnapshotStamp {
  double time = 0;           // s, the tool's time at that step
  Vec3 tip = Vec3::Zero();   // m, the HIP
  Vec3 force = Vec3::Zero(); // N, this tissue's force on the tool
  bool stepped = false;      // false for a copy not made by step() (construction, publish_now)
  Vec3 axis = Vec3(0, -1, 0);  // unit, the needle's direction at that step (handle to tip)
};

class SnapshotTissue final : public Tissue {
 public:
  explicit SnapshotTissue(std::unique_ptr<Tissue> inner);
  ~SnapshotTissue() override;
  SnapshotTissue(const SnapshotTissue&) = delete;
  SnapshotTissue& operator=(const SnapshotTissue&) = delete;

  // The Tissue interface: forwarded to the inner tissue.
  const std::string& name() const override { return inner_->name(); }
  Vec3 step(const ToolState& tool, double dt) noexcept override;
  bool last_step_failed() const noexcept override { return inner_->last_step_failed(); }
  std::span<const std::string> figure_names() const override { return inner_->figure_names(); }
  void figures(std::span<double> out) const noexcept override { inner_->figures(out); }
  size_t drain_events(std::span<TissueEvent> out) noexcept override { return inner_->drain_events(out); }
  // Reads the inner state directly: only while nothing steps it (loop stopped).
  void snapshot(TissueSnapshot& snap) const override { inner_->snapshot(snap); }
  void reset() noexcept override { inner_->reset(); }
  void set_real_time(bool real_time) noexcept override { inner_->set_real_time(real_time); }
  void set_second_tool(const ToolState& tool) noexcept override { inner_->set_second_tool(tool); }
  Vec3 second_tool_force() const noexcept override { return inner_->second_tool_force(); }
  Status set_install_schedule(std::span<const std::int32_t> installed) override {
    return inner_->set_install_schedule(installed);
  }
  void set_layers_above(std::span<Tissue* const> above) override { inner_->set_layers_above(above); }
  const ChargedLayer* charged_layer() const noexcept override { return inner_->charged_layer(); }
  const SpringBody* spring_body() const noexcept override { return inner_->spring_body(); }
  ContactComplianceSource* contact_compliance() noexcept override { return inner_->contact_compliance(); }

  // Render thread: ask for a fresh copy at the next step. Cheap; call every frame.
  void request() noexcept { wanted_.store(true, std::memory_order_release); }
  // Render thread: swap in the newest published copy (if any) and return it (never null: the
  // slots start with the rest state). `fresh` tells whether it is newer than the last call's.
  const TissueSnapshot& latest(bool* fresh = nullptr) noexcept;
  // Render thread: the copy the last latest() returned, without looking for a newer one.
  const TissueSnapshot& current() const noexcept { return slots_[front_]; }
  // Render thread: the step the copy last returned by latest() was taken at.
  const SnapshotStamp& current_stamp() const noexcept { return stamps_[front_]; }
  // Publish a copy now from the calling thread: only while nothing steps the tissue (before the
  // loop starts, after it stopped), e.g. after reset().
  void publish_now();
  // The same, stamped with the last step (a frame of a run that has ended shows the tool and
  // force of its last tick, not those of the last copy published while it ran). Same rule.
  void publish_last_step();

  // Copies published by step() so far, and how many of them had to grow a slot's arrays.
  std::uint64_t published() const noexcept { return published_.load(std::memory_order_relaxed); }
  std::uint64_t capacity_growths() const noexcept { return growths_.load(std::memory_order_relaxed); }

 private:
  void copy_into_back(const SnapshotStamp& stamp) noexcept;

  std::unique_ptr<Tissue> inner_;
  // Triple buffer: the writer (stepping thread) fills slots_[back_] and swaps it with the middle;
  // the reader (render thread) swaps its front with the middle when the middle is fresh. Each is
  // touched at most once per displayed frame, so no cache-line padding is needed.
  static constexpr std::uint8_t kFresh = 0x4, kIndex = 0x3;
  std::array<TissueSnapshot, 3> slots_;
  std::array<SnapshotStamp, 3> stamps_;
  std::atomic<std::uint8_t> middle_{1};
  std::uint8_t back_ = 0;   // owned by the writer
  std::uint8_t front_ = 2;  // owned by the reader
  SnapshotStamp last_step_; // owned by the stepping thread: the tool and force of its last step
  std::atomic<bool> wanted_{true};
  std::atomic<std::uint64_t> published_{0};
  std::atomic<std::uint64_t> growths_{0};
};

}  // namespace palpate
