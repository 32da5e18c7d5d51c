// No folds (issue 23 §4): the fold repair unfolds a map built to fold, in tissue, without moving
// a locked node (rigid cores, fixed regions): bones stay exactly as rigid, fixed regions exactly
// still, and nodes away from the folds are not written.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "test_volumes.hpp"
#include "vellum/deformation/deformer.hpp"
#include "vellum/deformation/fold_repair.hpp"
#include "vellum/deformation/placement.hpp"
#include "vellum/deformation/rigidity.hpp"
#include "vellum/deformation/synthesis.hpp"

using namespace vellum;
using namespace vellum::deformation;

namespace {

// The identity on a 20^3 control grid (2 mm spacing) with a fold pressed into its middle: the
// nodes of a slab (x nodes 9, 10) swap their x, so the cells around the slab turn inside out.
ControlVolume foldedIdentity() {
  Geometry out;
  out.dims = {39, 39, 39};
  out.spacing = {1, 1, 1};
  out.origin = {-19, -19, -19};
  ControlVolume cv = identityControlVolume(out, 2);
  const Dims d = cv.grid.dims;
  for (int64_t k = 5; k < 15; ++k)
    for (int64_t j = 5; j < 15; ++j) {
      float* a = cv.sourceMm.data() + 3 * ((k * d.y + j) * d.x + 9);
      float* b = cv.sourceMm.data() + 3 * ((k * d.y + j) * d.x + 10);
      std::swap(a[0], b[0]);
    }
  return cv;
}

double minCellJacobian(const ControlVolume& cv) {
  const Dims d = cv.grid.dims;
  double m = 1e30;
  for (int64_t k = 0; k + 1 < d.z; ++k)
    for (int64_t j = 0; j + 1 < d.y; ++j)
      for (int64_t i = 0; i + 1 < d.x; ++i) m = std::min(m, cellMinJacobian(cv, i, j, k));
  return m;
}

}  // namespace

TEST(FoldRepair, UnfoldsAndNeverMovesALockedNode) {
  ControlVolume cv = foldedIdentity();
  ASSERT_LT(minCellJacobian(cv), -0.5) << "the map must fold before the repair";
  // Lock a block right next to the fold (x nodes 11..13) and a corner far away.
  const Dims d = cv.grid.dims;
  std::vector<uint8_t> locked(static_cast<size_t>(d.voxelCount()), 0);
  for (int64_t k = 0; k < d.z; ++k)
    for (int64_t j = 0; j < d.y; ++j)
      for (int64_t i = 0; i < d.x; ++i)
        if ((i >= 11 && i <= 13 && j >= 4 && j <= 16 && k >= 4 && k <= 16) || (i < 3 && j < 3 && k < 3))
          locked[static_cast<size_t>((k * d.y + j) * d.x + i)] = 1;
  const ControlVolume before = cv;
  const FoldRepairStats st = repairFolds(cv, locked);
  EXPECT_GT(st.cellsBefore, 0);
  EXPECT_EQ(st.cellsAfter, 0);
  EXPECT_GT(st.minJacobianAfter, 0.2 - 1e-9);
  EXPECT_GT(minCellJacobian(cv), 0.0);
  int64_t written = 0;
  for (int64_t n = 0; n < d.voxelCount(); ++n) {
    const bool same = std::memcmp(cv.sourceMm.data() + 3 * n, before.sourceMm.data() + 3 * n, 3 * sizeof(float)) == 0;
    if (locked[static_cast<size_t>(n)]) {
      ASSERT_TRUE(same) << "locked node " << n << " moved";
    }
    written += !same;
  }
  EXPECT_GT(written, 0);
  EXPECT_LE(written, st.nodesRelaxed);  // a step below float resolution writes the same value
  // Local: far from the fold (x nodes 0..3, outside the lock) nothing was written.
  for (int64_t k = 0; k < d.z; ++k)
    for (int64_t j = 0; j < d.y; ++j)
      for (int64_t i = 0; i < 4; ++i) {
        const int64_t n = (k * d.y + j) * d.x + i;
        EXPECT_EQ(std::memcmp(cv.sourceMm.data() + 3 * n, before.sourceMm.data() + 3 * n, 3 * sizeof(float)), 0);
      }
  // Cells that care about nothing are left alone (folds in air are harmless).
  ControlVolume air = foldedIdentity();
  const FoldRepairStats none = repairFolds(air, {}, [](const Vec3&) { return false; });
  EXPECT_EQ(none.cellsBefore, 0);
  EXPECT_EQ(none.nodesRelaxed, 0);
}

