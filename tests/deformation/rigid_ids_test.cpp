// A bone is a label id (issue 23): one id = one rigid body whatever its connectivity, a
// touching neighbour of another id is another body, a fixed region does not move, and the
// measures report per body, over tissue only, and nothing where nothing was measured.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <map>
#include <set>

#include "vellum/core/rigid_fit.hpp"
#include "vellum/deformation/deformer.hpp"
#include "vellum/deformation/placement.hpp"
#include "vellum/deformation/rigidity.hpp"
#include "vellum/deformation/synthesis.hpp"
#include "vellum/phantom/phantom.hpp"

using namespace vellum;
using namespace vellum::deformation;

namespace {

constexpr uint16_t kSoft = 1, kBone = 20, kNeighbour = 21, kStill = 22;

// A leg-like block of soft tissue (1.5 mm voxels, air border) with:
//  - bone 20: a rod along z split into an upper and a lower piece by a 3-voxel gap at the
//    joint (z index 30..32), as a bad slice splits a real tibia;
//  - bone 21: a block touching the rod's lower piece face to face (another bone, another id);
//  - label 22: a soft block far up one side, the region that must stay still.
struct SplitBone {
  VolumeI16 ct;
  LabelVolume labels;
  Geometry g;
  Vec3 pivot;  // the bend's axis point (mm), in the gap
};

const SplitBone& splitBone() {
  static const SplitBone s = [] {
    SplitBone r;
    Geometry g;
    g.dims = {40, 40, 64};
    g.spacing = {1.5, 1.5, 1.5};
    g.origin = {-30, -30, -48};
    r.g = g;
    r.ct = VolumeI16(g, -1000, -1000);
    r.labels = LabelVolume(g);
    for (int64_t k = 0; k < g.dims.z; ++k)
      for (int64_t j = 0; j < g.dims.y; ++j)
        for (int64_t i = 0; i < g.dims.x; ++i) {
          uint16_t id = 0;
          if (i >= 3 && i < 37 && j >= 3 && j < 37) id = kSoft;
          if (i >= 16 && i < 24 && j >= 16 && j < 24 && k >= 6 && k < 58 && !(k >= 30 && k < 33)) id = kBone;
          if (i >= 24 && i < 30 && j >= 16 && j < 24 && k >= 10 && k < 20) id = kNeighbour;
          if (i >= 4 && i < 12 && j >= 4 && j < 12 && k >= 44 && k < 60) id = kStill;
          r.labels(i, j, k) = id;
          r.ct(i, j, k) = id == 0 ? -1000 : (id == kBone || id == kNeighbour) ? 1200 : 40;
        }
    r.pivot = g.indexToPhysical({19.5, 19.5, 31});
    return r;
  }();
  return s;
}

// A bend at the gap: box points below it swing 25 degrees about x, those above stay.
ControlVolume bend(const SplitBone& s) {
  DeformParams p;
  p.controlScale = 2;
  Deformer d(AnyVolume(s.ct), p);
  d.setPoints(kneeBendTrack(s.g, 25.0, 2.0, s.pivot).keyframes[1].points);
  return d.update();
}

// The rigid fit of v -> u over the voxels of `id` with k in [k0, k1) (from the full map).
RigidTransform fitVoxels(const SplitBone& s, const std::vector<float>& map, uint16_t id, int64_t k0, int64_t k1) {
  RigidFitSums sums;
  const Dims d = s.g.dims;
  for (int64_t k = k0; k < k1; ++k)
    for (int64_t j = 0; j < d.y; ++j)
      for (int64_t i = 0; i < d.x; ++i) {
        const int64_t t = (k * d.y + j) * d.x + i;
        const Vec3 u{map[3 * t], map[3 * t + 1], map[3 * t + 2]};
        const Vec3 src = s.g.physicalToIndex(u);
        const int64_t si = std::llround(src.x), sj = std::llround(src.y), sk = std::llround(src.z);
        if (si < 0 || sj < 0 || sk < 0 || si >= d.x || sj >= d.y || sk >= d.z) continue;
        if (s.labels(si, sj, sk) != id || sk < k0 || sk >= k1) continue;
        sums.add(s.g.indexToPhysical({double(i), double(j), double(k)}), u);
      }
  return fitRigid(sums);
}

// The largest distance between two transforms over a box of points (mm).
double transformGap(const RigidTransform& a, const RigidTransform& b, const Geometry& g) {
  double worst = 0;
  for (int q = 0; q < 8; ++q) {
    const Vec3 idx{(q & 1) ? 24.0 : 16.0, (q & 2) ? 24.0 : 16.0, (q & 4) ? 58.0 : 6.0};
    const Vec3 p = g.indexToPhysical(idx);
    worst = std::max(worst, norm(a.apply(p) - b.apply(p)));
  }
  return worst;
}

}  // namespace

