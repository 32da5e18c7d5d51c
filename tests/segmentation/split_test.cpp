// Splitting a mask into objects (split.hpp) on analytic shapes: a dumbbell cut at its bar,
// small pieces merged or dropped, seeds choosing the objects.
#include <gtest/gtest.h>

#include <cmath>

#include "test_volumes.hpp"
#include "vellum/core/error.hpp"
#include "vellum/segmentation/morphology.hpp"
#include "vellum/segmentation/split.hpp"

namespace vellum::segmentation {
namespace {
using test::grid;

/// Sets the voxels within r of the segment a-b (a capsule).
void addCapsule(Mask& m, Vec3 a, Vec3 b, double r) {
  const Geometry& g = m.geometry();
  const Vec3 ab = b - a;
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i) {
        const Vec3 p = g.indexToPhysical({double(i), double(j), double(k)});
        const double len2 = dot(ab, ab);  // 0: a ball
        const double t = len2 > 0 ? std::clamp(dot(p - a, ab) / len2, 0.0, 1.0) : 0.0;
        if (norm(p - (a + ab * t)) <= r) m(i, j, k) = 1;
      }
}

TEST(SplitObjects, DumbbellIsCutAtItsBar) {
  Mask m = makeMask(grid(60, 30, 30));
  const Vec3 big{15, 15, 15}, small{45, 15, 15};
  addCapsule(m, big, big, 9);    // 3054 mm³
  addCapsule(m, small, small, 7);  // 1437 mm³
  addCapsule(m, big, small, 1.2);  // the contact: a bar 3 voxels across
  const SplitResult r = splitObjects(m, {2.0, 100.0, {}});
  ASSERT_EQ(r.count(), 2);
  EXPECT_EQ(r.objects(15, 15, 15), 1);  // the larger sphere first
  EXPECT_EQ(r.objects(45, 15, 15), 2);
  // Every sphere voxel away from the bar belongs to its own sphere.
  for (int64_t k = 0; k < 30; ++k)
    for (int64_t j = 0; j < 30; ++j)
      for (int64_t i = 0; i < 60; ++i) {
        if (!m(i, j, k)) { EXPECT_EQ(r.objects(i, j, k), 0); continue; }
        const Vec3 p{double(i), double(j), double(k)};
        if (norm(p - big) <= 7) EXPECT_EQ(r.objects(i, j, k), 1);
        if (norm(p - small) <= 5) EXPECT_EQ(r.objects(i, j, k), 2);
      }
  EXPECT_NEAR(r.volumesMm3[1], 4.0 / 3 * M_PI * 729, 0.08 * 3054);
  EXPECT_NEAR(r.volumesMm3[2], 4.0 / 3 * M_PI * 343, 0.12 * 1437);
  EXPECT_DOUBLE_EQ(r.droppedMm3, 0.0);
  EXPECT_NEAR(r.volumesMm3[1] + r.volumesMm3[2], maskVolumeMm3(m), 1e-6);
}

TEST(SplitObjects, WithoutANeckOnlyUnconnectedPiecesSplit) {
  Mask m = makeMask(grid(60, 30, 30));
  addCapsule(m, {15, 15, 15}, {15, 15, 15}, 9);
  addCapsule(m, {45, 15, 15}, {45, 15, 15}, 7);
  addCapsule(m, {15, 15, 15}, {45, 15, 15}, 1.2);
  EXPECT_EQ(splitObjects(m, {0.0, 100.0, {}}).count(), 1);  // joined by the bar
  Mask apart = makeMask(grid(60, 30, 30));
  addCapsule(apart, {15, 15, 15}, {15, 15, 15}, 9);
  addCapsule(apart, {45, 15, 15}, {45, 15, 15}, 7);
  EXPECT_EQ(splitObjects(apart, {0.0, 100.0, {}}).count(), 2);
}

TEST(SplitObjects, SmallPiecesMergeIntoTheirNeighbourOrAreDropped) {
  Mask m = makeMask(grid(50, 40, 40));
  addCapsule(m, {20, 20, 20}, {20, 20, 20}, 10);
  addCapsule(m, {35, 20, 20}, {35, 20, 20}, 3.5);  // a knob on a stalk: its own marker, 180 mm³
  addCapsule(m, {20, 20, 20}, {35, 20, 20}, 1.2);
  addCapsule(m, {44, 35, 35}, {44, 35, 35}, 2);    // a speck far away: 33 mm³
  const double speck = [&] {
    Mask s = makeMask(m.geometry());
    addCapsule(s, {44, 35, 35}, {44, 35, 35}, 2);
    return maskVolumeMm3(s);
  }();
  const SplitResult r = splitObjects(m, {2.0, 500.0, {}});
  EXPECT_GE(r.markers, 2);
  ASSERT_EQ(r.count(), 1);
  EXPECT_EQ(r.objects(35, 20, 20), 1);  // the knob joined the sphere
  EXPECT_EQ(r.objects(44, 35, 35), 0);  // the speck is gone
  EXPECT_NEAR(r.droppedMm3, speck, 1e-9);
  EXPECT_NEAR(r.volumesMm3[1] + r.droppedMm3, maskVolumeMm3(m), 1e-6);
}

TEST(SplitObjects, SeedsChooseTheObjects) {
  Mask m = makeMask(grid(60, 20, 20));
  addCapsule(m, {8, 10, 10}, {40, 10, 10}, 5);   // one rod, no neck anywhere
  addCapsule(m, {54, 10, 10}, {54, 10, 10}, 4);  // an unseeded blob
  const SplitResult r = splitObjects(m, {2.0, 0.0, {{8, 10, 10}, {40, 10, 10}}});
  ASSERT_EQ(r.count(), 2);
  // The rod is shared between the two seeds, near its middle (both halves alike).
  EXPECT_NE(r.objects(8, 10, 10), r.objects(40, 10, 10));
  EXPECT_EQ(r.objects(12, 10, 10), r.objects(8, 10, 10));
  EXPECT_EQ(r.objects(36, 10, 10), r.objects(40, 10, 10));
  EXPECT_NEAR(r.volumesMm3[1], r.volumesMm3[2], 0.15 * r.volumesMm3[1]);
  EXPECT_EQ(r.objects(54, 10, 10), 0);
  EXPECT_GT(r.droppedMm3, 200.0);
  EXPECT_THROW(splitObjects(m, {2.0, 0.0, {{24, 2, 2}}}), Error);     // on background
  EXPECT_THROW(splitObjects(m, {2.0, 0.0, {{500, 10, 10}}}), Error);  // outside the grid
}

TEST(SplitObjects, AnisotropicSpacingMeasuresTheNeckInMm) {
  // 1 x 1 x 3 mm voxels: a 3 mm bar along x still splits at neck 2 mm.
  Mask m = makeMask(grid(60, 30, 12, {1, 1, 3}));
  addCapsule(m, {15, 15, 16.5}, {15, 15, 16.5}, 9);
  addCapsule(m, {45, 15, 16.5}, {45, 15, 16.5}, 9);
  addCapsule(m, {15, 15, 16.5}, {45, 15, 16.5}, 1.5);
  const SplitResult r = splitObjects(m, {2.0, 100.0, {}});
  ASSERT_EQ(r.count(), 2);
  EXPECT_NE(r.objects(15, 15, 5), r.objects(45, 15, 5));
}

/// A CT of `value` HU where `inside(p)` holds for the voxel centre p (mm), others keep theirs.
template <class Inside>
void paint(VolumeI16& ct, Inside inside, int16_t value) {
  const Geometry& g = ct.geometry();
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i)
        if (inside(g.indexToPhysical({double(i), double(j), double(k)}))) ct(i, j, k) = value;
}

