// test_primitives.cpp — the lock-free pieces under the loop: the triple buffer, the SPSC ring and
// the latency histogram, each checked under real concurrency (and ThreadSanitizer).
#include "haptics/histogram.h"
#include "haptics/spsc_ring.h"
#include "haptics/triple_buffer.h"

#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <thread>

TEST(TripleBuffer, ReaderSeesOnlyWholeValuesNewestFirst) {
  struct Value {
    std::uint64_t seq = 0;
    std::array<std::uint64_t, 32> payload{};  // every entry equals seq when whole
  };
  palpate::TripleBuffer<Value> tb;
  constexpr std::uint64_t kN = 200000;
  std::thread writer([&] {
    for (std::uint64_t i = 1; i <= kN; ++i) {
      Value& v = tb.write_slot();
      v.seq = i;
      v.payload.fill(i);
      tb.publish();
    }
  });
  std::uint64_t last = 0, updates = 0;
  while (last < kN) {
    if (tb.update()) ++updates;
    const Value& v = tb.read();
    for (std::uint64_t p : v.payload) ASSERT_EQ(p, v.seq);
    ASSERT_GE(v.seq, last);
    last = v.seq;
  }
  writer.join();
  EXPECT_EQ(last, kN);
  EXPECT_GT(updates, 0u);
  EXPECT_FALSE(tb.update());  // nothing newer after the last value was taken
}

TEST(RecorderRing, SpscKeepsEveryRowInOrder) {
  palpate::SpscRing<double> ring(64, 4);
  EXPECT_EQ(ring.capacity(), 64u);
  constexpr int kN = 300000;
  std::thread producer([&] {
    for (int i = 0; i < kN; ++i) {
      const double row[4] = {double(i), 2.0 * i, -double(i), 0.5};
      while (!ring.try_push(row)) std::this_thread::yield();
    }
  });
  int expect = 0;
  while (expect < kN) {
    auto row = ring.front();
    if (row.empty()) {
      std::this_thread::yield();
      continue;
    }
    ASSERT_EQ(row[0], double(expect));
    ASSERT_EQ(row[1], 2.0 * expect);
    ASSERT_EQ(row[2], -double(expect));
    ring.pop();
    ++expect;
  }
  producer.join();
  EXPECT_TRUE(ring.front().empty());
  // Full: a push fails rather than overwriting.
  palpate::SpscRing<double> small(2, 1);
  const double one[1] = {1};
  EXPECT_TRUE(small.try_push(one));
  EXPECT_TRUE(small.try_push(one));
  EXPECT_FALSE(small.try_push(one));
}

TEST(HapticHistogram, PercentilesWithinABucketAndExactMax) {
  palpate::LatencyHistogram h;
  for (int i = 1; i <= 1000; ++i) h.add(i * 1e-6);  // 1 µs .. 1 ms uniformly
  EXPECT_EQ(h.count(), 1000u);
  EXPECT_NEAR(h.percentile(0.5), 500e-6, 500e-6 * 0.02);
  EXPECT_NEAR(h.percentile(0.99), 990e-6, 990e-6 * 0.02);
  EXPECT_EQ(h.max(), 1000e-6);
  EXPECT_LE(h.percentile(1.0), h.max());
  // Bucket edges are contiguous and increasing.
  for (int i = 1; i < palpate::LatencyHistogram::kBuckets; ++i)
    ASSERT_LT(palpate::LatencyHistogram::lower(i - 1), palpate::LatencyHistogram::lower(i)) << i;
  for (std::uint64_t ns : {0ull, 63ull, 64ull, 127ull, 128ull, 1000ull, 999999ull, 1000000000ull}) {
    const int i = palpate::LatencyHistogram::index(ns);
    EXPECT_LE(palpate::LatencyHistogram::lower(i), double(ns)) << ns;
    EXPECT_GT(palpate::LatencyHistogram::lower(i + 1), double(ns)) << ns;
  }
}
