// Bone rigidity on the knee phantom ([HVD 1.3, 1.6] in docs/references.md).
#include <gtest/gtest.h>

#include <map>
#include <set>

#include "vellum/deformation/deformer.hpp"
#include "vellum/deformation/placement.hpp"
#include "vellum/deformation/rigidity.hpp"
#include "vellum/deformation/synthesis.hpp"
#include "vellum/phantom/phantom.hpp"

using namespace vellum;
using namespace vellum::deformation;

namespace {

const phantom::Phantom& knee() {
  static const phantom::Phantom p = [] {
    phantom::PhantomOptions o;
    o.dims = {64, 64, 72};
    return phantom::makePhantom(o);
  }();
  return p;
}

// Every bone id of the phantom (cortex, marrow, cancellous cores: 4..9 and 11).
std::vector<uint16_t> boneIds() {
  std::vector<uint16_t> ids;
  for (uint16_t id = 1; id < 64; ++id)
    if (phantom::isBone(id)) ids.push_back(id);
  return ids;
}

// A strong bend (30 degrees of knee flexion: 40 folds even plain MLS with 16 box points) with
// a sideways sway: soft tissue moves a lot.
ControlPoints strongBend(const Geometry& g) {
  ControlPoints pts = kneeBendTrack(g, 30.0, 2.0, phantom::flexionAxisPointMm()).keyframes[1].points;
  for (auto& p : pts) p.target += Vec3{8, 0, 0};
  return pts;
}

}  // namespace

TEST(Rigidity, BodiesFromPhantomLabelsAreTheSeparateBones) {
  const auto bodies = RigidBodies::fromLabels(knee().labels, boneIds());
  // Cortex and marrow of one bone form one body; different bones never share a body.
  std::map<int, std::set<uint16_t>> idsOf;
  const auto& cls = bodies.classes().voxels();
  const auto& ids = knee().labels.ids().voxels();
  for (size_t t = 0; t < cls.size(); ++t)
    if (cls[t] >= 2) idsOf[cls[t]].insert(ids[t]);
  EXPECT_EQ(static_cast<int>(idsOf.size()), bodies.componentCount());
  EXPECT_GE(bodies.componentCount(), 2);
  bool femur = false, tibia = false;
  for (const auto& [c, s] : idsOf) {
    const bool hasFemur = s.count(4) || s.count(5), hasTibia = s.count(6) || s.count(7);
    EXPECT_FALSE(hasFemur && hasTibia) << "body " << c << " joins femur and tibia";
    femur = femur || (s.count(4) && s.count(5));
    tibia = tibia || (s.count(6) && s.count(7));
  }
  EXPECT_TRUE(femur);
  EXPECT_TRUE(tibia);
}

TEST(Rigidity, EachRigidBodyIsOneWholeBone) {
  const auto bodies = RigidBodies::fromLabels(knee().labels, boneIds());
  const VolumeU8 bones = phantom::boneMap(knee().labels);
  const auto& cls = bodies.classes().voxels();
  // body -> bones it holds, bone -> bodies it is split into; no bone voxel left out.
  std::map<int, std::set<int>> bonesOf, bodiesOf;
  int64_t boneVoxels = 0, missing = 0;
  for (size_t t = 0; t < cls.size(); ++t) {
    const int b = bones.data()[t];
    if (b != 0) ++boneVoxels;
    if (cls[t] >= 2) {
      bonesOf[cls[t]].insert(b);
      bodiesOf[b].insert(cls[t]);
    } else if (b != 0) {
      ++missing;
    }
  }
  EXPECT_EQ(bodies.componentCount(), 4);  // femur, tibia, fibula, patella
  EXPECT_EQ(missing, 0) << "bone voxels left out of every body (dropped fragments)";
  for (const auto& [c, s] : bonesOf) {
    EXPECT_EQ(s.size(), 1u) << "body " << c << " spans several bones";
    EXPECT_EQ(s.count(0), 0u) << "body " << c << " holds non-bone voxels";
  }
  for (int b = 1; b <= 4; ++b) EXPECT_EQ(bodiesOf[b].size(), 1u) << "bone " << b << " is not one body";
  EXPECT_GT(boneVoxels, 1000);
}

