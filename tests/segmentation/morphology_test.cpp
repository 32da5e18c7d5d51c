#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "test_volumes.hpp"
#include "vellum/core/distance_transform.hpp"
#include "vellum/segmentation/metrics.hpp"
#include "vellum/segmentation/morphology.hpp"

using namespace vellum;
using namespace vellum::segmentation;
using namespace vellum::segmentation::test;

TEST(DistanceTransform, MatchesBruteForceWithAnisotropicSpacing) {
  const Geometry g = grid(13, 9, 7, {0.7, 1.3, 2.5});
  Mask m(g, 0, 0.0);
  std::mt19937 rng(3);
  for (int n = 0; n < 6; ++n) m(rng() % 13, rng() % 9, rng() % 7) = 1;
  const VolumeF32 d2 = squaredDistanceMm(m);
  for (int64_t k = 0; k < 7; ++k)
    for (int64_t j = 0; j < 9; ++j)
      for (int64_t i = 0; i < 13; ++i) {
        double best = 1e30;
        for (int64_t c = 0; c < 7; ++c)
          for (int64_t b = 0; b < 9; ++b)
            for (int64_t a = 0; a < 13; ++a)
              if (m(a, b, c)) {
                const double dx = (i - a) * 0.7, dy = (j - b) * 1.3, dz = (k - c) * 2.5;
                best = std::min(best, dx * dx + dy * dy + dz * dz);
              }
        EXPECT_NEAR(d2(i, j, k), best, 1e-3 * (1 + best)) << i << "," << j << "," << k;
      }
}

namespace {
// Squared mm distance from voxel (i, j, k) to the nearest voxel with m == want (brute force).
double bruteD2(const Mask& m, int64_t i, int64_t j, int64_t k, uint8_t want) {
  const Geometry& g = m.geometry();
  double best = std::numeric_limits<double>::infinity();
  for (int64_t c = 0; c < g.dims.z; ++c)
    for (int64_t b = 0; b < g.dims.y; ++b)
      for (int64_t a = 0; a < g.dims.x; ++a)
        if ((m(a, b, c) != 0) == (want != 0)) {
          const double dx = (i - a) * g.spacing.x, dy = (j - b) * g.spacing.y, dz = (k - c) * g.spacing.z;
          best = std::min(best, dx * dx + dy * dy + dz * dz);
        }
  return best;
}

Mask randomBlobs(const Geometry& g, unsigned seed) {
  Mask m(g, 0, 0.0);
  std::mt19937 rng(seed);
  for (int n = 0; n < 40; ++n) {
    const int64_t i = rng() % g.dims.x, j = rng() % g.dims.y, k = rng() % g.dims.z, r = rng() % 3;
    for (int64_t c = std::max<int64_t>(0, k - r); c <= std::min(g.dims.z - 1, k + r); ++c)
      for (int64_t b = std::max<int64_t>(0, j - r); b <= std::min(g.dims.y - 1, j + r); ++b)
        for (int64_t a = std::max<int64_t>(0, i - r); a <= std::min(g.dims.x - 1, i + r); ++a) m(a, b, c) = 1;
  }
  return m;
}
}  // namespace

// Wider than one gathered block of columns (16) and not a multiple of it; the capped distance
// used by morphology must give exactly the brute-force ball operations.
TEST(DistanceTransform, BlocksCapsAndSignedDistanceMatchBruteForce) {
  const Geometry g = grid(37, 23, 11, {0.6, 1.1, 1.9});
  const Mask m = randomBlobs(g, 7);
  const VolumeF32 d2 = squaredDistanceMm(m);
  const VolumeF32 sd = signedDistanceMm(m);
  const Mask dil = dilate(m, 2.5), ero = erode(m, 1.5);
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i) {
        const double toIn = bruteD2(m, i, j, k, 1), toOut = bruteD2(m, i, j, k, 0);
        ASSERT_NEAR(d2(i, j, k), toIn, 1e-3 * (1 + toIn)) << i << "," << j << "," << k;
        const double signedBrute = m(i, j, k) ? -std::sqrt(toOut) : std::sqrt(toIn);
        ASSERT_NEAR(sd(i, j, k), signedBrute, 1e-3 * (1 + std::abs(signedBrute)));
        ASSERT_EQ(dil(i, j, k), toIn <= 2.5 * 2.5 + 1e-6 ? 1 : 0) << i << "," << j << "," << k;
        ASSERT_EQ(ero(i, j, k), m(i, j, k) && toOut > 1.5 * 1.5 + 1e-6 ? 1 : 0) << i << "," << j << "," << k;
      }
}

