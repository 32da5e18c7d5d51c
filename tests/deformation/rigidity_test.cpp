// Bone rigidity on the knee phantom (algorithms.md 1.3, 1.6).
#include <gtest/gtest.h>

#include <map>
#include <set>

#include "vellum/deformation/deformer.hpp"
#include "vellum/deformation/placement.hpp"
#include "vellum/deformation/rigidity.hpp"
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

std::vector<uint16_t> boneIds() { return {4, 5, 6, 7, 8, 9}; }

// A strong bend with a sideways sway: soft tissue moves a lot.
ControlPoints strongBend(const Geometry& g) {
  ControlPoints pts = kneeBendTrack(g, 40.0).keyframes[1].points;
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

TEST(Rigidity, RigidLabelsKeepBoneRigidWhileSoftTissueMoves) {
  const AnyVolume ct = knee().ct;
  const auto bodies = RigidBodies::fromLabels(knee().labels, boneIds());
  DeformParams p;
  p.controlScale = 2;
  ControlVolume cv = computeControlVolume(ct, strongBend(knee().ct.geometry()), p);
  const RigidityReport before = measureRigidity(cv, bodies);
  applyRigidity(cv, bodies, {10.0});
  const RigidityReport after = measureRigidity(cv, bodies);
  EXPECT_GT(before.boneRmsResidualMm, 0.5);  // plain MLS bends the bones
  EXPECT_LT(after.boneRmsResidualMm, 0.1);
  EXPECT_GE(after.softTissueMeanDisplacementMm, 10.0);
  EXPECT_EQ(after.foldFraction, 0.0);
  EXPECT_GT(after.boneNodes, 1000);
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
  const KeyframeTrack track = kneeBendTrack(knee().ct.geometry());
  DeformParams p;
  p.controlScale = 2;
  Deformer d(ct, p);
  for (int f = 0; f < track.frameCount(10); ++f) {
    d.setPoints(track.at(track.frameTimeS(f, 10)));
    ControlVolume cv = d.update();
    applyRigidity(cv, bodies, {10.0});
    const auto r = measureRigidity(cv, bodies);
    EXPECT_EQ(r.foldFraction, 0.0) << "frame " << f;
    EXPECT_LT(r.boneRmsResidualMm, 0.1) << "frame " << f;
  }
}