Mask above(const VolumeI16& ct, int16_t hu) {
  Mask m = makeMask(ct.geometry());
  for (size_t n = 0; n < m.size(); ++n) m.data()[n] = ct.data()[n] >= hu;
  return m;
}

TEST(SplitObjects, AHollowShellBoneWithALowDensityInsideBecomesOneFilledObject) {
  // A cortical shell (1200 HU, 2.5 mm) round fatty marrow (-50 HU, under the 250 HU
  // threshold), with a nutrient canal drilled through the shell: the inside is open to the
  // outside in 3D, but enclosed in most slices of the object alone.
  VolumeI16 ct(grid(48, 48, 48), 0, -1000.0);
  const Vec3 c{24, 24, 24};
  paint(ct, [&](Vec3 p) { return norm(p - c) <= 15; }, 1200);
  paint(ct, [&](Vec3 p) { return norm(p - c) <= 12.5; }, -50);
  paint(ct, [&](Vec3 p) { return p.x > 24 && std::hypot(p.y - 24, p.z - 24) <= 1.5; }, 40);  // the canal
  const Mask shell = above(ct, 250);
  const SplitResult plain = splitObjects(shell, {2.0, 100.0, {}});
  ASSERT_EQ(plain.count(), 1);
  EXPECT_EQ(plain.objects(24, 24, 24), 0);  // the marrow is not in the mask
  SplitParams p{2.0, 100.0, {}};
  p.fillObjects = true;
  const SplitResult r = splitObjects(shell, p);
  ASSERT_EQ(r.count(), 1);
  EXPECT_EQ(r.objects(24, 24, 24), 1);
  EXPECT_EQ(r.objects(24, 30, 20), 1);
  EXPECT_EQ(r.objects(2, 2, 2), 0);   // outside stays background
  EXPECT_EQ(r.objects(46, 24, 24), 0);  // and so does the canal's mouth beyond the shell
  const double ball = 4.0 / 3 * M_PI * 15 * 15 * 15;
  EXPECT_NEAR(r.volumesMm3[1], ball, 0.06 * ball);
  EXPECT_NEAR(r.filledMm3, r.volumesMm3[1] - plain.volumesMm3[1], 1e-6);
}

