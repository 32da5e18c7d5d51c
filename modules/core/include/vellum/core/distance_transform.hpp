#pragma once
// Exact Euclidean distance transforms in millimetres (anisotropic spacing respected): the one
// implementation that segmentation (morphology, metrics, body mask), deformation (rigidity
// falloff) and illustration use.
#include "vellum/core/progress.hpp"
#include "vellum/core/volume.hpp"

namespace vellum {

/// Squared distance in mm² from every voxel centre to the nearest centre of a voxel with
/// features != 0 (0 on features; +infinity everywhere when there is no feature). Exact:
/// separable lower-envelope-of-parabolas algorithm (Felzenszwalb & Huttenlocher), one pass
/// per axis with that axis's spacing; parallel. Distances are measured in index space scaled
/// by spacing (the direction matrix is a rotation and does not change them).
VolumeF32 squaredDistanceMm(const VolumeU8& features, Progress& progress = Progress::none());

/// Signed distance in mm to the mask boundary, negative inside: for inside voxels minus the
/// distance to the nearest outside voxel, for outside voxels the distance to the nearest
/// inside voxel (voxel-centre distances, so |d| >= one voxel spacing off the boundary).
VolumeF32 signedDistanceMm(const VolumeU8& mask, Progress& progress = Progress::none());

}  // namespace vellum
