#pragma once
// Label colours in the 3D view: each ray sample takes the colour of the label at its source
// position (nearest voxel), mixed into the transfer function's colour by
// RenderSettings::labelBlend before shading, so segments show in their label-table colours
// while the volume keeps its opacity and lighting (3D Slicer's "segmentation in 3D" over a
// volume rendering). The GL shader and renderReferenceCpu do the same.
#include <array>
#include <cstdint>
#include <set>
#include <vector>

#include "vellum/core/label_volume.hpp"

namespace vellum::render {

/// Ids 1 .. kMaxTintLabels - 1 can be tinted (a 1D colour texture); larger ids are not.
inline constexpr int kMaxTintLabels = 4096;

struct LabelTint {
  VolumeU16 ids;  ///< label ids on the rendered volume's grid
  /// kMaxTintLabels entries by id: r, g, b, and a = 255 tinted / 0 not (id 0, hidden ids, ids
  /// without a table entry).
  std::vector<std::array<uint8_t, 4>> colours;
};

/// The tint of `labels` in their table colours; ids in `hidden` stay untinted.
LabelTint makeLabelTint(const LabelVolume& labels, const std::set<uint16_t>& hidden = {});

}  // namespace vellum::render
