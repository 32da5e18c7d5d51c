#pragma once
// Small geometry of hinge axes shared by the two axis estimates (joint_axis.cpp: the articular
// surfaces' fit; joint_motion.cpp: the motion search).
#include <Eigen/Core>

#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

#include "vellum/core/label_volume.hpp"
#include "vellum/core/region.hpp"

namespace vellum::deformation::axis {

/// The voxel boxes of the voxels whose id `table` (65536 entries) marks 1 and 2, in one pass
/// over the labels (a box with no voxel: hi[0] < 0). Defined in joint_motion.cpp.
std::array<VoxelBox, 2> markedBoxes(const LabelVolume& labels, const std::vector<uint8_t>& table);

/// Two unit vectors completing unit `d` to an orthonormal basis (d, u, v).
inline void basisAcross(const Eigen::Vector3d& d, Eigen::Vector3d& u, Eigen::Vector3d& v) {
  u = (std::abs(d.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY()).cross(d).normalized();
  v = d.cross(u);
}

/// `n` unit directions spread evenly over the upper hemisphere (z > 0; an axis and its
/// opposite are one): a Fibonacci lattice, neighbours ~ sqrt(2 pi / n) rad apart.
inline std::vector<Eigen::Vector3d> hemisphereDirections(int n) {
  std::vector<Eigen::Vector3d> out;
  out.reserve(n);
  const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double z = (i + 0.5) / n, rxy = std::sqrt(1 - z * z), phi = golden * i;
    out.emplace_back(rxy * std::cos(phi), rxy * std::sin(phi), z);
  }
  return out;
}

/// Every (size / most)-th element, at most `most` (deterministic).
template <class T>
std::vector<T> thinned(const std::vector<T>& p, size_t most) {
  if (p.size() <= most) return p;
  std::vector<T> out;
  const double step = double(p.size()) / double(most);
  for (size_t i = 0; i < most; ++i) out.push_back(p[size_t(i * step)]);
  return out;
}

}  // namespace vellum::deformation::axis