TEST(RigidIds, OneIdIsOneBodyWhateverItsPiecesAndTouchingIdsAreSeparate) {
  const SplitBone& s = splitBone();
  const RigidBodies bodies = RigidBodies::fromLabels(s.labels, {kBone, kNeighbour});
  ASSERT_EQ(bodies.componentCount(), 2);
  EXPECT_EQ(bodies.bodies()[0].ids, std::vector<uint16_t>{kBone});
  EXPECT_EQ(bodies.bodies()[0].pieces, 2);  // the split rod: two pieces, one body
  EXPECT_EQ(bodies.bodies()[1].ids, std::vector<uint16_t>{kNeighbour});
  EXPECT_EQ(bodies.bodies()[0].voxels, 8 * 8 * (52 - 3));
  EXPECT_EQ(bodies.bodies()[1].voxels, 6 * 8 * 10);
  // The threshold path keeps connected components: the rod's lower piece and its touching
  // neighbour are one component there, the upper piece another.
  const RigidBodies byThreshold = RigidBodies::fromThreshold(AnyVolume(s.ct), 300);
  EXPECT_EQ(byThreshold.componentCount(), 2);
}

TEST(RigidIds, PiecesOfOneIdShareOneTransformAndTheNeighbourHasItsOwn) {
  const SplitBone& s = splitBone();
  ControlVolume cv = bend(s);
  const RigidBodies bodies = RigidBodies::fromLabels(s.labels, {kBone, kNeighbour});
  // Without rigidity the two pieces move apart (the bend is between them): the test can fail.
  const std::vector<float> plain = upsampleMap(cv, s.g);
  const double plainGap = transformGap(fitVoxels(s, plain, kBone, 0, 30), fitVoxels(s, plain, kBone, 33, 64), s.g);
  EXPECT_GT(plainGap, 5.0);
  applyRigidity(cv, bodies, {6.0});
  const std::vector<float> map = upsampleMap(cv, s.g);
  const RigidTransform lower = fitVoxels(s, map, kBone, 0, 30), upper = fitVoxels(s, map, kBone, 33, 64);
  const double gap = transformGap(lower, upper, s.g);
  EXPECT_LT(gap, 0.1) << "the two pieces of one id moved differently (plain MLS: " << plainGap << " mm)";
  const RigidTransform neighbour = fitVoxels(s, map, kNeighbour, 0, 64);
  EXPECT_GT(transformGap(neighbour, lower, s.g), 1.0) << "the touching neighbour follows the rod";
  const RigidityReport r = measureRigidityMap(map, s.g, bodies);
  ASSERT_EQ(r.bodies.size(), 2u);
  for (const auto& b : r.bodies) {
    EXPECT_TRUE(b.fitted);
    EXPECT_GT(b.samples, 300);
    EXPECT_LT(b.rmsResidualMm, 0.01);
    EXPECT_LT(b.maxResidualMm, 0.05);
  }
  std::cout << "split rod: pieces' transforms differ by " << gap << " mm (plain MLS " << plainGap
            << " mm); rod turned " << r.bodies[0].rotationDeg << " deg, neighbour " << r.bodies[1].rotationDeg
            << " deg; RMS " << r.bodies[0].rmsResidualMm << " / " << r.bodies[1].rmsResidualMm << " mm\n";
  // The rod's one fit is a compromise between its pieces; the neighbour turns with the lower leg.
  EXPECT_GT(r.bodies[1].rotationDeg, r.bodies[0].rotationDeg + 2.0);
  EXPECT_GT(r.bodies[1].rotationDeg, 10.0);
  EXPECT_LT(r.bodies[1].rotationDeg, 30.0);
}

