#pragma once
// Separable Gaussian blur of a float volume in millimetres (anisotropic spacing respected):
// the one blur that the snake's edge speed (segmentation) and the lighting's ambient
// occlusion (render) use.
#include "vellum/core/progress.hpp"
#include "vellum/core/volume.hpp"

namespace vellum {

/// Blurs `v` in place with a Gaussian of standard deviation sigmaMm along each axis (that
/// axis's spacing turns it into voxels; the kernel reaches 3 sigma, at least one voxel each
/// side). Samples outside the grid count as `outside`. sigmaMm <= 0: unchanged. Parallel;
/// the result does not depend on the number of threads.
void gaussianBlurMm(VolumeF32& v, double sigmaMm, float outside, Progress& progress = Progress::none());

}  // namespace vellum
