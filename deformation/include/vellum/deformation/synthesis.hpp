#pragma once
// Full-resolution synthesis of a deformed volume ([HVD 1.4] in docs/references.md): upsample the control
// volume's COORDINATES to every output voxel, then fetch the source there (trilinear,
// background outside). Same geometry and voxel type as the source.
#include "vellum/core/progress.hpp"
#include "vellum/core/volume.hpp"
#include "vellum/deformation/control_volume.hpp"

namespace vellum::deformation {

/// The deformed volume. `cv` must be built for the source's geometry (Deformer does that).
/// Integer types are rounded and saturated. Throws vellum::Error on mismatched grids.
AnyVolume synthesize(const AnyVolume& source, const ControlVolume& cv,
                     Upsampling upsampling = Upsampling::Trilinear,
                     Progress& progress = Progress::none());

/// The backward map at every output voxel: 3 floats (source position in mm) per voxel, x
/// fastest, upsampled from `cv` exactly as synthesize() does. Memory budget checked first.
std::vector<float> upsampleMap(const ControlVolume& cv, const Geometry& output,
                               Upsampling upsampling = Upsampling::Trilinear,
                               Progress& progress = Progress::none());

/// Peak signal-to-noise ratio (dB) of `test` against `reference` (same dims), with the peak
/// taken as the reference's value range. +infinity when identical.
double psnr(const AnyVolume& reference, const AnyVolume& test);

}  // namespace vellum::deformation
