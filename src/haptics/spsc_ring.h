// spsc_ring.h — SpscRing<T>: a lock-free single-producer single-consumer ring of fixed-width
// records (rows of `stride` T's), sized once; the haptic thread pushes, a writer thread pops.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstring>
#include <span>
#include <algorithm>
#include <type_traits>
#include <vector>

namespace palpate {

// Capacity is rounded up to a power of two. Head and tail are free-running counters on separate
// cache lines; the producer publishes a row with a release store, the consumer takes it with an
// acquire load, so the row's doubles are complete when seen. push/pop never allocate.
template <class T>
class SpscRing {
  static_assert(std::is_trivially_copyable_v<T>);


 public:
  SpscRing(size_t capacity_rows, size_t stride) : stride_(stride) {
    size_t cap = 1;
    while (cap < capacity_rows) cap <<= 1;
    mask_ = cap - 1;
    data_.assign(cap * stride_, T{});
  }
  size_t stride() const { return stride_; }
  size_t capacity() const { return mask_ + 1; }

  // Producer: copy a row in; false (and nothing written) when the ring is full.
  bool try_push(std::span<const T> row) noexcept {
    const size_t head = head_.load(std::memory_order_relaxed);
    if (head - tail_cache_ > mask_) {
      tail_cache_ = tail_.load(std::memory_order_acquire);
      if (head - tail_cache_ > mask_) return false;
    }
    std::memcpy(&data_[(head & mask_) * stride_], row.data(),
                std::min(row.size(), stride_) * sizeof(T));
    head_.store(head + 1, std::memory_order_release);
    return true;
  }

  // Consumer: the oldest row, or an empty span when none; pop() it once used.
  std::span<const T> front() noexcept {
    const size_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_cache_) {
      head_cache_ = head_.load(std::memory_order_acquire);
      if (tail == head_cache_) return {};
    }
    return {&data_[(tail & mask_) * stride_], stride_};
  }
  void pop() noexcept { tail_.store(tail_.load(std::memory_order_relaxed) + 1, std::memory_order_release); }

 private:
  size_t stride_;
  size_t mask_ = 0;
  std::vector<T> data_;  // capacity × stride
  alignas(64) std::atomic<size_t> head_{0};
  alignas(64) size_t tail_cache_ = 0;  // producer's last view of tail_
  alignas(64) std::atomic<size_t> tail_{0};
  alignas(64) size_t head_cache_ = 0;  // consumer's last view of head_
};

}  // namespace palpate