// Through the rigid blend, voxel level: a bend with a fixed region and a fold pressed into the
// soft tissue. After applyRigidity the map has no fold in tissue, the fixed region has not moved,
// and the bones are as rigid as without the repair.
TEST(FoldRepair, RigidBlendLeavesNoFoldInTissueAndKeepsBonesAndFixedRegions) {
  Geometry g;
  g.dims = {40, 40, 48};
  g.spacing = {1.5, 1.5, 1.5};
  g.origin = {-30, -30, -36};
  VolumeI16 ct(g, -1000, -1000);
  LabelVolume labels(g);
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i) {
        uint16_t id = 0;
        if (i >= 3 && i < 37 && j >= 3 && j < 37) id = 1;                                   // soft tissue
        if (i >= 16 && i < 24 && j >= 16 && j < 24 && k >= 4 && k < 20) id = 2;             // lower bone
        if (i >= 16 && i < 24 && j >= 16 && j < 24 && k >= 26 && k < 44) id = 3;            // upper bone
        if (i >= 4 && i < 12 && j >= 26 && j < 34 && k >= 30 && k < 44) id = 4;             // still region
        labels(i, j, k) = id;
        ct(i, j, k) = id == 0 ? -1000 : (id == 2 || id == 3) ? 1200 : 40;
      }
  FixedRegions fixed;
  fixed.ids = {4};
  const RigidBodies bodies = RigidBodies::fromLabels(labels, {2, 3}, 20, fixed);
  DeformParams p;
  p.controlScale = 2;
  Deformer d(AnyVolume(ct), p);
  d.setPoints(kneeBendTrack(g, 25.0, 2.0, g.indexToPhysical({19.5, 19.5, 23})).keyframes[1].points);
  ControlVolume base = d.update();
  // The fold: two node columns of the soft tissue (x nodes 3, 4: 9-12 mm from the bones) swap x.
  const Dims nd = base.grid.dims;
  for (int64_t k = 4; k < 12; ++k)
    for (int64_t j = 4; j < 16; ++j) std::swap(base.sourceMm[3 * ((k * nd.y + j) * nd.x + 3)], base.sourceMm[3 * ((k * nd.y + j) * nd.x + 4)]);
  ControlVolume plain = base, repaired = base;
  RigidityParams off(6.0), on(6.0);
  EXPECT_TRUE(on.repairFolds);  // the library's default: every path that builds a map repairs
  off.repairFolds = false;
  applyRigidity(plain, bodies, off);
  const FoldRepairStats st = applyRigidity(repaired, bodies, on);
  const RigidityReport a = measureRigidityVoxels(plain, g, bodies), b = measureRigidityVoxels(repaired, g, bodies);
  ASSERT_GT(a.foldFraction, 0.0) << "the map must fold in tissue before the repair";
  EXPECT_GT(st.cellsBefore, 0);
  EXPECT_EQ(b.foldFraction, 0.0) << "min det J " << b.minJacobian << ", cells left " << st.cellsAfter;
  EXPECT_GT(b.minJacobian, 0.0);
  EXPECT_LT(b.fixedMaxDisplacementMm, 1e-4);
  EXPECT_EQ(b.fixedContentElsewhere, a.fixedContentElsewhere);
  ASSERT_EQ(a.bodies.size(), b.bodies.size());
  for (size_t c = 0; c < a.bodies.size(); ++c) {
    if (a.bodies[c].fixed) continue;
    EXPECT_LE(b.bodies[c].rmsResidualMm, a.bodies[c].rmsResidualMm + 1e-4) << "body " << c;
    EXPECT_NEAR(b.bodies[c].rotationDeg, a.bodies[c].rotationDeg, 1e-3) << "body " << c;
  }
}

