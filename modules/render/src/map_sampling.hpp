#pragma once
// The backward map as both ray casters sample it: node positions in SOURCE index coordinates
// (padded for the Gaussian kernel), and the rigid snap (core SnapFrame) in the frames the shader
// works in (map node index p -> source index). The CPU reference (PreparedMap::at) is what
// the GLSL (shaders/raycast.frag.glsl: mapAt(), snapRigid()) computes, on the CPU.
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "vellum/core/geometry.hpp"
#include "vellum/render/backward_map.hpp"

namespace vellum::render::detail {

struct PreparedMap {
  Upsampling upsampling = Upsampling::Trilinear;
  Dims nodes;     ///< the map's node grid
  Dims texDims;   ///< grid of texture(): the nodes, or (Gaussian) nodes + 1 below and + 2 above
  std::vector<float> index;   ///< source index coordinates per node (3 floats, x fastest)
  std::vector<float> padded;  ///< Gaussian: `index` padded to texDims; empty for trilinear
  /// The node texture the GL path uploads (3 floats per texel of texDims).
  const std::vector<float>& texture() const { return padded.empty() ? index : padded; }
  /// Floats per texel of texels(): the twist kernel's stages (its weights), or 3 (positions).
  int texelFloats() const { return twist ? int(twist->stride()) : 3; }
  const std::vector<float>& texels() const { return twist ? twist->weights : texture(); }
  std::optional<SnapFrame> snap;
  double snapMarginVoxels = 0;  ///< how far (source voxels, per axis) the snap can move u
  /// The twist kernel (BackwardMap::twist), or none: u at p is then the kernel's (in mm from
  /// the node grid's mm, to source index), and the texture holds its weights, not `index`.
  std::shared_ptr<const TwistKernel> twist;
  Geometry nodeGrid;
  Geometry::ToIndex mmToNode, mmToSource;
  double twistMarginVoxels = 0;  ///< TwistKernel::chordBoundMm in source voxels
  /// With BackwardMap::output: output voxel index x = scale * p + offset per axis (same
  /// direction), and the output dims.
  struct OutputAxes {
    Vec3 scale, offset, dims;
  };
  std::optional<OutputAxes> output;
  /// Source index far outside every volume (its value is the background).
  static constexpr double kOutside = -1.0e6;

  /// u (source index) at map node index p: interpolated, then snapped (`snappedBody`: the
  /// body that moved it, or -1).
  Vec3 at(const Vec3& p, int* snappedBody = nullptr) const;
  /// u at p interpolated from the nodes (core interpolateNodes, the position clamped onto the
  /// nodes), without the snap (mapAt() in the shader).
  Vec3 interpolated(const Vec3& p) const;

  /// The node texture `index` filtered trilinearly at node index p (clamped to its texels):
  /// the map the shading normals differentiate, one hardware fetch in the shader under either
  /// kernel (the Gaussian kernel's 8 fetches per evaluation would make them 48).
  Vec3 nodeTexture(const Vec3& p) const;

  /// Shading normals of deformed samples. The deformed volume is f(u(x)), so its gradient is
  /// J^T grad f(u) with J = du/dx: the source normal `n` (physical, sampled at u(p)) turned
  /// into output space. J comes from central differences of the node texture (nodeTexture)
  /// kNormalStepNodes either side of p (the twist kernel: TwistKernel::jacobian, from its
  /// weights' differences as far either side); where the rigid snap moved the sample (`snappedBody`
  /// >= 0) J is that body's linear part, exactly: near a bone's surface the node map's
  /// differences straddle the rigid and the blended motion. The result keeps n's length and
  /// magnitude channel, so the shading's weak-gradient fade is the source's; the shader's
  /// deformedNormal() computes the same.
  std::array<float, 4> turnNormal(const Vec3& p, const std::array<float, 4>& n, int snappedBody = -1) const;
  static constexpr double kNormalStepNodes = 0.5;
  /// For turnNormal() and the shader: physical normal -> source index covector (S^T for
  /// S = source index -> mm), and node index covector -> physical normal (G^-T, G = node
  /// index -> mm).
  Mat3 normalToSourceIndex, nodeIndexToNormal;
  /// How much of the value at p comes from the volume rather than the background: 1 inside
  /// the output voxel centres, fading to 0 one voxel beyond them, as a texture with the
  /// background as border colour fades (the synthesised volume rendered plainly).
  double outputWeight(const Vec3& p) const;
};

/// Throws vellum::Error for malformed maps (sizes, non-finite snap, more than kMaxSnapBodies).
PreparedMap prepareMap(const BackwardMap& map, const Geometry& source);

}  // namespace vellum::render::detail
