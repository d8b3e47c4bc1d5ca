// triple_buffer.h — TripleBuffer<T>: a lock-free, wait-free exchange of the latest value between
// one writer thread and one reader thread; neither ever blocks nor waits for the other.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>

namespace palpate {

// Three slots: the writer fills its back slot and swaps it with the shared middle one; the
// reader swaps its front slot with the middle one when the middle holds something newer. The
// writer may publish many times between reads: the reader always sees the newest complete value
// (values in between are dropped, which is what a render or physics snapshot wants).
// T is copied only where the caller copies it: fill write_slot() in place to avoid allocation.
template <class T>
class TripleBuffer {
 public:
  TripleBuffer() = default;
  explicit TripleBuffer(const T& init) { slots_.fill(init); }
  // Set every slot (set-up only: before the two threads start).
  void fill(const T& value) { slots_.fill(value); }

  // Writer side: the slot to fill, then publish() it.
  T& write_slot() noexcept { return slots_[back_]; }
  void publish() noexcept {
    back_ = middle_.exchange(static_cast<std::uint8_t>(back_ | kFresh), std::memory_order_acq_rel) & kIndex;
  }

  // Reader side: swap in the newest published value if there is one; true when it is new.
  bool update() noexcept {
    if (!(middle_.load(std::memory_order_relaxed) & kFresh)) return false;
    front_ = middle_.exchange(front_, std::memory_order_acq_rel) & kIndex;
    return true;
  }
  // The reader's current value (the newest as of the last update()).
  const T& read() const noexcept { return slots_[front_]; }
  T& read_mut() noexcept { return slots_[front_]; }

 private:
  static constexpr std::uint8_t kFresh = 0x4, kIndex = 0x3;
  std::array<T, 3> slots_{};
  alignas(64) std::atomic<std::uint8_t> middle_{1};
  alignas(64) std::uint8_t back_ = 0;   // owned by the writer
  alignas(64) std::uint8_t front_ = 2;  // owned by the reader
};

}  // namespace palpate
