#pragma once
// Adding binary segments into a multi-label map.
#include <array>
#include <string>

#include "vellum/core/label_volume.hpp"
#include "vellum/segmentation/mask.hpp"

namespace vellum::segmentation {

/// What happens where the new segment overlaps voxels that already carry another segment.
enum class OverlapRule {
  Overwrite,     ///< the new segment wins everywhere it is set
  KeepExisting,  ///< voxels of other segments keep their id; the segment fills background only
  Replace,       ///< the id's previous voxels are cleared first, then Overwrite
};
/// "overwrite" | "keep-existing" (alias "only-background") | "replace".
OverlapRule parseOverlapRule(const std::string& name);

struct AddResult {
  int64_t written = 0;   ///< voxels that now carry the id because of the mask
  int64_t skipped = 0;   ///< mask voxels left to another segment (KeepExisting)
  int64_t cleared = 0;   ///< voxels of the id outside the mask that were cleared (Replace)
};

/// Writes `mask` into `labels` under `label` (id >= 1; the table entry is added or replaced).
/// Geometries must match (vellum::Error otherwise).
AddResult addSegment(LabelVolume& labels, const Mask& mask, const Label& label,
                     OverlapRule rule = OverlapRule::Overwrite);

/// The voxels of one id.
Mask segmentMask(const LabelVolume& labels, uint16_t id);

}  // namespace vellum::segmentation
