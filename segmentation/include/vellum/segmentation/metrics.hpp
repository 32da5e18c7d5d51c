#pragma once
// Quality of a segmentation against a truth: overlap and surface distances, in mm.
#include <cstdint>
#include <vector>

#include "vellum/core/label_volume.hpp"
#include "vellum/segmentation/mask.hpp"

namespace vellum::segmentation {

struct OverlapMetrics {
  int64_t voxels = 0;         ///< |A|
  int64_t truthVoxels = 0;    ///< |B|
  int64_t intersection = 0;   ///< |A ∩ B|
  double dice = 0;            ///< 2|A∩B| / (|A|+|B|); 1 when both are empty
  double jaccard = 0;         ///< |A∩B| / |A∪B|; 1 when both are empty
  double volumeMm3 = 0, truthVolumeMm3 = 0;
  double volumeDifferenceMm3 = 0;      ///< volume(A) - volume(B)
  double volumeDifferencePercent = 0;  ///< 100 * (A-B)/B; 0 when B is empty (and A too)
};

struct SegmentMetrics : OverlapMetrics {
  uint16_t id = 0;
  /// 95th percentile of the symmetric surface distance (mm): the larger of the 95th
  /// percentiles of the distances from A's boundary voxels to B's boundary voxels and back.
  /// +infinity when exactly one of the two is empty, 0 when both are.
  double hd95Mm = 0;
  double hausdorffMm = 0;     ///< the maximum (same conventions)
  double meanSurfaceDistanceMm = 0;  ///< mean over both directions
};

/// Voxel overlap of two masks (same geometry).
OverlapMetrics overlap(const Mask& a, const Mask& truth);

/// Overlap plus surface distances. Boundary voxels: mask voxels with a 6-neighbour that is
/// outside the mask or outside the grid. Distances are exact Euclidean, between voxel centres.
SegmentMetrics compareMasks(const Mask& a, const Mask& truth);

/// Per-id metrics for every id >= 1 present in either map (or only `ids` when given).
std::vector<SegmentMetrics> compareLabels(const VolumeU16& labels, const VolumeU16& truth,
                                          const std::vector<uint16_t>& ids = {});

}  // namespace vellum::segmentation