// Two bones one above the other (a joint gap of 6 mm, two control cells) turn opposite ways,
// 15 degrees each about the medio-lateral axis through the gap, as a pose gives them: the back
// of the gap closes to a third and the blend folds there. After the repair no tissue voxel
// folds, no cell is left locked all round, and both bones keep their turn exactly.
TEST(FoldRepair, TwoBonesTurningOppositeWaysLeaveNoFold) {
  Geometry g;
  g.dims = {32, 36, 44};
  g.spacing = {1.5, 1.5, 1.5};
  g.origin = {-24, -27, -33};
  LabelVolume labels(g);
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i) {
        uint16_t id = 0;
        if (i >= 3 && i < 29 && j >= 3 && j < 33) id = 1;                       // soft tissue
        if (i >= 10 && i < 22 && j >= 12 && j < 24 && k >= 4 && k < 20) id = 2;   // lower bone
        if (i >= 10 && i < 22 && j >= 12 && j < 24 && k >= 24 && k < 40) id = 3;  // upper bone, 6 mm above
        labels(i, j, k) = id;
      }
  const RigidBodies bodies = RigidBodies::fromLabels(labels, {2, 3}, 20);
  ASSERT_EQ(bodies.componentCount(), 2);
  // Backward transforms (output -> source) turning about x through the gap's centre.
  const Vec3 pivot = g.indexToPhysical({15.5, 17.5, 21.5});
  auto turn = [&](double deg) {
    const double a = deg * M_PI / 180;
    Mat3 r;
    r.m = {{{1, 0, 0}, {0, std::cos(a), -std::sin(a)}, {0, std::sin(a), std::cos(a)}}};
    const Mat3 back = r.transposed();
    return RigidTransform{back, pivot - back * pivot};
  };
  const std::vector<std::optional<RigidTransform>> known{turn(15), turn(-15)};
  ControlVolume plain = identityControlVolume(g, 2), repaired = plain;
  RigidityParams off(6.0), on(6.0);
  off.repairFolds = false;
  applyRigidity(plain, bodies, off, known);
  const FoldRepairStats st = applyRigidity(repaired, bodies, on, known);
  const RigidityReport a = measureRigidityVoxels(plain, g, bodies), b = measureRigidityVoxels(repaired, g, bodies);
  ASSERT_GT(a.foldFraction, 0.0) << "the blend must fold between the bones (else the test proves nothing)";
  EXPECT_EQ(st.lockedCells, 0);
  EXPECT_EQ(b.foldFraction, 0.0) << "min det J " << b.minJacobian << ", cells left " << st.cellsAfter;
  EXPECT_GT(b.minJacobian, 0.0);
  for (const auto& body : b.bodies) {
    EXPECT_LT(body.rmsResidualMm, 1e-3);
    EXPECT_NEAR(body.rotationDeg, 15.0, 1e-2);
  }
}

// Nothing folds (the usual case: every studio drag and movie frame): the repair's fast pass
// answers without the per-cell scan, reports the smallest cell Jacobian the exact scan finds,
// and writes nothing.
TEST(FoldRepair, AMapThatDoesNotFoldIsLeftAsItIsAndItsLeastJacobianReported) {
  Geometry out;
  out.dims = {33, 29, 25};
  out.spacing = {1, 1.5, 2};
  ControlVolume cv = identityControlVolume(out, 2);
  // A smooth squeeze along x (det 1 - 0.6 cos: 0.4 at the least) and a shear: nothing folds.
  for (size_t n = 0; n < cv.sourceMm.size() / 3; ++n) {
    float* p = cv.sourceMm.data() + 3 * n;
    p[0] += -0.6f * 8.f * std::sin(p[0] / 8.f) + 0.3f * p[1];
  }
  const double least = minCellJacobian(cv);
  ASSERT_GT(least, 0.25);
  ASSERT_LT(least, 0.6);
  const ControlVolume before = cv;
  const FoldRepairStats st = repairFolds(cv, {});
  EXPECT_EQ(st.cellsBefore, 0);
  EXPECT_EQ(st.nodesRelaxed, 0);
  EXPECT_NEAR(st.minJacobianBefore, least, 1e-4);
  EXPECT_EQ(std::memcmp(cv.sourceMm.data(), before.sourceMm.data(), cv.sourceMm.size() * sizeof(float)), 0);
  // Squeezed harder (det 0.15 at the least, below the repair's 0.2): the fast pass hands over.
  ControlVolume tight = identityControlVolume(out, 2);
  for (size_t n = 0; n < tight.sourceMm.size() / 3; ++n) {
    float* p = tight.sourceMm.data() + 3 * n;
    p[0] -= 0.85f * 8.f * std::sin(p[0] / 8.f);
  }
  EXPECT_GT(repairFolds(tight, {}).cellsBefore, 0);
}

