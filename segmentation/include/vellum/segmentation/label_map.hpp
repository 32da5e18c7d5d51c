#pragma once
// Adding binary segments into a multi-label map.
#include <array>
#include <map>
#include <string>
#include <vector>

#include "vellum/core/enum_table.hpp"
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
const params::EnumTable<OverlapRule>& overlapRules();
inline OverlapRule parseOverlapRule(const std::string& name) { return overlapRules().parse(name); }

struct AddResult {
  int64_t written = 0;   ///< voxels that now carry the id because of the mask
  int64_t skipped = 0;   ///< mask voxels left to another segment (KeepExisting)
  int64_t cleared = 0;   ///< voxels of the id outside the mask that were cleared (Replace)
};

/// Writes `mask` into `labels` under `label` (id >= 1; the table entry is added or replaced).
/// Geometries must match (vellum::Error otherwise).
AddResult addSegment(LabelVolume& labels, const Mask& mask, const Label& label,
                     OverlapRule rule = OverlapRule::Overwrite);

/// addSegment for many segments in one pass: voxels with object o (1..entries.size()) get
/// entries[o-1].id; 0 and larger values are not part of any segment. Counts are totals.
AddResult addSegments(LabelVolume& labels, const VolumeU16& objects, const std::vector<Label>& entries,
                      OverlapRule rule = OverlapRule::Overwrite);

/// The voxels of one id.
Mask segmentMask(const LabelVolume& labels, uint16_t id);

/// Moves ids: the voxels of each key get its value (0 drops them); ids not in `mapping` stay.
/// Pieces of a bone split apart become one id this way, and one id can be split off into a
/// new one. The table follows: a target without an entry takes its first source's name and
/// colour; ids left with no voxels lose their entries.
LabelVolume relabel(const LabelVolume& labels, const std::map<uint16_t, uint16_t>& mapping);

}  // namespace vellum::segmentation
