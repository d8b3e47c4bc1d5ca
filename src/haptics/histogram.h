// histogram.h — LatencyHistogram: durations in log-linear buckets (about 1.6 % wide), written by
// one thread and read live by any other, for median / p99 / max without storing samples.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>

namespace palpate {

// Bucket layout (as in HdrHistogram): values below 64 ns have a bucket each; above, every power
// of two is split into 64 sub-buckets. Covers 1 ns .. 2^40 ns (18 minutes). One writer: add()
// uses relaxed load+store, not read-modify-write, so it costs no bus lock; readers may see a
// count one tick stale, never a torn one.
class LatencyHistogram {
 public:
  static constexpr int kSub = 64;
  static constexpr int kBuckets = kSub * 36;

  void add(double seconds) noexcept {
    const double ns_d = seconds * 1e9;
    const std::uint64_t ns = ns_d <= 0 ? 0 : ns_d >= 1e12 ? std::uint64_t(1e12) : std::uint64_t(ns_d);
    auto& b = buckets_[static_cast<size_t>(index(ns))];
    b.store(b.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
    count_.store(count_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
    if (seconds > max_.load(std::memory_order_relaxed)) max_.store(seconds, std::memory_order_relaxed);
  }
  std::uint64_t count() const noexcept { return count_.load(std::memory_order_relaxed); }
  double max() const noexcept { return max_.load(std::memory_order_relaxed); }
  // The value (s) below which a fraction p of the samples lie, to the bucket's midpoint.
  double percentile(double p) const noexcept {
    std::uint64_t total = 0;
    for (const auto& b : buckets_) total += b.load(std::memory_order_relaxed);
    if (total == 0) return 0;
    const double want = p * double(total);
    std::uint64_t seen = 0;
    for (int i = 0; i < kBuckets; ++i) {
      seen += buckets_[static_cast<size_t>(i)].load(std::memory_order_relaxed);
      if (double(seen) >= want && seen > 0) {
        const double mid = 0.5 * (lower(i) + lower(i + 1)) * 1e-9;
        const double m = max();
        return mid < m ? mid : m;  // never above the exact maximum
      }
    }
    return max();
  }

  static int index(std::uint64_t ns) noexcept {
    if (ns < kSub) return static_cast<int>(ns);
    const int e = 63 - __builtin_clzll(ns) - 6;  // ns >> e lies in [64, 128)
    const int i = e * kSub + static_cast<int>(ns >> e);
    return i < kBuckets ? i : kBuckets - 1;
  }
  static double lower(int i) noexcept {  // smallest ns of bucket i
    if (i < kSub) return i;
    const int e = i / kSub - 1;
    return double(std::uint64_t(i % kSub + kSub) << e);
  }

 private:
  std::array<std::atomic<std::uint64_t>, kBuckets> buckets_{};
  std::atomic<std::uint64_t> count_{0};
  std::atomic<double> max_{0};
};

// The same buckets over raw counts (a time-stamp counter's ticks) for the tick's stage timing,
// where every nanosecond of the timing itself counts: add() is an index, one bucket's relaxed
// increment and a max, no floating point; the total is summed at read time. Counts convert to
// seconds when read (`seconds_per_count`). One writer, any readers (as LatencyHistogram).
class CountHistogram {
 public:
  void add(std::uint64_t count) noexcept {
    auto& b = buckets_[static_cast<size_t>(LatencyHistogram::index(count))];
    b.store(b.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
    if (count > max_.load(std::memory_order_relaxed)) max_.store(count, std::memory_order_relaxed);
  }
  double max(double seconds_per_count) const noexcept {
    return double(max_.load(std::memory_order_relaxed)) * seconds_per_count;
  }
  // Seconds below which a fraction p of the samples lie, to the bucket's midpoint (never above max).
  double percentile(double p, double seconds_per_count) const noexcept {
    std::uint64_t total = 0;
    for (const auto& b : buckets_) total += b.load(std::memory_order_relaxed);
    if (total == 0) return 0;
    const double want = p * double(total);
    std::uint64_t seen = 0;
    const double m = max(seconds_per_count);
    for (int i = 0; i < LatencyHistogram::kBuckets; ++i) {
      seen += buckets_[static_cast<size_t>(i)].load(std::memory_order_relaxed);
      if (double(seen) >= want && seen > 0) {
        const double mid = 0.5 * (LatencyHistogram::lower(i) + LatencyHistogram::lower(i + 1)) * seconds_per_count;
        return mid < m ? mid : m;
      }
    }
    return m;
  }

 private:
  std::array<std::atomic<std::uint64_t>, LatencyHistogram::kBuckets> buckets_{};
  std::atomic<std::uint64_t> max_{0};
};

}  // namespace palpate
