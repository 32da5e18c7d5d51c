// Segmentation against the phantom's ground truth (128³: about 1.4 x 1.4 x 1.7 mm voxels).
#include <gtest/gtest.h>

#include "vellum/phantom/phantom.hpp"
#include "vellum/segmentation/components.hpp"
#include "vellum/segmentation/metrics.hpp"
#include "vellum/segmentation/morphology.hpp"
#include "vellum/segmentation/region_growing.hpp"
#include "vellum/segmentation/snake.hpp"
#include "vellum/segmentation/threshold.hpp"

using namespace vellum;
using namespace vellum::segmentation;

namespace {

const phantom::Phantom& knee() {
  static const phantom::Phantom p = [] {
    phantom::PhantomOptions o;
    o.dims = {128, 128, 128};
    return phantom::makePhantom(o);
  }();
  return p;
}

// A seed in the posterior thigh muscle, 35 mm behind the femur axis.
const Vec3 kMuscleSeed{0, 35, 60};

}  // namespace

TEST(PhantomSegmentation, SeedIsInMuscle) {
  const auto v = nearestVoxel(knee().ct.geometry(), kMuscleSeed);
  ASSERT_TRUE(v);
  EXPECT_EQ(knee().labels(v->i, v->j, v->k), phantom::kMuscle);
}

// Bone by threshold: the bone preset (midpoint between cortex and its surroundings) against
// the cortical truth (femur, tibia, fibula and patella shells; majority-tissue voxel labels).
TEST(PhantomSegmentation, BoneThresholdMatchesCorticalTruth) {
  const Mask t = threshold(knee().ct, presetInterval(Preset::Bone));
  const double dice = overlap(t, maskFromIds(knee().labels.ids(), phantom::isCorticalBone)).dice;
  RecordProperty("cortical_dice", std::to_string(dice));
  std::printf("bone preset threshold vs isCorticalBone: Dice %.4f\n", dice);
  EXPECT_GE(dice, 0.98);
  // Nothing but bone (cortex, marrow, cancellous core) and the voxels touching it is taken.
  const Mask nearBone = dilate(maskFromIds(knee().labels.ids(), phantom::isBone), 2.5);
  EXPECT_EQ(countVoxels(maskAnd(t, maskNot(nearBone))), 0);
}

// Whole bones: the whole-bone preset keeps thin cortex closed, per-slice hole filling adds
// marrow and cancellous cores; compared with every bone label.
TEST(PhantomSegmentation, WholeBonesByThresholdAndHoleFilling) {
  const Mask t = threshold(knee().ct, presetInterval(Preset::WholeBone));
  const Mask bones = removeSmallIslands(fillHolesPerSlice(t, 2), 50.0);
  const double dice = overlap(bones, maskFromIds(knee().labels.ids(), phantom::isBone)).dice;
  RecordProperty("whole_bone_dice", std::to_string(dice));
  std::printf("whole-bone threshold + per-slice fill vs isBone: Dice %.4f\n", dice);
  EXPECT_GE(dice, 0.98);
  // Four bones, four pieces.
  EXPECT_EQ(connectedComponents(bones, Connectivity::Vertex26).count(), 4);
}

// On a coarser grid (96³: 1.9 x 1.9 x 2.3 mm) axial rings of the condyles' cortex open; filling
// slices of all three orientations still recovers whole bones.
TEST(PhantomSegmentation, WholeBonesOnACoarseGrid) {
  phantom::PhantomOptions o;
  o.dims = {96, 96, 96};
  // This test is about the fill rule on a coarse grid. With 1.9 mm voxels the default PSF
  // blur (0.9 voxel) lowers the 1.2 mm condylar cortex below the whole-bone threshold so its
  // rings open whatever the fill rule (x/y/z fill Dice 0.944); a sharper PSF keeps them closed.
  o.psfSmoothingVoxels = 0.5;
  const phantom::Phantom p = phantom::makePhantom(o);
  const Mask t = threshold(p.ct, presetInterval(Preset::WholeBone));
  const Mask truth = maskFromIds(p.labels.ids(), phantom::isBone);
  const double axial = overlap(removeSmallIslands(fillHolesPerSlice(t, 2), 100.0), truth).dice;
  const double all = overlap(removeSmallIslands(fillHolesAllSlices(t), 100.0), truth).dice;
  std::printf("96³ whole bones: axial fill Dice %.4f, x/y/z fill Dice %.4f\n", axial, all);
  EXPECT_GE(all, 0.98);
  EXPECT_GT(all, axial);
}

