#pragma once
// Deterministic analytic CT-like volumes and backward maps for the renderer tests.
#include "vellum/core/volume.hpp"
#include "vellum/render/backward_map.hpp"

namespace vellum::test {

/// n^3 int16, background -1000 HU, anisotropic spacing (1.0, 1.3, 1.6) mm, a direction
/// rotated 20 degrees about (1,2,3), centre at (10,-20,30) mm. Soft-tissue ellipsoid (40 HU, semi-axes
/// 26 x 32 x 40 mm), an off-centre bone ball (1000 HU) and a tilted 500 HU cylinder, all with
/// 2.5 mm smooth edges. Shapes are defined in physical mm, so they do not depend on n.
VolumeI16 makeAnalyticVolume(int n = 64);

/// n^3 int16 with identity direction and isotropic `spacing`, centred at the origin:
/// background -1000, one ball of `value` HU and radius `radiusMm` centred at `centre` (mm).
VolumeI16 makeBallVolume(int n, double spacing, double radiusMm, double value = 1000,
                         Vec3 centre = {0, 0, 0});

/// A twist about the volume's superior axis (angle grows along z) plus a shift, on a
/// `nodes`^3 grid slightly larger than the volume's box; with attributes when asked.
render::BackwardMap makeTwistMap(const Geometry& volume, int nodes, bool withAttributes);

/// The identity map on the volume's own grid (nodes at the voxel centres).
render::BackwardMap makeIdentityMap(const Geometry& volume);

}  // namespace vellum::test
