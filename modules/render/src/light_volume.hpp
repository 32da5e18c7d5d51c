#pragma once
// The light volume of the cinematic lighting terms (docs/lighting.md): per cell of a coarse
// grid over the source volume, the transmittance towards a directional key light (volumetric
// shadow) and the ambient openness (1 - occlusion), both from the transfer function's opacity.
// The GL ray caster samples it as an RG8 texture, the CPU reference with sample(); both from
// the same bytes. Internal to modules/render.
#include <array>
#include <cstdint>
#include <vector>

#include "map_sampling.hpp"
#include "render_common.hpp"
#include "vellum/core/volume.hpp"

namespace vellum::render::detail {

/// The key light's direction (unit, physical, pointing from the scene towards the light) for a
/// frame's camera basis.
Vec3 keyLightDirection(const Frame& f, const Lighting& l);

struct LightVolume {
  Dims dims;       ///< cells
  int factor = 1;  ///< source voxels per cell along each axis
  std::vector<uint8_t> rg;  ///< per cell: transmittance, openness (0..255), x fastest
  /// The frame's box index p (the source index; under a deformation the map node index) ->
  /// the light source's grid index w = (p + 0.5) * boxToSource - 0.5 (LightSource's).
  Vec3 boxToSource{1, 1, 1};
  /// Box index p -> cell index: (p + 0.5) * boxToSource / factor - 0.5 (the texture coordinate
  /// is (p + 0.5) * boxToSource / (factor * dims)).
  Vec3 cellOf(const Vec3& p) const;
  /// Box index offset that moves one cell towards the light (against self-shadowing).
  Vec3 towardsLight;
  /// Trilinear, clamped to the edge, as GL filters the RG8 texture: {transmittance, openness}.
  std::array<float, 2> sample(const Vec3& u) const;
};

/// The values the light volume is made from, kept by the renderer (the GL textures are not
/// readable back): the source itself (as float) up to 192 voxels per axis, else the means of
/// 2x2x2 blocks (an eighth of the voxels), with the source voxels per value voxel.
struct LightSource {
  /// The block means in the volume's own type (int16 CT: 2 bytes a value, not float's 4 —
  /// held for as long as the volume is drawn; the deformed source's are float).
  AnyVolume values;
  int factor = 1;
  Geometry source;
  /// The frame's box index p -> `source` index: (p + 0.5) * boxToSource - 0.5 (1: the box is
  /// the source itself).
  Vec3 boxToSource{1, 1, 1};
  /// Empty, or per value voxel the deformation's density scale (optical depth times it).
  std::vector<float> densityScale;
};
LightSource makeLightSource(const AnyVolume& volume);
/// The same from an int16 volume without an AnyVolume copy (the same values).
LightSource makeLightSource(const VolumeI16& volume);

/// Under a deformation the shadows belong to the deformed anatomy (a bending knee casts the
/// bent knee's shadows): the light source in OUTPUT space, over the map's box (its node
/// grid's voxel box) at about the undeformed light volume's cell size, one value per cell (at
/// most kDeformedValuesPerAxis values along the longest axis), each value the undeformed one
/// sampled at the map's u as the ray casters sample it (interpolated, snapped, faded to the
/// background outside the output box), with the map's density scale. Parallel; deterministic.
LightSource deformedLightSource(const LightSource& undeformed, const PreparedMap& map, const BackwardMap& m);
constexpr int kDeformedValuesPerAxis = 256;  ///< a bound; the cell size gives about 192
/// The CPU references' light source: the volume's, or through `map` (prepared) its deformed one.
LightSource lightSourceFor(const AnyVolume& volume, const BackwardMap* map, const PreparedMap& prepared);

/// Cells of about 1/192 of the largest axis (a multiple of the source's factor); extinction
/// per mm from the table's alpha (per step of stepMm), averaged per cell; the shadow swept
/// slice by slice away from the light (exact for a directional light, bilinear between
/// slices); openness 2 * (1 - local mean cell opacity) clamped to [0, 1], the mean over a
/// Gaussian of lighting.occlusionRadiusMm / 2 with air outside the box (a flat surface is
/// open, a crevice dark). lightSizeDeg > 0: a disc light of that angular radius, soft shadow
/// edges (an approximation: see the sweep). Parallel; deterministic.
LightVolume computeLightVolume(const LightSource& source, const TfTable& tf, double stepMm, const Vec3& lightDir,
                               const Lighting& lighting, double lightSizeDeg = 0);

}  // namespace vellum::render::detail