// A sliding shear the projections cannot lift: the nodes left of x node 5 are locked at the
// identity, those right of x node 9 locked 12 mm along y (two sides sliding past each other),
// and the free nodes between are scrambled (each column takes one side or the other), so the
// cells between fold over and over. The second stage relaxes the free nodes towards the mean
// of their neighbours, a shear across the gap that does not fold; the locked nodes stay exact.
TEST(FoldRepair, AScrambledSlideBetweenLockedSidesIsRelaxedIntoAShear) {
  Geometry out;
  out.dims = {31, 31, 31};
  out.spacing = {1, 1, 1};
  ControlVolume cv = identityControlVolume(out, 2);
  const Dims d = cv.grid.dims;
  std::vector<uint8_t> locked(static_cast<size_t>(d.voxelCount()), 0);
  for (int64_t k = 0; k < d.z; ++k)
    for (int64_t j = 0; j < d.y; ++j)
      for (int64_t i = 0; i < d.x; ++i) {
        const int64_t n = (k * d.y + j) * d.x + i;
        const bool slides = i >= 10 || (i >= 5 && (j + k + i) % 3 == 0);
        if (slides) cv.sourceMm[static_cast<size_t>(3 * n + 1)] += 12.0f;
        if (i < 5 || i >= 10) locked[static_cast<size_t>(n)] = kNodeHardLock;
      }
  const ControlVolume before = cv;
  ASSERT_LT(minCellJacobian(cv), -1.0);
  FoldRepairParams firstOnly;
  firstOnly.relaxRadius = 0;
  ControlVolume projected = cv;
  const FoldRepairStats p = repairFolds(projected, locked, {}, firstOnly);
  EXPECT_GT(p.cellsAfter, 0) << "the projections alone leave folds here";
  const FoldRepairStats st = repairFolds(cv, locked);
  EXPECT_GT(st.clustersRelaxed, 0);
  EXPECT_EQ(st.cellsAfter, 0) << "min " << st.minJacobianAfter;
  EXPECT_GT(minCellJacobian(cv), 0.0);
  for (int64_t n = 0; n < d.voxelCount(); ++n) {
    if (locked[static_cast<size_t>(n)]) {
      ASSERT_EQ(std::memcmp(cv.sourceMm.data() + 3 * n, before.sourceMm.data() + 3 * n, 3 * sizeof(float)), 0) << n;
    }
  }
}

// Issue 23's sliding contact in small: a block slides 8 mm along y past a still block 2 voxels
// (one control cell) away, as the right big toe passes the still left one. No tissue voxel
// folds, the still block does not move at all and is shown nowhere else, and the sliding block
// keeps its transform.
TEST(FoldRepair, ABlockSlidingPastAStillBlockTwoVoxelsAwayLeavesNoFoldAndTheStillBlockStill) {
  const Geometry g = test::grid({40, 32, 24});
  LabelVolume labels(g);
  test::fillWhere(labels, test::voxelBox(4, 18, 8, 24, 4, 20), 1);
  test::fillWhere(labels, test::voxelBox(20, 34, 8, 24, 4, 20), 2);
  FixedRegions fixed;
  fixed.ids = {1};
  const RigidBodies bodies = RigidBodies::fromLabels(labels, {2}, 20, fixed);
  ASSERT_EQ(bodies.componentCount(), 2);
  RigidTransform slide;  // backward (output -> source): the block's content moves +8 mm in y
  slide.translation = {0, -8, 0};
  std::vector<std::optional<RigidTransform>> known(2);
  known[0] = slide;
  ControlVolume cv = identityControlVolume(g, 2);
  applyRigidity(cv, bodies, RigidityParams{}, known);
  const RigidityReport r = measureRigidityVoxels(cv, g, bodies);
  EXPECT_GT(r.tissueSamples, 5000);
  EXPECT_EQ(r.foldFraction, 0.0) << "min det J " << r.minJacobian;
  EXPECT_GT(r.fixedSamples, 3000);
  EXPECT_EQ(r.fixedMaxDisplacementMm, 0.0);
  EXPECT_EQ(r.fixedContentElsewhere, 0);
  ASSERT_FALSE(r.bodies[0].fixed);
  EXPECT_LT(r.bodies[0].rmsResidualMm, 1e-4);
  EXPECT_NEAR(r.bodies[0].translationMm.y, -8.0, 1e-3);
}