TEST(PhantomSegmentation, RegionGrowingFromTheFemurLeaksNowhere) {
  const auto& p = knee();
  // A femur shaft cortex voxel.
  Vec3 seed;
  bool found = false;
  for (int64_t j = 0; j < 128 && !found; ++j)
    for (int64_t i = 0; i < 128 && !found; ++i)
      if (p.labels(i, j, 100) == phantom::kFemurCortex && p.ct(i, j, 100) > 1000) {
        seed = p.ct.geometry().indexToPhysical({double(i), double(j), 100.0});
        found = true;
      }
  ASSERT_TRUE(found);
  const Mask m = connectedThreshold(p.ct, {seed}, presetInterval(Preset::Bone), Connectivity::Face6);
  int64_t femur = 0, other = 0;
  for (size_t q = 0; q < m.size(); ++q) {
    if (!m.data()[q]) continue;
    const uint16_t id = p.labels.ids().data()[q];
    if (id == phantom::kFemurCortex || id == phantom::kFemurMarrow) ++femur;
    else ++other;
  }
  EXPECT_GT(femur, 1000);
  // Other bones are never reached, and every non-femur voxel grown is a partial-volume voxel
  // touching the femur (within one voxel diagonal of a femur voxel): no spreading.
  const Mask femurTruth = maskFromIds(p.labels.ids(), [](uint16_t id) {
    return id == phantom::kFemurCortex || id == phantom::kFemurMarrow;
  });
  const Mask nearFemur = dilate(femurTruth, 2.7);
  for (size_t q = 0; q < m.size(); ++q) {
    if (!m.data()[q]) continue;
    const uint16_t id = p.labels.ids().data()[q];
    ASSERT_FALSE(id == phantom::kTibiaCortex || id == phantom::kTibiaMarrow || id == phantom::kFibula ||
                 id == phantom::kPatella) << "leaked into bone " << id;
    ASSERT_TRUE(nearFemur.data()[q]) << "grown voxel " << q << " is away from the femur";
  }
  std::printf("femur growing: %lld femur voxels, %lld partial-volume neighbours\n",
              static_cast<long long>(femur), static_cast<long long>(other));
  // Soft-tissue growing from the muscle never enters any bone.
  const Mask soft = connectedThreshold(p.ct, {kMuscleSeed}, presetInterval(Preset::SoftTissue));
  for (size_t q = 0; q < soft.size(); ++q) {
    if (soft.data()[q]) {
      ASSERT_FALSE(phantom::isBone(p.labels.ids().data()[q])) << q;
    }
  }
}

TEST(PhantomSegmentation, SoftTissueSnakeThresholdSpeed) {
  const SpeedImage speed = thresholdSpeed(knee().ct);
  const SnakeResult r = evolveSnake(speed, {{kMuscleSeed, 10.0}}, {});
  const double dice = overlap(r.mask, maskFromIds(knee().labels.ids(), phantom::isSoftTissue)).dice;
  std::printf("soft-tissue snake, threshold speed: Dice %.4f, %d + %d coarse iterations, %.2f s\n", dice,
              r.iterations, r.coarseIterations, r.seconds);
  EXPECT_TRUE(r.converged);
  EXPECT_GE(dice, 0.97);
}

// Edge speed with the library defaults (exponent 4, kappa 120 HU/mm, advection 2,
// coarse-to-fine): the contour stops at the skin and at the bones.
TEST(PhantomSegmentation, SoftTissueSnakeEdgeSpeed) {
  const SpeedImage speed = edgeSpeed(knee().ct);
  const SnakeResult r = evolveSnake(speed, {{kMuscleSeed, 10.0}});
  const auto& ids = knee().labels.ids();
  const double dice = overlap(r.mask, maskFromIds(ids, phantom::isSoftTissue)).dice;
  std::printf("soft-tissue snake, edge speed: Dice %.4f, %d + %d coarse iterations, %.2f s\n", dice,
              r.iterations, r.coarseIterations, r.seconds);
  EXPECT_GT(r.coarseIterations, 0);
  EXPECT_TRUE(r.converged);
  EXPECT_GE(dice, 0.97);
  // Hardly anything inside the bones (marrow, cancellous cores): no leak through thin cortex.
  const Mask inner = maskFromIds(ids, [](uint16_t id) {
    return id == phantom::kFemurMarrow || id == phantom::kTibiaMarrow || id == phantom::kCancellous;
  });
  EXPECT_LT(countVoxels(maskAnd(r.mask, inner)), countVoxels(inner) / 50);
}
