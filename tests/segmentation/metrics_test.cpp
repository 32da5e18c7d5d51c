#include <gtest/gtest.h>

#include "test_volumes.hpp"
#include "vellum/segmentation/metrics.hpp"

using namespace vellum;
using namespace vellum::segmentation;
using namespace vellum::segmentation::test;

TEST(Metrics, OverlapByHand) {
  const Geometry g = grid(10, 1, 1, {2, 1, 1});  // voxel = 2 mm³
  Mask a(g, 0, 0.0), b(g, 0, 0.0);
  for (int i = 0; i < 4; ++i) a(i, 0, 0) = 1;      // 0..3
  for (int i = 1; i < 7; ++i) b(i, 0, 0) = 1;      // 1..6
  const OverlapMetrics m = overlap(a, b);
  EXPECT_EQ(m.intersection, 3);
  EXPECT_DOUBLE_EQ(m.dice, 6.0 / 10.0);
  EXPECT_DOUBLE_EQ(m.jaccard, 3.0 / 7.0);
  EXPECT_DOUBLE_EQ(m.volumeMm3, 8.0);
  EXPECT_DOUBLE_EQ(m.truthVolumeMm3, 12.0);
  EXPECT_DOUBLE_EQ(m.volumeDifferenceMm3, -4.0);
  EXPECT_DOUBLE_EQ(m.volumeDifferencePercent, -100.0 / 3.0);
}

TEST(Metrics, SurfaceDistancesByHand) {
  // Two single voxels 3 voxels apart along x, spacing 2 mm: every distance is 6 mm.
  const Geometry g = grid(8, 3, 3, {2, 1, 1});
  Mask a(g, 0, 0.0), b(g, 0, 0.0);
  a(1, 1, 1) = 1;
  b(4, 1, 1) = 1;
  const SegmentMetrics s = compareMasks(a, b);
  EXPECT_DOUBLE_EQ(s.dice, 0.0);
  EXPECT_NEAR(s.hd95Mm, 6.0, 1e-6);
  EXPECT_NEAR(s.hausdorffMm, 6.0, 1e-6);
  EXPECT_NEAR(s.meanSurfaceDistanceMm, 6.0, 1e-6);
}

TEST(Metrics, Hd95IgnoresTheWorstFivePercent) {
  // A: a 40x40 slab one voxel thick; B: the same plus one far voxel. A->B distances are all 0;
  // B->A: 1600 zeros and one 20 mm outlier: HD95 = 0 but Hausdorff = 20 mm.
  const Geometry g = grid(40, 40, 30);
  Mask a(g, 0, 0.0);
  fillBox(a, {0, 0, 5}, {39, 39, 5});
  Mask b = a;
  b(20, 20, 25) = 1;
  const SegmentMetrics s = compareMasks(b, a);
  EXPECT_NEAR(s.hd95Mm, 0.0, 1e-6);
  EXPECT_NEAR(s.hausdorffMm, 20.0, 1e-6);
}

TEST(Metrics, EmptyCases) {
  const Geometry g = grid(4, 4, 4);
  Mask a(g, 0, 0.0), b(g, 0, 0.0);
  EXPECT_DOUBLE_EQ(compareMasks(a, b).dice, 1.0);
  EXPECT_DOUBLE_EQ(compareMasks(a, b).hd95Mm, 0.0);
  b(1, 1, 1) = 1;
  EXPECT_DOUBLE_EQ(compareMasks(a, b).dice, 0.0);
  EXPECT_TRUE(std::isinf(compareMasks(a, b).hd95Mm));
}

TEST(Metrics, PerLabel) {
  const Geometry g = grid(6, 1, 1);
  VolumeU16 seg(g, 0, 0.0), truth(g, 0, 0.0);
  const uint16_t s[6] = {1, 1, 2, 2, 0, 3};
  const uint16_t t[6] = {1, 1, 1, 2, 2, 0};
  for (int i = 0; i < 6; ++i) { seg(i, 0, 0) = s[i]; truth(i, 0, 0) = t[i]; }
  const auto m = compareLabels(seg, truth);
  ASSERT_EQ(m.size(), 3u);
  EXPECT_EQ(m[0].id, 1);
  EXPECT_DOUBLE_EQ(m[0].dice, 2.0 * 2 / 5);
  EXPECT_DOUBLE_EQ(m[1].dice, 2.0 * 1 / 4);
  EXPECT_DOUBLE_EQ(m[2].dice, 0.0);
}
