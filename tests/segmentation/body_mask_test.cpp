// --remove-table: the CT table and its pads go, every body voxel stays (issue 12).
#include <gtest/gtest.h>

#include <cmath>

#include "vellum/phantom/phantom.hpp"
#include "vellum/segmentation/body_mask.hpp"
#include "vellum/segmentation/metrics.hpp"

using namespace vellum;
using namespace vellum::segmentation;

namespace {

struct Scene {
  VolumeI16 ct;
  Mask table;  ///< where the synthetic table slab was added (pads not included: their last
               ///< millimetres next to the skin cannot be told from the skin)
};

// The phantom leg with a table slab behind it (posterior = +y) a few voxels away, optionally
// touching the leg through thin pads, as on real scans.
Scene phantomOnATable(bool pads) {
  phantom::PhantomOptions o;
  o.dims = {64, 64, 48};
  const auto ph = phantom::makePhantom(o);
  Scene s{ph.ct, makeMask(ph.ct.geometry())};
  const Dims d = s.ct.dims();
  int64_t yMax = 0;  // the body's posterior extent
  for (int64_t k = 0; k < d.z; ++k)
    for (int64_t j = 0; j < d.y; ++j)
      for (int64_t i = 0; i < d.x; ++i)
        if (ph.labels(i, j, k) != phantom::kAir) yMax = std::max(yMax, j);
  const int64_t y0 = yMax + 3, y1 = std::min(d.y - 1, yMax + 6);
  for (int64_t k = 0; k < d.z; ++k)
    for (int64_t j = y0; j <= y1; ++j)
      for (int64_t i = 0; i < d.x; ++i) s.ct(i, j, k) = 150, s.table(i, j, k) = 1;
  if (pads)  // two 1x1-voxel rods from the slab to the skin
    for (int64_t k : {d.z / 3, 2 * d.z / 3})
      for (int64_t j = yMax - 2; j < y0; ++j)
        if (ph.labels(d.x / 2, j, k) == phantom::kAir) s.ct(d.x / 2, j, k) = 0;
  return s;
}

}  // namespace

TEST(BodyMask, RemovesATableSlabAndKeepsTheBody) {
  for (bool pads : {false, true}) {
    const Scene s = phantomOnATable(pads);
    phantom::PhantomOptions o;
    o.dims = {64, 64, 48};
    const Mask clean = bodyMask(phantom::makePhantom(o).ct);  // the same leg, no table
    const Mask body = bodyMask(s.ct);
    int64_t tableKept = 0;
    for (size_t i = 0; i < body.size(); ++i) tableKept += body.data()[i] && s.table.data()[i];
    EXPECT_EQ(tableKept, 0) << "pads " << pads;
    const auto m = compareMasks(body, clean);
    EXPECT_GE(m.dice, 0.999) << "pads " << pads;

    const VolumeI16 cleaned = removeTable(s.ct);
    for (size_t i = 0; i < cleaned.size(); ++i)
      if (s.table.data()[i]) ASSERT_EQ(cleaned.data()[i], -1000);
      else if (body.data()[i]) ASSERT_EQ(cleaned.data()[i], s.ct.data()[i]);
  }
}

TEST(BodyMask, MatchesThePhantomsBodyAndKeepsEnclosedAir) {
  phantom::PhantomOptions o;
  o.dims = {64, 64, 48};
  const auto ph = phantom::makePhantom(o);
  const Mask truth = maskFromIds(ph.labels.ids(), [](uint16_t id) { return id != phantom::kAir; });
  EXPECT_GE(compareMasks(bodyMask(ph.ct), truth).dice, 0.98);
  // A pocket of air inside the leg (as lungs are inside a chest) stays in the body.
  VolumeI16 ct = ph.ct;
  for (int64_t k = 20; k < 26; ++k)
    for (int64_t j = 30; j < 34; ++j)
      for (int64_t i = 30; i < 34; ++i) ct(i, j, k) = -1000;
  const Mask body = bodyMask(ct);
  EXPECT_TRUE(body(31, 31, 22));
}

