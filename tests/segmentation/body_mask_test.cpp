// --remove-table: the CT table and its pads go, every body voxel stays (issue 12).
#include <gtest/gtest.h>

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
