#pragma once
// Binary morphology with ball structuring elements of a radius in mm. Computed from exact
// Euclidean distance transforms, so the cost does not grow with the radius and anisotropic
// spacing gives an ellipsoid in index space (a ball in mm).
#include "vellum/core/progress.hpp"
#include "vellum/segmentation/mask.hpp"

namespace vellum::segmentation {

/// Voxels within radiusMm of the mask (voxel-centre distance <= radius). radius <= 0 returns
/// a copy.
Mask dilate(const Mask& m, double radiusMm, Progress& progress = Progress::none());
/// Voxels of the mask farther than radiusMm from every background voxel of the grid.
/// Outside the grid counts as foreground, so structures cut by the field of view keep their
/// cut faces (and close() does not eat them).
Mask erode(const Mask& m, double radiusMm, Progress& progress = Progress::none());
/// erode then dilate: removes parts thinner than 2·radius.
Mask open(const Mask& m, double radiusMm, Progress& progress = Progress::none());
/// dilate then erode: fills gaps and dents narrower than 2·radius.
Mask close(const Mask& m, double radiusMm, Progress& progress = Progress::none());
/// Removes thin tubes that stand apart from thick parts (a mounting wire or a positioning
/// cord lying on the skin, 200-400 HU like bone): voxels of the mask farther than radiusMm plus
/// one voxel diagonal from every voxel deeper than radiusMm below its surface, where the parts
/// open() would remove within 2·radius + one diagonal spread along one direction only. Unlike
/// open(), a thick object's edges and corners stay (they lie within that reach of its core),
/// and so does a thin sheet (a bone's cortical wall over a dark inside); a tube thinner than
/// about 2·radius goes, except a stub where it meets a thick object. radius <= 0: a copy.
Mask removeThin(const Mask& m, double radiusMm, Progress& progress = Progress::none());

}  // namespace vellum::segmentation
