#pragma once
// The control volume ([HVD 1.4] in docs/references.md): the backward map u(v) sampled on an output-space
// grid coarser than the volume by a factor s per axis. Same layout as
// vellum::render::BackwardMap, so the CLI/studio hand it to the renderer by moving the vectors.
#include <array>
#include <cstdint>
#include <memory>
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

/// Voxel-level rigid snap, set by applyRigidity(): trilinear (or Gaussian) upsampling of a
/// blended node map is not rigid inside a bone whose control cells also touch soft tissue or
/// another bone (a control cell wider than the joint gap holds nodes of both bones). So after
/// upsampling, an output voxel v whose source position u lands inside rigid body c takes that
/// body's rigid transform exactly, u = R_c v + t_c, when that moves u by at most `maxSnapMm`
/// (it corrects interpolation, never a far MLS excursion into bone).
struct RigidSnap {
  /// Source-space classes (0 air, 1 soft tissue, 2 + c body c) on `classGrid`.
  std::shared_ptr<const std::vector<uint16_t>> classes;
  Geometry classGrid;
  /// Per body: R row-major (9) then t (3), mm; `valid[c]` false = body left to the map.
  std::vector<std::array<double, 12>> fits;
  std::vector<uint8_t> valid;
  double maxSnapMm = 0;
  /// Per body: axis-aligned box (output mm: min xyz, max xyz) holding every output voxel the
  /// snap can move to that body (skips the rest of the volume quickly). Empty = everywhere.
  std::vector<std::array<double, 6>> reachMm;
};

struct ControlVolume {
  /// Output-space node grid (mm geometry). Node (i,j,k) sits on output voxel (i*s, j*s, k*s).
  Geometry grid;
  int scale = 1;  ///< s
  /// 3 floats per node, x fastest: the SOURCE position u in mm.
  std::vector<float> sourceMm;
  /// Empty, or 4 floats per node: lightness, a, b offsets and density scale.
  std::vector<float> attributes;
  /// Empty, or the rigid bodies' voxel-level snap applied by synthesize() / upsampleMap()
  /// (the GL path samples the node map only and does not apply it).
  std::shared_ptr<const RigidSnap> rigidSnap;

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
