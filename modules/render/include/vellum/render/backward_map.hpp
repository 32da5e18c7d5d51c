#pragma once
// A deformation as the renderer consumes it: the backward map u(v) sampled on a (usually
// coarse) grid over OUTPUT space, plus optional per-node attribute offsets. The renderer
// interpolates u trilinearly per ray sample and fetches the source volume at u, so no
// full-resolution deformed volume is ever made (algorithms.md 1.4).
#include <vector>

#include "vellum/core/geometry.hpp"

namespace vellum::render {

struct BackwardMap {
  /// Output-space grid of the map nodes (mm geometry). Rays are cast through this box.
  Geometry grid;
  /// grid.dims.voxelCount() * 3 floats, x fastest: for each node the SOURCE position in mm.
  std::vector<float> sourceMm;
  /// Empty, or grid.dims.voxelCount() * 4 floats: lightness offset (L*, -100..100),
  /// a offset, b offset (CIE L*a*b*), density scale (1 = unchanged).
  std::vector<float> attributes;
};

}  // namespace vellum::render
