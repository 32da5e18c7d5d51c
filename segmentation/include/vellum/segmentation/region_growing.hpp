#pragma once
// Region growing from seed points: connected threshold and confidence-connected.
#include <vector>

#include "vellum/core/progress.hpp"
#include "vellum/segmentation/threshold.hpp"

namespace vellum::segmentation {

/// Voxels inside `interval` connected to at least one seed (mm) through voxels inside
/// `interval`. Seeds outside the interval start nothing. Iterative (queue), never recursive.
/// Throws vellum::Error when a seed lies outside the grid.
Mask connectedThreshold(const VolumeI16& ct, const std::vector<Vec3>& seedsMm,
                        const HuInterval& interval,
                        Connectivity connectivity = Connectivity::Face6,
                        Progress& progress = Progress::none());

struct ConfidenceParams {
  double multiplier = 2.5;          ///< interval = mean ± multiplier * std
  int iterations = 4;               ///< re-estimate mean/std from the region this many times
  double seedRadiusMm = 2.0;        ///< first estimate from the voxels within this radius of the seeds
  Connectivity connectivity = Connectivity::Face6;
};

struct ConfidenceResult {
  Mask mask;
  HuInterval finalInterval;   ///< the interval of the last growing pass
  double mean = 0, stddev = 0;
  int iterations = 0;         ///< passes actually run (stops early when the region stops changing)
};

/// Confidence-connected growing (as in ITK): estimate mean and standard deviation around
/// the seeds, grow with mean ± k·std, re-estimate from the grown region, repeat.
ConfidenceResult confidenceConnected(const VolumeI16& ct, const std::vector<Vec3>& seedsMm,
                                     const ConfidenceParams& params = {},
                                     Progress& progress = Progress::none());

}  // namespace vellum::segmentation
