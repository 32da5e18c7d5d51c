#include <gtest/gtest.h>

#include "vellum/core/label_volume.hpp"
#include "vellum/core/volume.hpp"

using namespace vellum;

namespace {
VolumeF32 ramp() {
  Geometry g;
  g.dims = {4, 3, 2};
  VolumeF32 v(g, 0.f, -1000.0);
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 4; ++i) v(i, j, k) = static_cast<float>(i + 10 * j + 100 * k);
  return v;
}
}  // namespace

TEST(Volume, MemoryLayoutXFastest) {
  VolumeF32 v = ramp();
  EXPECT_EQ(v.data()[1], 1.f);
  EXPECT_EQ(v.data()[4], 10.f);
  EXPECT_EQ(v.data()[12], 100.f);
}

TEST(Volume, TrilinearReproducesLinearFunctionInside) {
  VolumeF32 v = ramp();
  EXPECT_DOUBLE_EQ(v.sampleLinear({1.25, 0.5, 0.75}), 1.25 + 5 + 75);
  EXPECT_DOUBLE_EQ(v.sampleLinear({3, 2, 1}), 3 + 20 + 100);  // last voxel centre, exact
}

TEST(Volume, OutsideGivesBackgroundNeverClamp) {
  VolumeF32 v = ramp();
  EXPECT_EQ(v.sampleLinear({-1.0, 1, 1}), -1000.0);
  EXPECT_EQ(v.sampleLinear({4.0, 1, 0}), -1000.0);
  // Half a voxel beyond the last centre the value is halfway to the background.
  EXPECT_DOUBLE_EQ(v.sampleLinear({3.5, 0, 0}), 0.5 * 3 + 0.5 * -1000.0);
  EXPECT_EQ(v.sampleNearest({-0.6, 0, 0}), -1000.0);
  EXPECT_EQ(v.sampleNearest({-0.4, 0, 0}), 0.0);
  EXPECT_EQ(v.sampleNearest({3.49, 2.2, 0.9}), 3 + 20 + 100);
}

TEST(Volume, SampleInMillimetresUsesGeometry) {
  VolumeF32 v = ramp();
  Geometry g = v.geometry();
  g.spacing = {2, 2, 2};
  g.origin = {10, 0, 0};
  v.setGeometry(g);
  EXPECT_DOUBLE_EQ(v.sampleLinearMm({13, 2, 0}), 1.5 + 10);
}

TEST(Volume, ValueRangeAndConversionSaturates) {
  Geometry g;
  g.dims = {3, 1, 1};
  VolumeF32 f(g);
  f(0, 0, 0) = -5000.4f;
  f(1, 0, 0) = 12.6f;
  f(2, 0, 0) = 70000.f;
  auto [lo, hi] = f.valueRange();
  EXPECT_FLOAT_EQ(lo, -5000.4f);
  EXPECT_FLOAT_EQ(hi, 70000.f);
  VolumeI16 s = toInt16(AnyVolume(f));
  EXPECT_EQ(s(0, 0, 0), -5000);
  EXPECT_EQ(s(1, 0, 0), 13);
  EXPECT_EQ(s(2, 0, 0), 32767);
  VolumeU8 u = convertVolume<uint8_t>(AnyVolume(f));
  EXPECT_EQ(u(0, 0, 0), 0);
  EXPECT_EQ(u(2, 0, 0), 255);
}

TEST(Volume, AnyVolumeAccessors) {
  AnyVolume a = ramp();
  EXPECT_EQ(voxelTypeOf(a), VoxelType::Float32);
  EXPECT_EQ(geometryOf(a).dims, (Dims{4, 3, 2}));
  EXPECT_EQ(backgroundOf(a), -1000.0);
  EXPECT_EQ(parseVoxelType("short"), VoxelType::Int16);
  EXPECT_THROW(parseVoxelType("complex"), Error);
}

TEST(LabelVolume, TableAndHistogram) {
  Geometry g;
  g.dims = {2, 2, 1};
  LabelVolume lv(g);
  lv(0, 0, 0) = 3;
  lv(1, 0, 0) = 3;
  lv(0, 1, 0) = 1;
  lv.setLabel({3, "bone", {255, 255, 255}});
  lv.setLabel({1, "skin", {200, 150, 120}});
  lv.setLabel({3, "cortical bone", {250, 250, 240}});
  ASSERT_EQ(lv.table().size(), 2u);
  EXPECT_EQ(lv.table()[0].id, 1);
  EXPECT_EQ(lv.label(3)->name, "cortical bone");
  EXPECT_FALSE(lv.label(2));
  EXPECT_EQ(lv.nextFreeId(), 2);
  EXPECT_EQ(lv.maxId(), 3);
  EXPECT_EQ(lv.histogram(), (std::vector<uint64_t>{1, 1, 0, 2}));
  EXPECT_NE(defaultLabelColor(1), defaultLabelColor(2));
}
