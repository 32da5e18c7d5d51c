#pragma once
// A deformation as the renderer consumes it: the backward map u(v) sampled on a (usually
// coarse) grid over OUTPUT space, plus optional per-node attribute offsets. The renderer
// interpolates u trilinearly per ray sample and fetches the source volume at u, so no
// full-resolution deformed volume is ever made ([HVD 1.4] in docs/references.md).
//
// How it is rendered (GL shader and renderReferenceCpu alike):
// - rays are clipped to the grid's voxel box ([-0.5, dims-0.5] in grid index space) and
//   stepped by RenderSettings::stepVoxels * the SOURCE volume's smallest spacing;
// - u is interpolated trilinearly between nodes, clamping to the outermost nodes (no
//   extrapolation); the source is sampled at u with background outside it;
// - shading uses the source's gradient normal at u, NOT rotated by the map's Jacobian
//   (lighting on strongly rotated parts is approximate);
// - attributes: (dL, da, db) shift the transfer-function colour in CIE L*a*b* (D65, sRGB),
//   density scales the optical depth: alpha' = 1 - (1 - alpha)^density. MIP ignores them.
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