namespace {

// Two legs (cylinders along z, 25 mm radius, 20 mm apart) lying on a 10 mm table slab that
// spans the whole width, each leg resting on it through a thin pad (real scans: a mattress or
// a sheet above the foam); and a small dense blob (a marker, a stray cable) beside them.
struct TwoLegs {
  VolumeI16 ct;
  Mask legs, table, blob;
};

TwoLegs twoLegsOnATable() {
  Geometry g;
  g.dims = {100, 70, 40};
  g.spacing = {1.5, 1.5, 2.0};
  TwoLegs s{VolumeI16(g, int16_t(-1000), -1000), makeMask(g), makeMask(g), makeMask(g)};
  const double cy = 30 * 1.5, r = 25;
  const double cx[2] = {50 * 1.5 - 35, 50 * 1.5 + 35};
  const double slabTop = cy + r + 3;  // 3 mm of pad between the legs and the slab
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i) {
        const double x = i * 1.5, y = j * 1.5, z = k * 2.0;
        for (double c : cx)
          if ((x - c) * (x - c) + (y - cy) * (y - cy) <= r * r) s.ct(i, j, k) = 40, s.legs(i, j, k) = 1;
        if (y >= slabTop && y < slabTop + 10) s.ct(i, j, k) = 200, s.table(i, j, k) = 1;
        // The pads: 3 mm wide strips under each leg, from the skin to the slab.
        for (double c : cx)
          if (std::abs(x - c) <= 1.5 && y > cy && y < slabTop && !s.legs(i, j, k)) s.ct(i, j, k) = 0;
        // A 6 mm cube (0.2 mL), well away from everything.
        if (x >= 4 && x < 10 && y >= 4 && y < 10 && z >= 30 && z < 36) s.ct(i, j, k) = 300, s.blob(i, j, k) = 1;
      }
  return s;
}

}  // namespace

// Issue 21: --remove-table kept only the largest component and dropped one leg of two.
TEST(BodyMask, KeepsBothLegsAndDropsTheTableAndAStrayBlob) {
  const TwoLegs s = twoLegsOnATable();
  BodyMaskReport report;
  const Mask body = bodyMask(s.ct, {}, Progress::none(), &report);
  int64_t tableKept = 0, blobKept = 0;
  for (size_t i = 0; i < body.size(); ++i) {
    tableKept += body.data()[i] && s.table.data()[i];
    blobKept += body.data()[i] && s.blob.data()[i];
  }
  EXPECT_EQ(tableKept, 0);
  EXPECT_EQ(blobKept, 0);
  EXPECT_GE(compareMasks(body, s.legs).dice, 0.995);
  // Each leg is pi 25^2 80 mm^3 = 157 mL (voxelised); both kept, reported largest first.
  ASSERT_EQ(report.keptPartsMl.size(), 2u);
  for (double ml : report.keptPartsMl) EXPECT_NEAR(ml, 157.1, 4.0);
  EXPECT_GE(report.keptPartsMl[0], report.keptPartsMl[1]);
  EXPECT_FALSE(report.keptLargestBelowMinimum);
  // Removed: the slab (150 x 10 x 80 mm^3 = 120 mL, voxelised), the pads and the blob.
  double tableMl = 0;
  for (size_t i = 0; i < s.table.size(); ++i) tableMl += s.table.data()[i];
  tableMl *= voxelVolumeMm3(s.ct.geometry()) / 1000;
  EXPECT_GE(report.removedMl, tableMl + 0.2);
  EXPECT_LE(report.removedMl, tableMl + 2.0);
  EXPECT_GE(report.removedParts, 1);  // the slab (the opening already took the blob)

  // A blob over the minimum volume and thickness is a body part; under either it is not
  // (without the opening, which would take the 6 mm cube anyway).
  BodyMaskParams smallParts;
  smallParts.openingRadiusMm = 0;
  smallParts.minPartMl = 0.1;
  smallParts.minPartThicknessMm = 5;
  const Mask withBlob = bodyMask(s.ct, smallParts);
  EXPECT_TRUE(withBlob(4, 4, 16));
  smallParts.minPartThicknessMm = 8;  // the cube is 6 mm thick
  EXPECT_FALSE(bodyMask(s.ct, smallParts)(4, 4, 16));
  smallParts.minPartThicknessMm = 5;
  smallParts.minPartMl = 0.3;  // the cube is 0.22 mL
  EXPECT_FALSE(bodyMask(s.ct, smallParts)(4, 4, 16));

  // The old behaviour (keep the largest part) is what a huge minimum gives, and it says so.
  BodyMaskParams one;
  one.minPartMl = 1e5;
  BodyMaskReport r1;
  const Mask largest = bodyMask(s.ct, one, Progress::none(), &r1);
  EXPECT_TRUE(r1.keptLargestBelowMinimum);
  ASSERT_EQ(r1.keptPartsMl.size(), 1u);
  EXPECT_NEAR(maskVolumeMm3(largest) / 1000, 157.1, 4.0);
}
