#pragma once
// Rotation about an axis through the origin (Rodrigues), as a vector operation and as a matrix:
// the twist map, its kernel, the pose's joints and the demo bend all turn by it.
#include <cmath>

#include "vellum/core/vec.hpp"

namespace vellum {

/// `p` (relative to a point on the axis) turned by `rad` about the unit axis `a`.
inline Vec3 rotateAbout(const Vec3& p, const Vec3& a, double rad) {
  const double c = std::cos(rad), s = std::sin(rad);
  return p * c + cross(a, p) * s + a * (dot(a, p) * (1 - c));
}

/// The rotation by `rad` about the unit axis `a` as a matrix (the same turn as rotateAbout).
inline Mat3 rotationMatrix(const Vec3& a, double rad) {
  const double c = std::cos(rad), s = std::sin(rad), k = 1 - c;
  return Mat3::fromColumns({c + k * a.x * a.x, k * a.x * a.y + s * a.z, k * a.x * a.z - s * a.y},
                           {k * a.x * a.y - s * a.z, c + k * a.y * a.y, k * a.y * a.z + s * a.x},
                           {k * a.x * a.z + s * a.y, k * a.y * a.z - s * a.x, c + k * a.z * a.z});
}

}  // namespace vellum