TEST(Rigidity, RigidLabelsKeepBoneRigidWhileSoftTissueMoves) {
  const AnyVolume ct = knee().ct;
  const Geometry& g = knee().ct.geometry();
  const auto bodies = RigidBodies::fromLabels(knee().labels, boneIds());
  DeformParams p;
  p.controlScale = 2;
  ControlVolume cv = computeControlVolume(ct, strongBend(g), p);
  const RigidityReport before = measureRigidityVoxels(cv, g, bodies);
  const RigidityReport beforeNodes = measureRigidity(cv, bodies);
  applyRigidity(cv, bodies, {10.0});
  const RigidityReport nodes = measureRigidity(cv, bodies);
  // Voxel level: the upsampled map that synthesis actually resamples with, every voxel.
  const RigidityReport after = measureRigidityVoxels(cv, g, bodies);
  ControlVolume noSnap = cv;  // what trilinear upsampling of the blended nodes alone gives
  noSnap.rigidSnap.reset();
  const RigidityReport interpolated = measureRigidityVoxels(noSnap, g, bodies);
  std::cout << "voxel level without the snap: bone RMS " << interpolated.boneRmsResidualMm << " mm (max "
            << interpolated.boneMaxResidualMm << "), folds " << interpolated.foldFraction << "\n";
  ASSERT_TRUE(cv.rigidSnap);
  {
    // The per-body reach boxes only skip voxels the snap cannot move: same map as snapping
    // everywhere.
    ControlVolume everywhere = cv;
    auto snap = std::make_shared<RigidSnap>(*cv.rigidSnap);
    snap->reachMm.clear();
    everywhere.rigidSnap = snap;
    EXPECT_EQ(upsampleMap(everywhere, g), upsampleMap(cv, g));
  }
  // The snap only corrects interpolation: soft tissue moves as before.
  EXPECT_NEAR(interpolated.softTissueMeanDisplacementMm, after.softTissueMeanDisplacementMm, 0.5);
  std::cout << "node level:  bone RMS " << beforeNodes.boneRmsResidualMm << " -> " << nodes.boneRmsResidualMm
            << " mm (max " << nodes.boneMaxResidualMm << "), soft tissue " << nodes.softTissueMeanDisplacementMm
            << " mm, folds " << nodes.foldFraction << "\n"
            << "voxel level: bone RMS " << before.boneRmsResidualMm << " -> " << after.boneRmsResidualMm
            << " mm (max " << after.boneMaxResidualMm << "), soft tissue " << after.softTissueMeanDisplacementMm
            << " mm, folds " << after.foldFraction << "\n";
  EXPECT_TRUE(after.voxelLevel);
  EXPECT_FALSE(nodes.voxelLevel);
  EXPECT_GT(before.boneRmsResidualMm, 0.5);  // plain MLS bends the bones
  EXPECT_LT(after.boneRmsResidualMm, 0.1);
  EXPECT_GE(after.softTissueMeanDisplacementMm, 10.0);
  EXPECT_EQ(after.foldFraction, 0.0);
  EXPECT_GT(after.boneNodes, 8000);
  EXPECT_LT(nodes.boneRmsResidualMm, 0.1);
  EXPECT_EQ(nodes.foldFraction, 0.0);
  // A strided subset measures the same map.
  const RigidityReport strided = measureRigidityVoxels(cv, g, bodies, Upsampling::Trilinear, 2);
  EXPECT_EQ(strided.stride, 2);
  EXPECT_LT(strided.boneRmsResidualMm, 0.1);
  EXPECT_NEAR(strided.softTissueMeanDisplacementMm, after.softTissueMeanDisplacementMm, 1.0);
}

TEST(Rigidity, DensityAwareWeightsBendBoneLessThanPlainMls) {
  const AnyVolume ct = knee().ct;
  const auto bodies = RigidBodies::fromLabels(knee().labels, boneIds());
  const ControlPoints pts = strongBend(knee().ct.geometry());
  DeformParams plain;
  plain.controlScale = 2;
  DeformParams dense = plain;
  dense.density.enabled = true;
  const auto rPlain = measureRigidity(computeControlVolume(ct, pts, plain), bodies);
  const auto rDense = measureRigidity(computeControlVolume(ct, pts, dense), bodies);
  std::cout << "bone RMS residual: plain " << rPlain.boneRmsResidualMm << " mm, density-aware "
            << rDense.boneRmsResidualMm << " mm\n";
  EXPECT_LT(rDense.boneRmsResidualMm, rPlain.boneRmsResidualMm);
}

TEST(Rigidity, DemoBendHasNoFoldOver) {
  const AnyVolume ct = knee().ct;
  const auto bodies = RigidBodies::fromLabels(knee().labels, boneIds());
  const KeyframeTrack track = kneeBendTrack(knee().ct.geometry(), 15.0, 2.0, phantom::flexionAxisPointMm());
  DeformParams p;
  p.controlScale = 2;
  Deformer d(ct, p);
  for (int f = 0; f < track.frameCount(10); ++f) {
    d.setPoints(track.at(track.frameTimeS(f, 10)));
    ControlVolume cv = d.update();
    applyRigidity(cv, bodies, {10.0});
    const auto r = measureRigidityVoxels(cv, knee().ct.geometry(), bodies);
    EXPECT_EQ(r.foldFraction, 0.0) << "frame " << f;
    EXPECT_LT(r.boneRmsResidualMm, 0.1) << "frame " << f;
  }
}
