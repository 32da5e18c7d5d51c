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
  const Mask bone = threshold(ct, presetInterval(Preset::Bone));
  // Remove specks (noise, table edges) under 1 cm³, then the shell must be a single piece
  // holding most of the thresholded voxels.
  const Mask cleaned = removeSmallIslands(bone, 1000.0);
  const Components c = connectedComponents(cleaned, Connectivity::Vertex26);
  std::printf("bone voxels %lld, after islands %lld, components %lld\n",
              static_cast<long long>(countVoxels(bone)), static_cast<long long>(countVoxels(cleaned)),
              static_cast<long long>(c.count()));
  EXPECT_EQ(c.count(), 1);
  EXPECT_GT(static_cast<double>(countVoxels(cleaned)), 0.9 * static_cast<double>(countVoxels(bone)));
}
