#pragma once
// A deformation as the renderer consumes it: the backward map u(v) sampled on a (usually
// coarse) grid over OUTPUT space, plus optional per-node attribute offsets. The renderer
// interpolates u trilinearly per ray sample and fetches the source volume at u, so no
// full-resolution deformed volume is ever made ([HVD 1.4] in docs/references.md).
//
// How it is rendered (GL shader and renderReferenceCpu alike):
// - rays are clipped to the grid's voxel box ([-0.5, dims-0.5] in grid index space) and
//   stepped by RenderSettings::stepVoxels * the SOURCE volume's smallest spacing;
// - u is interpolated between nodes, trilinearly or with the Gaussian kernel of CPU synthesis
//   (core/backward_map.hpp; outside the outermost nodes the position is clamped onto them, no
//   extrapolation); then the rigid snap, if any, as CPU synthesis applies it per voxel
//   (SnapFrame): if u lies in the class voxel of rigid body c (valid), and |R_c v + t_c - u| <=
//   maxSnapMm, u = R_c v + t_c. The source is sampled at u with background outside it, and
//   background also outside the `output` voxel box when that is set;
// - shading uses the source's gradient normal at u turned by the map: n ~ J^T n_source with
//   J = du/dv from central differences of the interpolated map half a node either side
//   (without the snap), so rotated parts are lit as rotated (RenderSettings::
//   turnDeformedNormals = false shades with n_source itself, the old behaviour);
// - attributes: (dL, da, db) shift the transfer-function colour in CIE L*a*b* (D65, sRGB),
//   density scales the optical depth: alpha' = 1 - (1 - alpha)^density. MIP ignores them.
#include <optional>
#include <vector>

#include "vellum/core/backward_map.hpp"

namespace vellum::render {

/// The one map model (core/backward_map.hpp), by the name the renderer's API uses.
using BackwardMap = vellum::BackwardMap;

/// The GL path keeps the per-body fits in a uniform array of this size.
constexpr int kMaxSnapBodies = 64;

/// The identity map (u = v) on `grid`, optionally carrying attributes (4 floats per node) and
/// the output grid: renders an already deformed volume (`output`, the volume's own grid) with
/// the attribute fields of its deformation, exactly as the live deformed render draws it.
BackwardMap identityBackwardMap(const Geometry& grid, std::vector<float> attributes = {},
                                std::optional<Geometry> output = std::nullopt);

}  // namespace vellum::render
