#pragma once
// Small analytic volumes for the segmentation tests.
#include <cmath>

#include "vellum/core/volume.hpp"
#include "vellum/segmentation/mask.hpp"

namespace vellum::segmentation::test {

inline Geometry grid(int64_t nx, int64_t ny, int64_t nz, Vec3 spacing = {1, 1, 1}) {
  Geometry g;
  g.dims = {nx, ny, nz};
  g.spacing = spacing;
  return g;
}

/// Physical centre of the grid (identity direction, origin 0).
inline Vec3 centreMm(const Geometry& g) { return g.indexToPhysical({(g.dims.x - 1) / 2.0, (g.dims.y - 1) / 2.0, (g.dims.z - 1) / 2.0}); }

/// CT with `inside` HU within radiusMm of centre, `outside` elsewhere.
inline VolumeI16 sphereCt(const Geometry& g, const Vec3& c, double r, int16_t inside, int16_t outside) {
  VolumeI16 v(g, outside, kCtAirHu);
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i)
        if (norm(g.indexToPhysical({double(i), double(j), double(k)}) - c) <= r) v(i, j, k) = inside;
  return v;
}

inline Mask sphereMask(const Geometry& g, const Vec3& c, double r) {
  Mask m(g, 0, 0.0);
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i)
        m(i, j, k) = norm(g.indexToPhysical({double(i), double(j), double(k)}) - c) <= r;
  return m;
}

/// Box [lo, hi] in index coordinates (inclusive).
inline void fillBox(Mask& m, Index3 lo, Index3 hi, uint8_t v = 1) {
  for (int64_t k = lo.k; k <= hi.k; ++k)
    for (int64_t j = lo.j; j <= hi.j; ++j)
      for (int64_t i = lo.i; i <= hi.i; ++i) m(i, j, k) = v;
}

}  // namespace vellum::segmentation::test
