#pragma once
// A pose of one hinge, built by hand as the pose tests need it: parent and child one label id
// each, the axis through a -> b (mm), linked (no fixed region, no keyframe).
#include <string>

#include "vellum/deformation/pose.hpp"

namespace vellum::test {

inline deformation::Pose hingePose(const std::string& name, uint16_t parent, uint16_t child, const Vec3& a,
                                   const Vec3& b) {
  deformation::Pose pose;
  deformation::Joint joint;
  joint.name = name;
  joint.parent = {parent};
  joint.child = {child};
  joint.axisA = a;
  joint.axisB = b;
  pose.joints.push_back(joint);
  deformation::linkJoints(pose);
  return pose;
}

}  // namespace vellum::test
