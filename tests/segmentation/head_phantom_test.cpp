// Integration on real CT: the skull shell of ../shared/data/ct-head-phantom by threshold.
#include <gtest/gtest.h>

#include "test_data.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/segmentation/components.hpp"
#include "vellum/segmentation/threshold.hpp"

using namespace vellum;
using namespace vellum::segmentation;

TEST(HeadPhantom, SkullShellIsOneComponent) {
  VELLUM_REQUIRE_DATA("ct-head-phantom");
  io::LoadedVolume lv;
  try {
    lv = io::loadVolume(test::dataDir() / "ct-head-phantom");
  } catch (const Error& e) {
    GTEST_SKIP() << "io cannot read the DICOM series yet: " << e.what();
  }
  const VolumeI16 ct = toInt16(lv.volume);
  ASSERT_EQ(ct.dims().z, 28);
  // The whole-bone preset (550 HU): the skull in 5 mm slices is strongly partial-volumed, and
  // the cortical "bone" preset (700 HU, the phantom cortex midpoint) breaks it into three
  // pieces of similar size (measured: 29k / 18k / 18k voxels).
  const Mask bone = threshold(ct, presetInterval(Preset::WholeBone));
  // Remove specks (noise, table edges) under 1 cm³, then the shell must be a single piece
  // holding most of the thresholded voxels.
  // Remove specks under 1 cm³. What remains: the skull shell as ONE piece (not fragmented by
  // the 5 mm slice gaps) plus separate dense objects (inserts, table). The shell is the
  // largest piece and holds most of the bone voxels.
  const Mask cleaned = removeSmallIslands(bone, 1000.0);
  const Components c = connectedComponents(cleaned, Connectivity::Vertex26);
  ASSERT_GE(c.count(), 1);
  const int64_t shell = c.sizes[c.largest()];
  std::printf("bone voxels %lld, after islands %lld, components %lld, largest %lld\n",
              static_cast<long long>(countVoxels(bone)), static_cast<long long>(countVoxels(cleaned)),
              static_cast<long long>(c.count()), static_cast<long long>(shell));
  for (int64_t l = 1; l <= c.count(); ++l) std::printf("  component %lld: %lld voxels\n", static_cast<long long>(l), static_cast<long long>(c.sizes[l]));
  EXPECT_GT(static_cast<double>(shell), 0.8 * static_cast<double>(countVoxels(bone)));
  // No second piece is shell-sized (a fragmented shell would split into comparable parts).
  for (int64_t l = 1; l <= c.count(); ++l) {
    if (static_cast<uint32_t>(l) != c.largest()) {
      EXPECT_LT(c.sizes[l], shell / 10);
    }
  }
}
