#pragma once
// Label edits of the segmentation panel and the brush, each returning the undo delta of
// what it changed. Thin wrappers over the segmentation module (no algorithm lives here).
#include <functional>
#include <string>

#include "undo.hpp"
#include "vellum/segmentation/threshold.hpp"

namespace vellum::studio {

/// Runs `edit` on `labels` and returns what it changed (a transient copy is diffed).
LabelDelta recordEdit(LabelVolume& labels, const std::string& description,
                      const std::function<void(LabelVolume&)>& edit);

/// Voxels of `ct` inside `interval` become `label` (overwriting other ids).
void thresholdInto(LabelVolume& labels, const VolumeI16& ct, const segmentation::HuInterval& interval,
                   const Label& label);
/// Sets every voxel whose centre lies within radiusMm of centerMm to `id` (0 erases).
/// Returns the number of voxels changed.
int64_t paintSphere(LabelVolume& labels, const Vec3& centerMm, double radiusMm, uint16_t id);
/// Keeps only the largest 26-connected component of `id` (the others become background).
void keepLargest(LabelVolume& labels, uint16_t id);
/// Fills the cavities of `id` (background only; other segments are kept).
void fillHoles(LabelVolume& labels, uint16_t id);

}  // namespace vellum::studio
