#pragma once
// The patient's body in a CT, without the table, pads and head holders beside it: real scans
// carry them and they show as plates next to the anatomy in every rendering.
#include <vector>

#include "vellum/core/params.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/segmentation/mask.hpp"

namespace vellum::segmentation {

struct BodyMaskParams {
  double airThresholdHu = -500;  ///< body = above this: half-way between air and soft tissue
  double openingRadiusMm = 4;    ///< cuts contacts thinner than ~2x this (pads, rods, cushions)
  /// A body part (two legs, two feet, two arms beside a chest: each a separate component) is
  /// kept when it holds at least this volume...
  double minPartMl = 20;
  /// ...and is at least this thick somewhere (the diameter of the largest ball inside it): a
  /// foot or a wrist is 40+ mm thick, a table top or a pad 10-20 mm.
  double minPartThicknessMm = 30;
};
const params::Table<BodyMaskParams>& bodyMaskParamsTable();

/// What bodyMask() kept and removed (volumes in mL = cm³).
struct BodyMaskReport {
  std::vector<double> keptPartsMl;  ///< each body part kept, largest first
  double removedMl = 0;             ///< voxels above air left out: table, pads, small strays
  int removedParts = 0;             ///< components of the opened voxels left out
  /// True when no component met the minimums and the largest was kept anyway (a small or
  /// thin sample: something is always kept).
  bool keptLargestBelowMinimum = false;
};

/// Voxels above air, opened to cut thin contacts, reduced to the body parts (the components
/// at least minPartMl large and minPartThicknessMm thick; the largest when none is), grown
/// back by the opening radius inside the thresholded voxels, with enclosed air (lungs,
/// airways, bowel gas) filled slice by slice along every axis; pieces under minPartMl left
/// after the growth are dropped too. `report`, when given, says what was kept and removed.
Mask bodyMask(const VolumeI16& ct, const BodyMaskParams& params = {}, Progress& progress = Progress::none(),
              BodyMaskReport* report = nullptr);

/// The CT with every voxel outside bodyMask() set to its background (air, -1000 HU).
VolumeI16 removeTable(const VolumeI16& ct, const BodyMaskParams& params = {}, Progress& progress = Progress::none(),
                      BodyMaskReport* report = nullptr);

}  // namespace vellum::segmentation
