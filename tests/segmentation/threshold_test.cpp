#include <gtest/gtest.h>

#include "test_volumes.hpp"
#include "vellum/segmentation/threshold.hpp"

using namespace vellum;
using namespace vellum::segmentation;
using namespace vellum::segmentation::test;

TEST(Threshold, IntervalIsClosedAndExact) {
  VolumeI16 ct(grid(5, 1, 1), 0, kCtAirHu);
  const int16_t v[5] = {-1000, 99, 100, 200, 201};
  for (int i = 0; i < 5; ++i) ct(i, 0, 0) = v[i];
  const Mask m = threshold(ct, {100, 200});
  EXPECT_EQ(m(0, 0, 0), 0);
  EXPECT_EQ(m(1, 0, 0), 0);
  EXPECT_EQ(m(2, 0, 0), 1);
  EXPECT_EQ(m(3, 0, 0), 1);
  EXPECT_EQ(m(4, 0, 0), 0);
}

TEST(Threshold, PresetsParseAndAreOrdered) {
  for (Preset p : allPresets()) {
    EXPECT_EQ(parsePreset(presetName(p)), p);
    EXPECT_LT(presetInterval(p).lower, presetInterval(p).upper);
  }
  EXPECT_EQ(parsePreset("soft"), Preset::SoftTissue);
  EXPECT_THROW(parsePreset("brain"), Error);
  // Soft tissue and bone meet without overlap.
  EXPECT_LE(presetInterval(Preset::SoftTissue).upper, presetInterval(Preset::Bone).lower);
}

TEST(Otsu, SplitsTwoClustersBetweenThem) {
  VolumeI16 ct(grid(10, 10, 10), 0, kCtAirHu);
  for (size_t i = 0; i < ct.size(); ++i) ct.data()[i] = (i % 3 == 0) ? 1000 : static_cast<int16_t>(i % 7);
  const Histogram h = histogram(ct, {256, -1024, 3071});
  const double t = otsuThreshold(h);
  EXPECT_GT(t, 6);
  EXPECT_LE(t, 1000);
  const Mask m = threshold(ct, {t, 3071});
  for (size_t i = 0; i < ct.size(); ++i) EXPECT_EQ(m.data()[i], i % 3 == 0 ? 1 : 0);
}

TEST(Otsu, MultiOtsuSeparatesThreeClusters) {
  VolumeI16 ct(grid(30, 10, 10), 0, kCtAirHu);
  for (int64_t k = 0; k < 10; ++k)
    for (int64_t j = 0; j < 10; ++j)
      for (int64_t i = 0; i < 30; ++i)
        ct(i, j, k) = static_cast<int16_t>(i < 10 ? -1000 + (i + j) % 5 : (i < 20 ? 40 + (j % 5) : 1400 + (k % 5)));
  const auto t = multiOtsuThresholds(histogram(ct, {256, -1024, 3071}), 3);
  ASSERT_EQ(t.size(), 2u);
  EXPECT_GT(t[0], -996);
  EXPECT_LE(t[0], 40);
  EXPECT_GT(t[1], 44);
  EXPECT_LE(t[1], 1400);
  const VolumeU16 c = classify(ct, t);
  EXPECT_EQ(c(3, 3, 3), 1);
  EXPECT_EQ(c(15, 3, 3), 2);
  EXPECT_EQ(c(25, 3, 3), 3);
  EXPECT_THROW(multiOtsuThresholds(histogram(ct, {256, -1024, 3071}), 9), Error);
}

TEST(Hysteresis, KeepsWeakVoxelsOnlyWhenConnectedToStrong) {
  VolumeI16 ct(grid(12, 3, 3), 0, kCtAirHu);
  // Run A: weak 500s touching a strong 1500; run B: weak only.
  for (int i = 1; i <= 4; ++i) ct(i, 1, 1) = 500;
  ct(2, 1, 1) = 1500;
  for (int i = 7; i <= 10; ++i) ct(i, 1, 1) = 500;
  const Mask m = hysteresis(ct, {{1000, 3071}, {400, 3071}, Connectivity::Face6});
  for (int i = 1; i <= 4; ++i) EXPECT_EQ(m(i, 1, 1), 1) << i;
  for (int i = 7; i <= 10; ++i) EXPECT_EQ(m(i, 1, 1), 0) << i;
  EXPECT_EQ(countVoxels(m), 4);
}
