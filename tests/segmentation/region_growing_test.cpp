#include <gtest/gtest.h>

#include "test_volumes.hpp"
#include "vellum/segmentation/region_growing.hpp"

using namespace vellum;
using namespace vellum::segmentation;
using namespace vellum::segmentation::test;

// Two 100-HU boxes separated by one voxel of air; only the seeded one grows.
TEST(RegionGrowing, StaysInsideTheSeededRegion) {
  VolumeI16 ct(grid(20, 10, 10, {0.5, 1, 2}), -1000, kCtAirHu);
  for (int64_t k = 2; k < 8; ++k)
    for (int64_t j = 2; j < 8; ++j) {
      for (int64_t i = 2; i < 9; ++i) ct(i, j, k) = 100;
      for (int64_t i = 10; i < 18; ++i) ct(i, j, k) = 100;
    }
  const Vec3 seed = ct.geometry().indexToPhysical({4, 4, 4});
  const Mask m = connectedThreshold(ct, {seed}, {50, 150});
  EXPECT_EQ(countVoxels(m), 7 * 6 * 6);
  EXPECT_EQ(m(9, 4, 4), 0);
  EXPECT_EQ(m(12, 4, 4), 0);
  // 26-connectivity does not jump a full voxel gap either.
  EXPECT_EQ(countVoxels(connectedThreshold(ct, {seed}, {50, 150}, Connectivity::Vertex26)), 7 * 6 * 6);
  // Two seeds take both boxes.
  const Vec3 seed2 = ct.geometry().indexToPhysical({12, 4, 4});
  EXPECT_EQ(countVoxels(connectedThreshold(ct, {seed, seed2}, {50, 150})), 7 * 6 * 6 + 8 * 6 * 6);
}

TEST(RegionGrowing, DiagonalContactNeeds26Connectivity) {
  VolumeI16 ct(grid(4, 4, 4), -1000, kCtAirHu);
  ct(1, 1, 1) = 100;
  ct(2, 2, 2) = 100;
  const Vec3 seed{1, 1, 1};
  EXPECT_EQ(countVoxels(connectedThreshold(ct, {seed}, {0, 200}, Connectivity::Face6)), 1);
  EXPECT_EQ(countVoxels(connectedThreshold(ct, {seed}, {0, 200}, Connectivity::Edge18)), 1);
  EXPECT_EQ(countVoxels(connectedThreshold(ct, {seed}, {0, 200}, Connectivity::Vertex26)), 2);
}

TEST(RegionGrowing, SeedOutsideTheGridIsAnError) {
  VolumeI16 ct(grid(4, 4, 4), 0, kCtAirHu);
  EXPECT_THROW(connectedThreshold(ct, {{100, 0, 0}}, {0, 1}), Error);
}

TEST(RegionGrowing, HugeRegionDoesNotRecurse) {
  // 2M voxels all inside: a recursive fill would overflow the stack.
  VolumeI16 ct(grid(128, 128, 128), 0, kCtAirHu);
  EXPECT_EQ(countVoxels(connectedThreshold(ct, {{0, 0, 0}}, {-10, 10})), 128 * 128 * 128);
}

TEST(ConfidenceConnected, GrowsTheNoisyBlobAndNotTheBackground) {
  const Geometry g = grid(40, 40, 40);
  VolumeI16 ct(g, 0, kCtAirHu);
  const Vec3 c = centreMm(g);
  for (int64_t k = 0; k < 40; ++k)
    for (int64_t j = 0; j < 40; ++j)
      for (int64_t i = 0; i < 40; ++i) {
        const bool in = norm(g.indexToPhysical({double(i), double(j), double(k)}) - c) <= 12;
        const int noise = static_cast<int>((i * 7 + j * 13 + k * 29) % 21) - 10;  // +-10 HU
        ct(i, j, k) = static_cast<int16_t>((in ? 300 : 0) + noise);
      }
  const ConfidenceResult r = confidenceConnected(ct, {c}, {});
  const Mask truth = sphereMask(g, c, 12);
  EXPECT_EQ(countVoxels(r.mask), countVoxels(truth));
  EXPECT_NEAR(r.mean, 300, 3);
  EXPECT_GT(r.finalInterval.lower, 100);
  EXPECT_LT(r.finalInterval.upper, 500);
}
