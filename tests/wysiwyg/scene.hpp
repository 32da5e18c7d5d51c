#pragma once
// A deformed, attributed, rigid-bone scene: the phantom knee bent by kneeBendTrack with its
// bones rigid (applyRigidity sets the voxel snap) and a lightness/hue attribute on two points.
#include <memory>

#include "vellum/deformation/deformer.hpp"
#include "vellum/deformation/placement.hpp"
#include "vellum/deformation/rigidity.hpp"
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

}  // namespace vellum::test
