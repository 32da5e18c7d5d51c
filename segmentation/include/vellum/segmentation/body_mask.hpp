#pragma once
// The patient's body in a CT, without the table, pads and head holders beside it: real scans
// carry them and they show as plates next to the anatomy in every rendering.
#include "vellum/core/params.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/segmentation/mask.hpp"

namespace vellum::segmentation {

struct BodyMaskParams {
  double airThresholdHu = -500;  ///< body = above this: half-way between air and soft tissue
  double openingRadiusMm = 4;    ///< cuts contacts thinner than ~2x this (pads, rods, cushions)
};
const params::Table<BodyMaskParams>& bodyMaskParamsTable();

/// Voxels above air, opened to cut thin contacts, reduced to the largest component (the body),
/// grown back by the opening radius inside the thresholded voxels, and with enclosed air
/// (lungs, airways, bowel gas) filled slice by slice along every axis.
Mask bodyMask(const VolumeI16& ct, const BodyMaskParams& params = {}, Progress& progress = Progress::none());

/// The CT with every voxel outside bodyMask() set to its background (air, -1000 HU).
VolumeI16 removeTable(const VolumeI16& ct, const BodyMaskParams& params = {}, Progress& progress = Progress::none());

}  // namespace vellum::segmentation
