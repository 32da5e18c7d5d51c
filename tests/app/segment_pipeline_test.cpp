// The segmentation request shared by `vellum segment` and the studio.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "test_data.hpp"
#include "vellum/app/label_edit.hpp"
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

namespace {
/// A CT of two bone balls (1000 HU, radii 8 and 6 mm) joined by a 2 mm bar, in air.
VolumeI16 dumbbellCt() {
  Geometry g;
  g.dims = {56, 28, 28};
  VolumeI16 ct(g, -1000, kCtAirHu);
  const Vec3 a{14, 14, 14}, b{42, 14, 14};
  for (int64_t k = 0; k < 28; ++k)
    for (int64_t j = 0; j < 28; ++j)
      for (int64_t i = 0; i < 56; ++i) {
        const Vec3 p{double(i), double(j), double(k)};
        const double bar = std::hypot(p.y - 14, p.z - 14);
        if (norm(p - a) <= 8 || norm(p - b) <= 6 || (p.x > 14 && p.x < 42 && bar <= 1.2)) ct(i, j, k) = 1000;
      }
  return ct;
}
}  // namespace

TEST(SegmentPipeline, SplitWritesOneIdPerObjectAndLabelEditMergesThem) {
  const auto dir = test::tempDir("segment-split");
  io::saveVolume(AnyVolume(dumbbellCt()), dir / "ct.nrrd");
  app::SegmentRequest r;
  r.input = dir / "ct.nrrd";
  r.output = dir / "bones.nrrd";
  r.report = dir / "bones.json";
  r.labelName = "bone";
  r.settings.lower = 500;
  r.settings.post.split = true;
  r.settings.post.splitParams.minVolumeMm3 = 100;
  const app::SegmentResult result = app::runSegment(r);
  ASSERT_EQ(result.written, (std::vector<uint16_t>{1, 2}));
  const LabelVolume labels = io::loadLabels(r.output);
  EXPECT_EQ(labels.ids()(14, 14, 14), 1);  // the larger ball first
  EXPECT_EQ(labels.ids()(42, 14, 14), 2);
  EXPECT_EQ(labels.label(1)->name, "bone 1");
  EXPECT_EQ(labels.label(2)->name, "bone 2");
  const auto& objects = result.report["segment"]["objects"];
  ASSERT_EQ(objects.size(), 2u);
  EXPECT_NEAR(objects[0]["volume_mm3"].get<double>(), 4.0 / 3 * M_PI * 512, 0.1 * 2145);
  EXPECT_EQ(result.report["split"]["markers"].get<int>(), 2);

  // The two pieces made one bone again, renamed; an id that is not there is refused.
  app::LabelEditRequest edit;
  edit.input = r.output;
  edit.output = dir / "merged.nrrd";
  edit.assign = {{{1, 2}, 5}};
  edit.names[5] = "pelvis";
  const app::LabelEditResult e = app::runLabelEdit(edit);
  ASSERT_EQ(e.after.size(), 1u);
  EXPECT_EQ(e.after[0].id, 5);
  EXPECT_EQ(e.after[0].name, "pelvis");
  EXPECT_EQ(e.after[0].voxels, e.before[0].voxels + e.before[1].voxels);
  // Where each id is (1 mm voxels at the origin): centres on the balls' axis, bounds the balls'.
  EXPECT_NEAR(e.before[0].centreMm.x, 14, 1.5);
  EXPECT_NEAR(e.before[1].centreMm.x, 42, 1.5);
  for (const auto& entry : {e.before[0], e.before[1], e.after[0]}) {
    EXPECT_NEAR(entry.centreMm.y, 14, 1e-9);
    EXPECT_NEAR(entry.centreMm.z, 14, 1e-9);
  }
  EXPECT_EQ(e.before[0].boxMinMm.x, 6);
  EXPECT_EQ(e.before[0].boxMinMm.y, 6);
  EXPECT_EQ(e.before[0].boxMaxMm.z, 22);
  EXPECT_EQ(e.after[0].boxMinMm.x, 6);
  EXPECT_EQ(e.after[0].boxMaxMm.x, 48);
  const LabelVolume merged = io::loadLabels(edit.output);
  EXPECT_EQ(merged.ids()(14, 14, 14), 5);
  EXPECT_EQ(merged.ids()(42, 14, 14), 5);
  ASSERT_EQ(merged.table().size(), 1u);

  app::LabelEditRequest bad = edit;
  bad.output = dir / "bad.nrrd";
  bad.assign = {{{9}, 5}};
  EXPECT_THROW(app::runLabelEdit(bad), FileError);
  EXPECT_FALSE(std::filesystem::exists(bad.output));
  bad.assign = {{{1}, 5}, {{1}, 6}};
  EXPECT_THROW(app::runLabelEdit(bad), Error);
  // Dropping one ball and keeping nothing else.
  app::LabelEditRequest drop = edit;
  drop.output = dir / "dropped.nrrd";
  drop.assign.clear();
  drop.names.clear();
  drop.drop = {2};
  const app::LabelEditResult d = app::runLabelEdit(drop);
  ASSERT_EQ(d.after.size(), 1u);
  EXPECT_EQ(d.after[0].id, 1);
  EXPECT_EQ(d.after[0].name, "bone 1");
}