TEST(DistanceTransform, EmptyMaskIsInfinite) {
  const Mask m(grid(4, 4, 4), 0, 0.0);
  EXPECT_TRUE(std::isinf(squaredDistanceMm(m)(1, 2, 3)));
}

TEST(Morphology, DilatingOneVoxelGivesABallInMillimetres) {
  const Geometry g = grid(31, 21, 11, {0.5, 0.8, 1.6});
  Mask m(g, 0, 0.0);
  m(15, 10, 5) = 1;
  const Mask d = dilate(m, 4.0);
  for (int64_t k = 0; k < 11; ++k)
    for (int64_t j = 0; j < 21; ++j)
      for (int64_t i = 0; i < 31; ++i) {
        const double dx = (i - 15) * 0.5, dy = (j - 10) * 0.8, dz = (k - 5) * 1.6;
        EXPECT_EQ(d(i, j, k), dx * dx + dy * dy + dz * dz <= 16.0 + 1e-9 ? 1 : 0);
      }
}

// A sphere stays a sphere in mm under anisotropic spacing: dilating a 10 mm sphere by 3 mm
// gives the 13 mm sphere, eroding by 3 mm the 7 mm one, and open/close change nothing.
TEST(Morphology, SphereStaysASphereWithAnisotropicSpacing) {
  const Geometry g = grid(80, 60, 30, {0.5, 0.7, 1.5});
  const Vec3 c = centreMm(g);
  const Mask s10 = sphereMask(g, c, 10);
  // (Voxelised spheres differ from Minkowski sums of voxelised spheres by about one voxel at
  // the rim; an index-space ball on this grid scores ~0.6.)
  EXPECT_GT(overlap(dilate(s10, 3.0), sphereMask(g, c, 13)).dice, 0.97);
  EXPECT_GT(overlap(erode(s10, 3.0), sphereMask(g, c, 7)).dice, 0.97);
  EXPECT_GT(overlap(close(s10, 3.0), s10).dice, 0.995);
  EXPECT_GT(overlap(open(s10, 3.0), s10).dice, 0.98);
  // Each axis in mm: the dilated sphere's extent along x and z is 2*13 mm (within a voxel).
  const Mask d = dilate(s10, 3.0);
  int64_t ix0 = 1000, ix1 = -1, kz0 = 1000, kz1 = -1;
  for (int64_t k = 0; k < 30; ++k)
    for (int64_t j = 0; j < 60; ++j)
      for (int64_t i = 0; i < 80; ++i)
        if (d(i, j, k)) {
          ix0 = std::min(ix0, i); ix1 = std::max(ix1, i);
          kz0 = std::min(kz0, k); kz1 = std::max(kz1, k);
        }
  EXPECT_NEAR((ix1 - ix0) * 0.5, 26.0, 1.0);
  EXPECT_NEAR((kz1 - kz0) * 1.5, 26.0, 3.0);
}

TEST(Morphology, OpeningRemovesThinPartsClosingFillsNarrowGaps) {
  const Geometry g = grid(40, 20, 20);
  Mask m(g, 0, 0.0);
  fillBox(m, {2, 4, 4}, {15, 15, 15});
  fillBox(m, {24, 4, 4}, {37, 15, 15});
  fillBox(m, {16, 9, 9}, {23, 9, 9});  // a 1-voxel bridge
  const Mask o = open(m, 2.0);
  EXPECT_EQ(o(20, 9, 9), 0);
  EXPECT_EQ(o(8, 9, 9), 1);
  Mask gap(g, 0, 0.0);
  fillBox(gap, {2, 4, 4}, {18, 15, 15});
  fillBox(gap, {21, 4, 4}, {37, 15, 15});  // two-voxel gap
  const Mask cl = close(gap, 2.0);
  EXPECT_EQ(cl(19, 9, 9), 1);
  EXPECT_EQ(cl(20, 9, 9), 1);
  // Structures cut by the grid border keep their cut face under closing.
  Mask edge(g, 0, 0.0);
  fillBox(edge, {0, 0, 0}, {39, 19, 5});
  EXPECT_EQ(countVoxels(close(edge, 3.0)), countVoxels(edge));
}
