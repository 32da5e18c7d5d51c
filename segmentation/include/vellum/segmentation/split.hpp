#pragma once
// Splitting a mask into separate objects — bones that touch at a joint, or one threshold that
// holds both feet — by a marker-based watershed on the distance to the background.
#include <cstdint>
#include <vector>

#include "vellum/core/params.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/core/volume.hpp"
#include "vellum/segmentation/mask.hpp"

namespace vellum::segmentation {

struct SplitParams {
  /// Contacts narrower than about twice this are cut: the markers are the pieces of the mask
  /// deeper than this below its surface (one per object). 0 = the connected pieces themselves.
  double neckMm = 2.0;
  /// Objects smaller than this merge into the neighbour they share most boundary with, or are
  /// dropped when they touch none.
  double minVolumeMm3 = 500.0;
  /// Seeds (mm, on the mask): one object per seed instead of the automatic markers; pieces of
  /// the mask that hold no seed are dropped.
  std::vector<Vec3> seedsMm;
};

/// neck, min_volume (the seeds are a list, not a table row).
const params::Table<SplitParams>& splitParamsTable();

struct SplitResult {
  VolumeU16 objects;                ///< 0 outside, 1..count: largest object first
  std::vector<double> volumesMm3;   ///< per object (index 0 unused)
  double droppedMm3 = 0;            ///< mask volume left out (pieces below the minimum, unseeded pieces)
  int markers = 0;                  ///< markers flooded from (before small objects merged)
  int count() const { return static_cast<int>(volumesMm3.size()) - 1; }
};

/// Splits `mask` into objects: markers (seeds, or the 26-connected pieces of the mask deeper
/// than neckMm) grow over the mask in order of decreasing depth (priority flood, 26 neighbours),
/// so two bones joined by a thin contact meet at the contact's narrowest place. Mask pieces
/// that no marker reaches become objects of their own. Deterministic (no thread dependence).
/// Throws vellum::Error for a seed outside the grid or on background.
SplitResult splitObjects(const Mask& mask, const SplitParams& params = {}, Progress& progress = Progress::none());

}  // namespace vellum::segmentation
