// test_view_ultrasound.cpp — the viewer's live ultrasound feed (apps/palpate/view/ultrasound_feed.*):
// images rendered off the GUI thread at their rate from the poses it is handed, taken once each.
#include <gtest/gtest.h>

// The viewer's parts are compiled into the tests directly (they are not in the library).
#include "../apps/palpate/view/ultrasound_feed.cpp"

#include <palpate/scene_def.h>

#include <atomic>
#include <chrono>
#include <thread>

namespace {

using palpate::Vec3;

TEST(ViewUltrasoundFeed, RendersAtItsRateFromTheGivenPosesAndHandsEachImageOverOnce) {
  const palpate::NeckDef neck;
  const palpate::ProbeDef probe;
  std::atomic<int> asked{0};
  palpate::UltrasoundImage img;
  std::uint64_t rendered = 0;
  {
    palpate::view::UltrasoundFeed feed(
        neck, probe,
        [&](palpate::ProbePose& p, palpate::NeedlePose& n) {
          ++asked;
          p.position = Vec3(0, -0.0026, 0);  // resting on the skin over the vein
          n.present = false;
        },
        50.0);
    const auto start = std::chrono::steady_clock::now();
    while (feed.rendered() < 3 && std::chrono::steady_clock::now() - start < std::chrono::seconds(20))
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    ASSERT_GE(feed.rendered(), 3u);
    ASSERT_TRUE(feed.take(img));
    EXPECT_FALSE(feed.take(img)) << "each image is handed over once";
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    rendered = feed.rendered();
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_LE(double(rendered), elapsed * 50.0 + 2) << "no faster than its rate";
  }
  EXPECT_EQ(img.width, probe.image_width);
  EXPECT_EQ(img.height, probe.image_height);
  EXPECT_EQ(img.grey.size(), size_t(probe.image_width) * size_t(probe.image_height));
  EXPECT_TRUE(img.in_contact);
  EXPECT_GE(asked.load(), int(rendered));
}

}  // namespace