TEST(RigidIds, FixedRegionDoesNotMove) {
  const SplitBone& s = splitBone();
  // The still region by label, and a box (mm) on the other side of the leg, both above the bend.
  FixedRegions fixed;
  fixed.ids = {kStill};
  const Vec3 lo = s.g.indexToPhysical({28, 4, 46}), hi = s.g.indexToPhysical({35, 12, 60});
  fixed.boxesMm.push_back({lo.x, lo.y, lo.z, hi.x, hi.y, hi.z});
  const RigidBodies bodies = RigidBodies::fromLabels(s.labels, {kBone, kNeighbour}, 20, fixed);
  ASSERT_EQ(bodies.componentCount(), 3);
  EXPECT_EQ(bodies.fixedBody(), 2);
  EXPECT_TRUE(bodies.bodies()[2].fixed);
  ControlVolume cv = bend(s);
  // Tilt the whole map so that the still regions would move without the constraint.
  for (int64_t n = 0; n < cv.grid.dims.voxelCount(); ++n) {
    float* u = cv.sourceMm.data() + 3 * n;
    u[0] += 0.05f * u[2];
  }
  const std::vector<float> before = upsampleMap(cv, s.g);
  applyRigidity(cv, bodies, {6.0});
  const std::vector<float> map = upsampleMap(cv, s.g);
  const AnyVolume out = synthesize(AnyVolume(s.ct), cv);
  const auto& outVoxels = std::get<VolumeI16>(out);
  const Dims d = s.g.dims;
  int64_t fixedVoxels = 0;
  double movedBefore = 0, movedAfter = 0;
  for (int64_t k = 0; k < d.z; ++k)
    for (int64_t j = 0; j < d.y; ++j)
      for (int64_t i = 0; i < d.x; ++i) {
        const bool inBox = i >= 28 && i <= 35 && j >= 4 && j <= 12 && k >= 46 && k <= 60;
        if (!inBox && s.labels(i, j, k) != kStill) continue;
        ++fixedVoxels;
        const int64_t t = (k * d.y + j) * d.x + i;
        const Vec3 v = s.g.indexToPhysical({double(i), double(j), double(k)});
        movedBefore = std::max(movedBefore, norm(Vec3{before[3 * t], before[3 * t + 1], before[3 * t + 2]} - v));
        movedAfter = std::max(movedAfter, norm(Vec3{map[3 * t], map[3 * t + 1], map[3 * t + 2]} - v));
        // The voxel is the source's, bit for bit.
        ASSERT_EQ(outVoxels(i, j, k), s.ct(i, j, k)) << "voxel " << i << "," << j << "," << k;
      }
  EXPECT_EQ(fixedVoxels, 8 * 8 * 16 + 8 * 9 * 15);
  EXPECT_GT(movedBefore, 2.0);
  EXPECT_LT(movedAfter, 1e-4);  // float: the identity stored in single precision
  const RigidityReport r = measureRigidityMap(map, s.g, bodies);
  EXPECT_EQ(r.fixedSamples, fixedVoxels);
  EXPECT_EQ(r.fixedContentElsewhere, 0);
  EXPECT_LT(r.fixedMaxDisplacementMm, 1e-4);
  EXPECT_LT(r.fixedMeanDisplacementMm, 1e-5);
  EXPECT_TRUE(r.bodies[2].fixed);
  // An id both rigid and fixed is refused.
  FixedRegions both;
  both.ids = {kBone};
  EXPECT_THROW(RigidBodies::fromLabels(s.labels, {kBone}, 20, both), Error);
}

