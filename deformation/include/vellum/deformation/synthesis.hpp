#pragma once
// Full-resolution synthesis of a deformed volume ([HVD 1.4] in docs/references.md): upsample the control
// volume's COORDINATES to every output voxel, then fetch the source there (trilinear,
// background outside). Same geometry and voxel type as the source.
#include <memory>
#include <optional>

#include "vellum/core/progress.hpp"
#include "vellum/core/volume.hpp"
#include "vellum/deformation/control_volume.hpp"

namespace vellum::deformation {

/// The deformed volume. `cv` must be built for the source's geometry (Deformer does that).
/// Integer types are rounded and saturated. Throws vellum::Error on mismatched grids.
AnyVolume synthesize(const AnyVolume& source, const ControlVolume& cv,
                     Upsampling upsampling = Upsampling::Trilinear,
                     Progress& progress = Progress::none());

/// The deformed volume from a full-resolution backward map (3 floats, source mm, per voxel of
/// `source`'s grid, x fastest: upsampleMap() or twistMap()), fetched as synthesize() does.
AnyVolume synthesizeFromMap(const AnyVolume& source, const std::vector<float>& mapMm,
                            Progress& progress = Progress::none());
/// The backward map at every output voxel: 3 floats (source position in mm) per voxel, x
/// fastest, upsampled from `cv` exactly as synthesize() does. Memory budget checked first.
std::vector<float> upsampleMap(const ControlVolume& cv, const Geometry& output,
                               Upsampling upsampling = Upsampling::Trilinear,
                               Progress& progress = Progress::none());

/// The backward map at arbitrary output positions (mm), for pictures whose pixels are not
/// voxels (the studio's slice views): the nodes interpolated with the taps upsampleMap() uses
/// at the voxels, then the rigid snap, so at every output voxel centre it gives what
/// upsampleMap() gives (float rounding aside). Owns its node map (move the control volume in
/// to spare the copy); thread-safe.
class MapSampler {
 public:
  /// `cv` must be built for `output` (throws vellum::Error otherwise, as synthesize() does).
  MapSampler(ControlVolume cv, const Geometry& output, Upsampling upsampling = Upsampling::Trilinear);
  /// The source position (mm) of output position `outputMm`; nullopt outside the output
  /// grid's voxel box (beyond half a voxel from the outer voxel centres: the deformed volume
  /// is background there). Between the outer centres and the box's faces the map is clamped
  /// onto the outer centres (upsampleMap() defines it at the voxels only).
  std::optional<Vec3> sourceMm(const Vec3& outputMm) const;
  /// sourceMm() along a row of n positions firstMm + i stepMm: 3 floats per position into
  /// `out`, and inside[i] = 0 where sourceMm() gives nullopt (out left as it was). Equal to
  /// sourceMm() up to float rounding; faster when the row runs along an output grid axis (a
  /// slice pixel row of a volume with identity direction): the two other axes are blended once.
  void sourceMmRow(const Vec3& firstMm, const Vec3& stepMm, int n, float* out, uint8_t* inside) const;
  const Geometry& output() const;
  Upsampling upsampling() const;

 private:
  struct Impl;
  std::shared_ptr<const Impl> impl_;
};

/// Peak signal-to-noise ratio (dB) of `test` against `reference` (same dims), with the peak
/// taken as the reference's value range. +infinity when identical.
double psnr(const AnyVolume& reference, const AnyVolume& test);

}  // namespace vellum::deformation
