#pragma once
// Boxes in mm: one grown point by point (BoxMm), and the eight corners of a box: an
// axis-aligned one from two opposite corners, an index range of a grid in mm, or a grid's whole
// voxel box in mm. Its own small header so that only the
// places that frame or clip a box include it.
#include <algorithm>
#include <array>
#include <limits>

#include "vellum/core/geometry.hpp"
#include "vellum/core/vec.hpp"

namespace vellum {

/// An axis-aligned box (mm); empty until a point is added.
struct BoxMm {
  Vec3 lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
          std::numeric_limits<double>::infinity()};
  Vec3 hi = -lo;
  bool empty() const { return !(lo.x <= hi.x); }
  void add(const Vec3& p) {
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
  }
};

/// The corners of the axis-aligned box with opposite corners lo and hi: corner c takes hi's
/// coordinate on the axes whose bit is set in c (bit 0 x, bit 1 y, bit 2 z), lo's on the others.
inline std::array<Vec3, 8> boxCorners(const Vec3& lo, const Vec3& hi) {
  std::array<Vec3, 8> out;
  for (int c = 0; c < 8; ++c) out[size_t(c)] = {(c & 1) ? hi.x : lo.x, (c & 2) ? hi.y : lo.y, (c & 4) ? hi.z : lo.z};
  return out;
}

/// The physical corners (mm) of the grid's continuous index range lo..hi, in boxCorners' order.
inline std::array<Vec3, 8> indexBoxCorners(const Geometry& g, const Vec3& lo, const Vec3& hi) {
  std::array<Vec3, 8> out = boxCorners(lo, hi);
  for (Vec3& p : out) p = g.indexToPhysical(p);
  return out;
}

/// The physical corners (mm) of the grid's voxel box: the outer voxel faces (index -0.5 to
/// dims - 0.5), not the outer voxel centres.
inline std::array<Vec3, 8> voxelBoxCorners(const Geometry& g) {
  const Dims& d = g.dims;
  return indexBoxCorners(g, {-0.5, -0.5, -0.5}, {d.x - 0.5, d.y - 0.5, d.z - 0.5});
}

/// The radius of the sphere about `centre` (mm) that holds the grid's voxel box: how the
/// renderers frame a volume.
inline double voxelBoxRadius(const Geometry& g, const Vec3& centre) {
  double radius = 0;
  for (const Vec3& p : voxelBoxCorners(g)) radius = std::max(radius, norm(p - centre));
  return radius;
}

}  // namespace vellum
