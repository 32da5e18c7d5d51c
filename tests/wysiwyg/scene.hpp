#pragma once
// A deformed, attributed, rigid-bone scene: the phantom knee bent by kneeBendTrack with its
// bones rigid (applyRigidity sets the voxel snap) and a lightness/hue attribute on two points;
// and the same knee turned by the twist map (its kernel between nodes).
#include <memory>

#include "vellum/deformation/deformer.hpp"
#include "vellum/deformation/placement.hpp"
#include "vellum/deformation/pose.hpp"
#include "vellum/deformation/rigidity.hpp"
#include "vellum/deformation/twist_frames.hpp"
#include "vellum/phantom/phantom.hpp"

namespace vellum::test {

struct BentKnee {
  phantom::Phantom ph;
  std::unique_ptr<deformation::RigidBodies> bodies;
  deformation::ControlVolume plain;  ///< MLS map, no rigidity
  deformation::ControlVolume rigid;  ///< with applyRigidity (node blend + voxel snap)
};

inline BentKnee makeBentKnee(int size = 72, int scale = 2, double angleDeg = 30) {
  using namespace vellum::deformation;
  phantom::PhantomOptions o;
  o.dims = {size, size, size + size / 8};
  BentKnee k{phantom::makePhantom(o), nullptr, {}, {}};
  const AnyVolume ct = k.ph.ct;
  const KeyframeTrack track = kneeBendTrack(k.ph.ct.geometry(), angleDeg, 2.0, phantom::flexionAxisPointMm());
  DeformParams p;
  p.controlScale = scale;
  ControlPoints pts = track.keyframes[1].points;
  pts[0].attributes.lightness = 30;  // attribute fields over part of the volume
  pts[1].attributes.a = 25;
  pts[1].attributes.density = 1.5;
  k.plain = computeControlVolume(ct, pts, p);
  k.bodies = std::make_unique<RigidBodies>(RigidBodies::fromLabels(k.ph.labels, {4, 5, 6, 7, 8, 9, 11}));
  k.rigid = k.plain;
  applyRigidity(k.rigid, *k.bodies);
  return k;
}

/// A movie frame of the phantom knee through the twist map (deformation::TwistFrames at
/// `scale`: the twist kernel between nodes, the voxel snap): the femur (4, 5) still, the tibia
/// (6, 7) turned by `angleDeg` about the flexion axis, everything else blended.
struct TwistKnee {
  phantom::Phantom ph;
  std::unique_ptr<deformation::RigidBodies> bodies;
  std::shared_ptr<const deformation::ControlVolume> frame;
};

inline TwistKnee makeTwistKnee(int size = 72, int scale = 2, double angleDeg = 30) {
  using namespace vellum::deformation;
  phantom::PhantomOptions o;
  o.dims = {size, size, size + size / 8};
  TwistKnee k{phantom::makePhantom(o), nullptr, nullptr};
  Pose pose;
  Joint j;
  j.name = "knee";
  j.parent = {4, 5};
  j.child = {6, 7};
  j.axisA = phantom::flexionAxisPointMm();
  j.axisB = j.axisA + Vec3{10, 0, 0};
  pose.joints.push_back(j);
  linkJoints(pose);
  const std::vector<std::vector<uint16_t>> groups{{4, 5}, {6, 7}};
  k.bodies = std::make_unique<RigidBodies>(RigidBodies::fromLabelGroups(k.ph.labels, groups, 20, {}));
  const TwistFrames frames(pose, nodeBodiesOf(labelsAtNodes(k.ph.labels, scale), groups, scale, {}),
                           k.ph.ct.geometry(), scale);
  k.frame = frames.sharedAt({angleDeg}, *k.bodies);
  return k;
}

}  // namespace vellum::test
