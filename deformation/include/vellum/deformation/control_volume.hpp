#pragma once
// The control volume (algorithms.md 1.4): the backward map u(v) sampled on an output-space
// grid coarser than the volume by a factor s per axis. Same layout as
// vellum::render::BackwardMap, so the CLI/studio hand it to the renderer by moving the vectors.
#include <string>
#include <vector>

#include "vellum/core/geometry.hpp"

namespace vellum::deformation {

enum class Upsampling {
  Trilinear,  ///< default: fast, exact for affine maps
  Gaussian,   ///< separable 4-tap Gaussian (sigma 0.6 node), corrected to reproduce linear maps
};
const char* upsamplingName(Upsampling u);
Upsampling parseUpsampling(const std::string& name);  ///< "trilinear", "gaussian"

struct ControlVolume {
  /// Output-space node grid (mm geometry). Node (i,j,k) sits on output voxel (i*s, j*s, k*s).
  Geometry grid;
  int scale = 1;  ///< s
  /// 3 floats per node, x fastest: the SOURCE position u in mm.
  std::vector<float> sourceMm;
  /// Empty, or 4 floats per node: lightness, a, b offsets and density scale.
  std::vector<float> attributes;

  Vec3 sourceAt(int64_t node) const {
    const float* p = sourceMm.data() + 3 * node;
    return {p[0], p[1], p[2]};
  }
};

/// The node grid for an output geometry and factor s (1, 2, 4, ...): dims = ceil((d-1)/s)+1 so
/// that the last node reaches or passes the last voxel; spacing * s; same origin and direction.
Geometry controlGrid(const Geometry& output, int scale);

/// The identity map on a control grid (u = v): what no deformation looks like.
ControlVolume identityControlVolume(const Geometry& output, int scale);

}  // namespace vellum::deformation
