#pragma once
// The tests' small hand-made volumes in one place: a grid, a loop over its voxels, and shapes
// (boxes, balls, any predicate on the voxel index) filled with a value, for Volume<T> and
// LabelVolume alike, instead of a triple loop in every test.
#include <cstdint>
#include <type_traits>

#include "vellum/core/geometry.hpp"
#include "vellum/core/label_volume.hpp"
#include "vellum/core/volume.hpp"

namespace vellum::test {

/// `dims` voxels of `spacingMm`, origin 0, identity directions.
inline Geometry grid(const Dims& dims, const Vec3& spacingMm = {1, 1, 1}) {
  Geometry g;
  g.dims = dims;
  g.spacing = spacingMm;
  return g;
}

/// fn(i, j, k) for every voxel of `dims`, i fastest.
template <class F>
void forEachVoxel(const Dims& dims, F fn) {
  for (int64_t k = 0; k < dims.z; ++k)
    for (int64_t j = 0; j < dims.y; ++j)
      for (int64_t i = 0; i < dims.x; ++i) fn(i, j, k);
}

/// The half-open voxel box [i0, i1) x [j0, j1) x [k0, k1) as a predicate on (i, j, k).
inline auto voxelBox(int64_t i0, int64_t i1, int64_t j0, int64_t j1, int64_t k0, int64_t k1) {
  return [=](int64_t i, int64_t j, int64_t k) { return i >= i0 && i < i1 && j >= j0 && j < j1 && k >= k0 && k < k1; };
}

/// Sets `volume`(i, j, k) (a Volume<T> or a LabelVolume) to `value` wherever inside(i, j, k).
template <class V, class Inside, class T>
V& fillWhere(V& volume, Inside inside, T value) {
  forEachVoxel(volume.geometry().dims, [&](int64_t i, int64_t j, int64_t k) {
    if (inside(i, j, k)) volume(i, j, k) = static_cast<std::remove_reference_t<decltype(volume(i, j, k))>>(value);
  });
  return volume;
}

}  // namespace vellum::test
