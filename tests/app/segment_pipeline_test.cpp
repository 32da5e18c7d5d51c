// The segmentation request shared by `vellum segment` and the studio.
#include <gtest/gtest.h>

#include "vellum/app/segment_pipeline.hpp"
#include "vellum/core/error.hpp"
#include "vellum/phantom/phantom.hpp"
#include "vellum/segmentation/components.hpp"
#include "vellum/segmentation/metrics.hpp"
#include "vellum/segmentation/threshold.hpp"

using namespace vellum;
namespace seg = vellum::segmentation;

namespace {
const phantom::Phantom& knee() {
  static const phantom::Phantom ph = [] {
    phantom::PhantomOptions o;
    o.dims = {48, 48, 48};
    return phantom::makePhantom(o);
  }();
  return ph;
}
}  // namespace

TEST(SegmentPipeline, ThresholdIsTheLibraryThresholdAndReportsItsInterval) {
  app::SegmentSettings r;
  r.preset = "bone";
  r.upper = 2000;
  const auto out = app::runSegmentation(knee().ct, r);
  const seg::HuInterval iv{seg::presetInterval(seg::Preset::Bone).lower, 2000};
  EXPECT_EQ(out.mask.voxels(), seg::threshold(knee().ct, iv).voxels());
  EXPECT_EQ(out.info["interval_hu"][0].get<double>(), iv.lower);
  EXPECT_EQ(out.info["interval_hu"][1].get<double>(), 2000.0);
  EXPECT_TRUE(out.info["post_processing"].empty());
}

TEST(SegmentPipeline, PostProcessingKeepsTheLargestPiece) {
  app::SegmentSettings r;
  r.preset = "bone";
  r.post.keepLargest = true;
  const auto out = app::runSegmentation(knee().ct, r);
  const auto all = seg::threshold(knee().ct, seg::presetInterval(seg::Preset::Bone));
  EXPECT_EQ(out.mask.voxels(), seg::keepLargestComponent(all).voxels());
  EXPECT_LT(seg::countVoxels(out.mask), seg::countVoxels(all)) << "the phantom's bone has several pieces";
  EXPECT_EQ(out.info["post_processing"][0], "keep_largest");
}

TEST(SegmentPipeline, SnakeFromASeedIsObservedAndFillsTheMuscle) {
  const auto& ph = knee();
  // A seed in the thigh muscle (label 3): the first muscle voxel at mid height.
  Vec3 seed;
  bool found = false;
  for (int64_t i = 0; i < 48 && !found; ++i)
    if (ph.labels.ids()(i, 24, 24) == 3 && ph.labels.ids()(i + 3, 24, 24) == 3) {
      seed = ph.ct.geometry().indexToPhysical({double(i + 2), 24, 24});
      found = true;
    }
  ASSERT_TRUE(found);
  app::SegmentSettings r;
  r.method = "snake";
  r.seedsMm = {seed};
  r.bubbleRadiusMm = 3;
  int observed = 0;
  const auto out = app::runSegmentation(ph.ct, r, Progress::none(), [&](const seg::Mask&, int) { ++observed; });
  EXPECT_GT(observed, 0);
  EXPECT_GT(out.info["snake"]["iterations"].get<int>(), 0);
  const seg::Mask muscle = seg::maskFromIds(ph.labels.ids(), [](uint16_t v) { return v == 3; });
  EXPECT_GT(seg::compareMasks(out.mask, muscle).dice, 0.6);
}

TEST(SegmentPipeline, BadRequestsAreOneLineErrors) {
  app::SegmentSettings unknown;
  unknown.method = "magic";
  EXPECT_THROW(app::runSegmentation(knee().ct, unknown), Error);
  app::SegmentSettings noSeed;
  noSeed.method = "grow";
  try {
    app::runSegmentation(knee().ct, noSeed);
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("seed"), std::string::npos) << e.what();
  }
  app::SegmentSettings reversed;
  reversed.lower = 500;
  reversed.upper = 100;
  EXPECT_THROW(app::runSegmentation(knee().ct, reversed), Error);
}