TEST(RigidIds, FoldsCountInTissueOnlyAndEmptyClassesAreNotMeasured) {
  const SplitBone& s = splitBone();
  ControlVolume cv = bend(s);
  // Fold the air border: the first 2 node columns swap places (x), outside the leg.
  const Dims nd = cv.grid.dims;
  for (int64_t k = 0; k < nd.z; ++k)
    for (int64_t j = 0; j < nd.y; ++j) {
      float* a = cv.sourceMm.data() + 3 * ((k * nd.y + j) * nd.x + 0);
      float* b = cv.sourceMm.data() + 3 * ((k * nd.y + j) * nd.x + 1);
      std::swap(a[0], b[0]);
    }
  // Bone-only label map: the rod and its neighbour, nothing else labelled.
  LabelVolume boneOnly(s.g);
  for (size_t t = 0; t < boneOnly.ids().size(); ++t) {
    const uint16_t id = s.labels.ids().data()[t];
    boneOnly.ids().data()[t] = (id == kBone || id == kNeighbour) ? id : 0;
  }
  const RigidBodies bodies = RigidBodies::fromLabels(boneOnly, {kBone, kNeighbour});
  const RigidityReport r = measureRigidityVoxels(cv, s.g, bodies);
  EXPECT_EQ(r.softNodes, 0);  // nothing to measure: the report must not say "moved 0 mm"
  EXPECT_GT(r.tissueSamples, 0);
  EXPECT_EQ(r.foldFraction, 0.0) << "the folds in air were counted";
  EXPECT_GT(r.minJacobian, 0.0);
  // With the whole leg as tissue, still no fold: the fold lies in air.
  const RigidityReport leg = measureRigidityVoxels(cv, s.g, RigidBodies::fromLabels(s.labels, {kBone, kNeighbour}));
  EXPECT_GT(leg.softNodes, 1000);
  EXPECT_EQ(leg.foldFraction, 0.0);
  // A fold inside the leg is counted: swap two node columns in the middle.
  ControlVolume folded = cv;
  for (int64_t k = 0; k < nd.z; ++k)
    for (int64_t j = 0; j < nd.y; ++j) {
      float* a = folded.sourceMm.data() + 3 * ((k * nd.y + j) * nd.x + 6);
      float* b = folded.sourceMm.data() + 3 * ((k * nd.y + j) * nd.x + 7);
      std::swap(a[0], b[0]);
    }
  const RigidityReport f = measureRigidityVoxels(folded, s.g, RigidBodies::fromLabels(s.labels, {kBone, kNeighbour}));
  EXPECT_GT(f.foldFraction, 0.01);
  EXPECT_LT(f.minJacobian, 0.0);
  // The report says where: between the swapped columns (nodes 6 and 7, a node either side).
  EXPECT_GE(f.minJacobianAtMm.x, cv.grid.indexToPhysical({5, 0, 0}).x);
  EXPECT_LE(f.minJacobianAtMm.x, cv.grid.indexToPhysical({8, 0, 0}).x);
}
// Groups: `--rigid-labels 4+5,6+7,8+11,9+11` makes the phantom's four bones even where the
// cortex is thinner than a voxel (48 voxels across: cortex labels in fragments, so the core
// rule cannot find the marrow inside them and the flat list gives 6 bodies); the shared id 11
// splits by piece to the bone it touches. The bodies are exactly phantom::boneMap's bones.
// (At 32 voxels the fibula's and patella's cortex has no voxel left: there is nothing to group.)
TEST(RigidIds, GroupsMakeThePhantomsBonesAtAnyResolution) {
  for (int n : {48, 64}) {
    phantom::PhantomOptions o;
    o.dims = {n, n, n * 5 / 4};
    const phantom::Phantom ph = phantom::makePhantom(o);
    const RigidBodies b = RigidBodies::fromLabelGroups(ph.labels, {{4, 5}, {6, 7}, {8, 11}, {9, 11}});
    ASSERT_EQ(b.componentCount(), 4) << n;
    const VolumeU8 bones = phantom::boneMap(ph.labels);
    std::map<int, std::set<int>> bodiesOf;
    for (size_t t = 0; t < bones.size(); ++t)
      if (bones.data()[t] != 0) bodiesOf[bones.data()[t]].insert(b.classes().data()[t]);
    for (int bone = 1; bone <= 4; ++bone)
      EXPECT_EQ(bodiesOf[bone], std::set<int>{bone + 1}) << "bone " << bone << " at " << n;
    EXPECT_EQ(b.bodies()[0].ids, (std::vector<uint16_t>{4, 5})) << n;
    EXPECT_EQ(b.bodies()[2].ids, (std::vector<uint16_t>{8, 11})) << n;
    if (n == 48) {
      EXPECT_EQ(RigidBodies::fromLabels(ph.labels, {4, 5, 6, 7, 8, 9, 11}).componentCount(), 6);
    }
  }
}
