#pragma once
// Voxel grid geometry: dims, spacing, origin, direction (DICOM LPS, millimetres).
//   physical = origin + direction * (index ⊙ spacing)
// Voxel (i,j,k) has its centre at index coordinates (i,j,k); i varies fastest in memory.
#include <cstddef>
#include <cstdint>
#include <string>

#include "vellum/core/vec.hpp"

namespace vellum {

struct Dims {
  int64_t x = 0, y = 0, z = 0;
  constexpr int64_t operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  constexpr int64_t voxelCount() const { return x * y * z; }
  constexpr bool operator==(const Dims&) const = default;
  std::string str() const;  ///< "512x512x28"
};

struct Geometry {
  Dims dims;
  Vec3 spacing{1, 1, 1};  ///< mm between voxel centres along i, j, k
  Vec3 origin{0, 0, 0};   ///< mm, physical position of voxel (0,0,0)
  Mat3 direction;         ///< columns: unit physical directions of the i, j, k axes

  /// Continuous index (i,j,k) -> physical position in mm.
  Vec3 indexToPhysical(const Vec3& ijk) const { return origin + direction * mul(ijk, spacing); }
  /// Physical position in mm -> continuous index. Uses the inverse direction (which equals
  /// the transpose for orthonormal directions; general inverse otherwise).
  Vec3 physicalToIndex(const Vec3& p) const;
  /// physicalToIndex() for many points: the inverse direction is found once.
  struct ToIndex {
    Vec3 origin, spacing;
    Mat3 inverseDirection;
    Vec3 operator()(const Vec3& p) const { return div(inverseDirection * (p - origin), spacing); }
  };
  ToIndex physicalToIndexMap() const;
  /// Physical centre of the grid (mm).
  Vec3 center() const;
  /// Physical extent of the voxel-centre box along each index axis (mm).
  Vec3 extent() const;
  /// The smallest voxel spacing (mm): the finest step along any index axis.
  double minSpacing() const;
  bool contains(int64_t i, int64_t j, int64_t k) const {
    return i >= 0 && j >= 0 && k >= 0 && i < dims.x && j < dims.y && k < dims.z;
  }
  /// Throws vellum::Error when dims are non-positive, spacing is zero/negative/NaN, or the
  /// direction matrix is singular or not finite. `what` names the source in the message.
  void validate(const std::string& what) const;
  bool approxEqual(const Geometry& o, double tolMm = 1e-4) const;
};

}  // namespace vellum
