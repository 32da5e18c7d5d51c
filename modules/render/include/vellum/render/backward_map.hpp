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
//   (core/gaussian_upsampling.hpp; outside the outermost nodes the position is clamped onto
//   them, no extrapolation); then the rigid snap, if any, exactly as CPU synthesis applies it
//   per voxel: if u lies in the class voxel of rigid body c (valid), and |R_c v + t_c - u| <=
//   maxSnapMm, u = R_c v + t_c. The source is sampled at u with background outside it, and
//   background also outside the `output` voxel box when that is set;
// - shading uses the source's gradient normal at u turned by the map: n ~ J^T n_source with
//   J = du/dv from central differences of the interpolated map half a node either side
//   (without the snap), so rotated parts are lit as rotated (RenderSettings::
//   turnDeformedNormals = false shades with n_source itself, the old behaviour);
// - attributes: (dL, da, db) shift the transfer-function colour in CIE L*a*b* (D65, sRGB),
//   density scales the optical depth: alpha' = 1 - (1 - alpha)^density. MIP ignores them.
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "vellum/core/geometry.hpp"

namespace vellum::render {

/// How u is interpolated between map nodes (the same two kernels as CPU synthesis).
enum class MapUpsampling { Trilinear, Gaussian };

/// Voxel-level snap of rigid bodies (the renderer's copy of deformation::RigidSnap).
struct MapRigidSnap {
  /// Source-space classes per voxel of `classGrid` (0 air, 1 soft tissue, 2 + c body c).
  std::shared_ptr<const std::vector<uint16_t>> classes;
  Geometry classGrid;
  /// Per body: R row-major (9) then t (3), mm: u = R v + t. `valid[c]` 0 = body not snapped.
  std::vector<std::array<double, 12>> fits;
  std::vector<uint8_t> valid;
  double maxSnapMm = 0;
};

/// The GL path keeps the per-body fits in a uniform array of this size.
constexpr int kMaxSnapBodies = 64;

struct BackwardMap {
  /// Output-space grid of the map nodes (mm geometry). Rays are cast through this box.
  Geometry grid;
  /// grid.dims.voxelCount() * 3 floats, x fastest: for each node the SOURCE position in mm.
  std::vector<float> sourceMm;
  /// Empty, or grid.dims.voxelCount() * 4 floats: lightness offset (L*, -100..100),
  /// a offset, b offset (CIE L*a*b*), density scale (1 = unchanged).
  std::vector<float> attributes;
  MapUpsampling upsampling = MapUpsampling::Trilinear;
  /// Empty, or the rigid snap applied after interpolating u (at most kMaxSnapBodies bodies).
  std::shared_ptr<const MapRigidSnap> rigidSnap;
  /// Empty, or the deformed volume's voxel grid (same direction as `grid`; the node grid of a
  /// control volume reaches up to s - 1/2 voxels beyond it): samples outside its voxel box see
  /// the background, as they do when the synthesised volume itself is rendered.
  std::optional<Geometry> output;
};

/// The identity map (u = v) on `grid`, optionally carrying attributes (4 floats per node) and
/// the output grid: renders an already deformed volume (`output`, the volume's own grid) with
/// the attribute fields of its deformation, exactly as the live deformed render draws it.
BackwardMap identityBackwardMap(const Geometry& grid, std::vector<float> attributes = {},
                                std::optional<Geometry> output = std::nullopt);

}  // namespace vellum::render
