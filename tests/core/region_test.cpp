// Crop and downsample on load: geometry stays exact, intensities average, labels never do.
#include <gtest/gtest.h>

#include <cmath>

#include "vellum/core/error.hpp"
#include "vellum/core/region.hpp"

using namespace vellum;

namespace {

Geometry obliqueGeometry(Dims d) {
  Geometry g;
  g.dims = d;
  g.spacing = {0.5, 0.75, 2.0};
  g.origin = {-10, 20, 5};
  const double c = std::cos(0.3), s = std::sin(0.3);
  g.direction = Mat3::fromColumns({c, s, 0}, {-s, c, 0}, {0, 0, 1});
  return g;
}

// Voxel value = a linear function of its index: block means are exact at block centres.
VolumeF32 ramp(const Geometry& g) {
  VolumeF32 v(g, 0.f);
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i) v(i, j, k) = float(i + 10 * j + 100 * k);
  return v;
}

}  // namespace

TEST(Region, CropKeepsEveryVoxelWhereItWas) {
  const Geometry g = obliqueGeometry({20, 16, 12});
  const VolumeF32 v = ramp(g);
  const VoxelBox box{{3, 2, 1}, {10, 9, 7}};
  const auto c = std::get<VolumeF32>(cropVolume(v, box));
  EXPECT_EQ(c.dims(), (Dims{8, 8, 7}));
  for (int64_t k = 0; k < 7; ++k)
    for (int64_t i = 0; i < 8; ++i) {
      EXPECT_EQ(c(i, 4, k), v(i + 3, 6, k + 1));
      const Vec3 a = c.geometry().indexToPhysical({double(i), 4, double(k)});
      const Vec3 b = g.indexToPhysical({double(i + 3), 6, double(k + 1)});
      EXPECT_LT(norm(a - b), 1e-9);
    }
}

TEST(Region, DownsampleMeanPutsEachVoxelAtItsBlockCentre) {
  const Geometry g = obliqueGeometry({8, 8, 8});
  const VolumeF32 v = ramp(g);
  const auto d = std::get<VolumeF32>(downsampleMean(v, 2));
  EXPECT_EQ(d.dims(), (Dims{4, 4, 4}));
  EXPECT_DOUBLE_EQ(d.geometry().spacing.x, 1.0);
  for (int64_t k = 0; k < 4; ++k)
    for (int64_t j = 0; j < 4; ++j)
      for (int64_t i = 0; i < 4; ++i) {
        // Mean of a linear ramp over a 2x2x2 block = its value at the block centre.
        const Vec3 centreIndex{2 * i + 0.5, 2 * j + 0.5, 2 * k + 0.5};
        EXPECT_FLOAT_EQ(d(i, j, k), float(centreIndex.x + 10 * centreIndex.y + 100 * centreIndex.z));
        const Vec3 p = d.geometry().indexToPhysical({double(i), double(j), double(k)});
        EXPECT_LT(norm(p - g.indexToPhysical(centreIndex)), 1e-9);
      }
}

TEST(Region, LabelsTakeTheMostFrequentIdNeverAnAverage) {
  Geometry g;
  g.dims = {4, 2, 2};
  VolumeU16 ids(g, 0);
  // Block 0 (i 0..1): six voxels of 7, two of 1 -> 7 (an average would give a new id, 5.5).
  for (int64_t k = 0; k < 2; ++k)
    for (int64_t j = 0; j < 2; ++j) ids(0, j, k) = ids(1, j, k) = 7;
  ids(0, 0, 0) = ids(1, 1, 1) = 1;
  // Block 1 (i 2..3): a tie 4 vs 3 between ids 2 and 9 -> the smaller id.
  for (int64_t k = 0; k < 2; ++k)
    for (int64_t j = 0; j < 2; ++j) ids(2, j, k) = 2, ids(3, j, k) = 9;
  const VolumeU16 d = downsampleMode(ids, 2);
  ASSERT_EQ(d.dims(), (Dims{2, 1, 1}));
  EXPECT_EQ(d(0, 0, 0), 7);
  EXPECT_EQ(d(1, 0, 0), 2);
}

TEST(Region, MillimetreBoxSelectsTheVoxelCentresInside) {
  Geometry g;
  g.dims = {10, 10, 10};
  g.spacing = {2, 2, 2};
  Region r;
  r.cropMm = {{Vec3{3.0, 0.0, 17.5}, Vec3{9.0, 4.0, 4.0}}};  // corners in any order
  const VoxelBox b = regionBox(g, r);
  EXPECT_EQ(b.lo, (std::array<int64_t, 3>{2, 0, 2}));  // x 3..9 mm -> centres 4, 6, 8
  EXPECT_EQ(b.hi, (std::array<int64_t, 3>{4, 2, 8}));
  const auto v = applyRegion(VolumeI16(g, -1000), r);
  EXPECT_EQ(geometryOf(v).dims, (Dims{3, 3, 7}));
}

TEST(Region, BadRegionsAreClearErrors) {
  Geometry g;
  g.dims = {10, 10, 10};
  Region r;
  r.cropVoxels = VoxelBox{{0, 0, 0}, {10, 5, 5}};
  EXPECT_THROW(applyRegion(VolumeI16(g, 0), r), Error);
  r.cropVoxels = VoxelBox{{5, 0, 0}, {4, 5, 5}};
  EXPECT_THROW(applyRegion(VolumeI16(g, 0), r), Error);
  Region d;
  d.downsample = 17;
  EXPECT_THROW(applyRegion(VolumeI16(g, 0), d), Error);
}