TEST(SplitObjects, TwoBonesTouchingAcrossAThinJointSpaceStayTwoObjects) {
  // Two filled bones (cancellous 450 HU, subchondral plates 1200 HU) pressed together: the
  // joint space between the plates is one voxel of 300 HU, above the 250 HU threshold, so the
  // mask joins them over their whole face and the depth alone cannot cut them. The joint cut
  // sees the dark sheet between the bright plates. The left bone has a waist (3 mm across)
  // that the depth cuts: its two halves meet outside any joint space and merge back.
  VolumeI16 ct(grid(64, 32, 32), 0, -1000.0);
  auto rod = [](double x0, double x1) { return [=](Vec3 p) { return p.x >= x0 && p.x <= x1 && std::hypot(p.y - 16, p.z - 16) <= 11; }; };
  paint(ct, rod(4, 30.5), 450);
  paint(ct, rod(33.5, 60), 450);
  paint(ct, rod(30.5, 31.5), 1200);   // plate of the left bone
  paint(ct, rod(32.5, 33.5), 1200);   // plate of the right bone
  paint(ct, rod(31.5, 32.5), 300);    // the joint space, partial-volumed
  paint(ct, [](Vec3 q) { return q.x >= 14.5 && q.x <= 16.5 && std::hypot(q.y - 16, q.z - 16) > 1.5; }, 0);
  const Mask mask = above(ct, 250);
  const SplitResult depthOnly = splitObjects(mask, {2.0, 100.0, {}}, Progress::none(), &ct);  // without the cut
  ASSERT_EQ(depthOnly.count(), 2);  // cut at the waist, the two bones one object
  EXPECT_EQ(depthOnly.objects(20, 16, 16), depthOnly.objects(54, 16, 16));
  SplitParams p{2.0, 100.0, {}};
  p.jointContrastHu = 300;
  p.jointWidthMm = 2;
  EXPECT_THROW(splitObjects(mask, p), Error);  // the cut needs the CT
  p.jointShare = 0;  // no merging: the waist's halves stay apart
  EXPECT_EQ(splitObjects(mask, p, Progress::none(), &ct).count(), 3);
  p.jointShare = 0.5;
  const SplitResult r = splitObjects(mask, p, Progress::none(), &ct);
  ASSERT_EQ(r.count(), 2);
  EXPECT_GT(r.jointVoxels, 300);
  EXPECT_EQ(r.jointMerges, 1);
  EXPECT_NE(r.objects(10, 16, 16), r.objects(54, 16, 16));
  // Each bone up to its plate is one object; the joint space joins one side or the other.
  for (int64_t i = 4; i <= 60; ++i) {
    if (i == 32 || i == 15 || i == 16) continue;
    EXPECT_EQ(r.objects(i, 16, 16), i < 32 ? r.objects(10, 16, 16) : r.objects(54, 16, 16)) << "x " << i;
    EXPECT_EQ(r.objects(i, 8, 20), r.objects(i, 16, 16)) << "x " << i;
  }
  EXPECT_NEAR(r.volumesMm3[1] + r.volumesMm3[2], maskVolumeMm3(mask), 1e-6);
  // Open joints: the joint space is a gap between the two; the bones keep every other voxel.
  p.openJoints = true;
  p.fillObjects = true;
  const SplitResult open = splitObjects(mask, p, Progress::none(), &ct);
  ASSERT_EQ(open.count(), 2);
  for (int64_t i = 4; i <= 60; ++i)
    EXPECT_EQ(open.objects(i, 16, 16) != 0, i != 32) << "x " << i;
  EXPECT_GT(open.openedMm3, 300.0);
}

