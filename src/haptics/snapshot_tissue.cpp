// snapshot_tissue.cpp — SnapshotTissue: forwarding step() and the allocation-free hand-over of
// drawn positions from the stepping thread to the render thread.
#include <palpate/snapshot_tissue.h>

#include <algorithm>

namespace palpate {

namespace {

// Capacity for `size` elements plus headroom, so a later copy of about the same size never allocates.
size_t with_headroom(size_t size) { return 2 * size + 16; }

template <class T>
void reserve_headroom(std::vector<T>& v, size_t size) {
  v.reserve(with_headroom(size));
}

}  // namespace

SnapshotTissue::SnapshotTissue(std::unique_ptr<Tissue> inner) : inner_(std::move(inner)) {
  TissueSnapshot first;
  inner_->snapshot(first);
  for (TissueSnapshot& s : slots_) {
    reserve_headroom(s.points, first.points.size());
    reserve_headroom(s.rows_cols, first.rows_cols.size());
    reserve_headroom(s.triangles, first.triangles.size());
    reserve_headroom(s.links, first.links.size());
    reserve_headroom(s.velocities, first.velocities.size());
    reserve_headroom(s.loads, first.loads.size());
    reserve_headroom(s.punctured, first.punctured.size());
    // A blade's cut links: at most the layer's links (a charged layer drops a link from `links` as it
    // adds it here), so a wound never grows the copy on the haptic thread.
    reserve_headroom(s.cut_links, first.links.size() + first.cut_links.size());
    s.points = first.points;
    s.rows_cols = first.rows_cols;
    s.triangles = first.triangles;
    s.links = first.links;
    s.velocities = first.velocities;
    s.loads = first.loads;
    s.punctured = first.punctured;
    s.cut_links = first.cut_links;
  }
}

// Out of line: inlined where a unique_ptr<Tissue> dies, GCC 12 warns falsely (-Wfree-nonheap-object).
SnapshotTissue::~SnapshotTissue() = default;

Vec3 SnapshotTissue::step(const ToolState& tool, double dt) noexcept {
  const Vec3 force = inner_->step(tool, dt);
  last_step_ = {tool.time, tool.tip, force, true, tool.axis};
  if (wanted_.load(std::memory_order_relaxed) && wanted_.exchange(false, std::memory_order_acquire)) {
    copy_into_back(last_step_);
  }
  return force;
}

void SnapshotTissue::copy_into_back(const SnapshotStamp& stamp) noexcept {
  TissueSnapshot& s = slots_[back_];
  const size_t caps[8] = {s.points.capacity(),     s.rows_cols.capacity(), s.triangles.capacity(),
                          s.links.capacity(),      s.velocities.capacity(), s.loads.capacity(),
                          s.punctured.capacity(), s.cut_links.capacity()};
  try {
    inner_->snapshot(s);
  } catch (...) {
    // Only an allocation failure can throw here (the slot's capacity was exceeded and memory ran
    // out): keep the previous copy and count it; the haptic thread must go on.
    growths_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  if (s.points.capacity() != caps[0] || s.rows_cols.capacity() != caps[1] ||
      s.triangles.capacity() != caps[2] || s.links.capacity() != caps[3] || s.velocities.capacity() != caps[4] ||
      s.loads.capacity() != caps[5] || s.punctured.capacity() != caps[6] || s.cut_links.capacity() != caps[7]) {
    growths_.fetch_add(1, std::memory_order_relaxed);
  }
  stamps_[back_] = stamp;
  back_ = middle_.exchange(static_cast<std::uint8_t>(back_ | kFresh), std::memory_order_acq_rel) & kIndex;
  published_.fetch_add(1, std::memory_order_relaxed);
}

const TissueSnapshot& SnapshotTissue::latest(bool* fresh) noexcept {
  const bool is_fresh = (middle_.load(std::memory_order_relaxed) & kFresh) != 0;
  if (is_fresh) front_ = middle_.exchange(front_, std::memory_order_acq_rel) & kIndex;
  if (fresh) *fresh = is_fresh;
  return slots_[front_];
}

void SnapshotTissue::publish_now() {
  copy_into_back({});
  wanted_.store(true, std::memory_order_release);
}

void SnapshotTissue::publish_last_step() {
  copy_into_back(last_step_);
  wanted_.store(true, std::memory_order_release);
}

}  // namespace palpate