TEST(SplitObjects, ACordLyingAcrossTwoBonesIsRemovedAndTheBonesKeepTheirVolume) {
  // Two bone blocks (700 HU, 13 mm cubes, 7 mm apart) with a cord (300 HU, radius 1.2 mm:
  // as bright as bone at a 250 HU threshold) lying across their tops and beyond. The cord
  // joins them into one piece; with the joint cut the two halves of the cord meet outside any
  // joint space and the bones merge into one object, as a mounting wire did on real feet.
  VolumeI16 ct(grid(56, 28, 28), 0, -1000.0);
  auto block = [](double x0) { return [=](Vec3 p) { return p.x >= x0 && p.x <= x0 + 12 && p.y >= 8 && p.y <= 20 && p.z >= 6 && p.z <= 18; }; };
  paint(ct, block(12), 700);
  paint(ct, block(32), 700);
  paint(ct, [](Vec3 p) { return p.x >= 1 && p.x <= 54 && std::hypot(p.y - 14, p.z - 19.5) <= 1.2; }, 300);
  const Mask mask = above(ct, 250);
  const Mask bones = above(ct, 500);
  const double blockMm3 = 13.0 * 13 * 13;
  SplitParams p{2.0, 100.0, {}};
  p.jointContrastHu = 200;
  ASSERT_EQ(splitObjects(mask, p, Progress::none(), &ct).count(), 1);  // joined by the cord
  p.thinMm = 1.5;
  const SplitResult r = splitObjects(mask, p, Progress::none(), &ct);
  ASSERT_EQ(r.count(), 2);
  EXPECT_NE(r.objects(18, 14, 12), r.objects(38, 14, 12));
  // Every bone voxel (edges and corners included) stays in its bone: nothing eroded.
  for (size_t n = 0; n < bones.size(); ++n)
    if (bones.data()[n]) ASSERT_NE(r.objects.data()[n], 0) << "bone voxel " << n << " lost";
  EXPECT_EQ(r.objects(28, 14, 19), 0);  // the cord between the bones is gone
  EXPECT_EQ(r.objects(3, 14, 19), 0);   // and its free ends
  EXPECT_EQ(r.objects(53, 14, 19), 0);
  // What stays of the cord is the part lying on each bone and a stub of a few voxels past it
  // (within reach of the bone's core, which the cord on top thickens): its 6-voxel section.
  EXPECT_GE(r.volumesMm3[1], blockMm3);
  EXPECT_LE(r.volumesMm3[1], blockMm3 + 6 * (13 + 2 * 4));
  EXPECT_NEAR(r.thinRemovedMm3 + r.openedMm3 + r.droppedMm3, maskVolumeMm3(mask) - r.volumesMm3[1] - r.volumesMm3[2], 1e-6);
  EXPECT_GT(r.thinRemovedMm3, 6 * 10);
  // open() by the same radius would shave the bones' edges; removeThin keeps them.
  EXPECT_LT(countVoxels(open(bones, 1.5)), countVoxels(bones));
  EXPECT_EQ(countVoxels(removeThin(bones, 1.5)), countVoxels(bones));
  // Only tubes go: a thin sheet (a cortical wall 2 voxels thick, 13 x 9 mm, over a dark
  // inside) standing on a bone stays whole.
  Mask walled = bones;
  for (int64_t k = 19; k <= 27; ++k)
    for (int64_t i = 12; i <= 24; ++i) walled(i, 8, k) = walled(i, 9, k) = 1;
  EXPECT_EQ(countVoxels(removeThin(walled, 1.5)), countVoxels(walled));
}

}  // namespace
}  // namespace vellum::segmentation
