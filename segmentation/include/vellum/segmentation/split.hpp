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
  /// Joint cut (needs the CT; 0 = off): voxels of the mask in a thin dark sheet, darker by at
  /// least this than bright voxels on both sides along one of the 13 voxel directions within
  /// jointWidthMm (a joint space between two subchondral plates), count as surface for the
  /// depth and the markers: two bones pressed together across a joint space get two markers
  /// and meet in it. Flooded last, so the joint space's voxels still join a bone.
  double jointContrastHu = 0;
  /// How far each side of a dark voxel the cut looks for bright bone, mm. Pieces of the sheet
  /// smaller than pi * width^2 mm^3 are dropped (the texture of cancellous bone, not a joint).
  double jointWidthMm = 3.0;
  /// With the joint cut: two objects that meet mostly outside the joint spaces (less than this
  /// share of their contact on joint-space voxels) were cut apart by a neck inside one bone or
  /// by a gap in the joint's sheet, and merge. 0 = never.
  double jointShare = 0.5;
  /// With the joint cut: the joint spaces' voxels end as background, a gap between the bones
  /// (bodies that move apart at a joint need it); pieces of the sheet inside one bone come back
  /// with fillObjects.
  bool openJoints = false;
  /// After the split, each object's cavities (holes enclosed in any axial, coronal or sagittal
  /// slice of the object alone, then 3D) become the object: the low-density inside of a bone
  /// (fatty marrow, cancellous bone under the threshold) without bridging to its neighbours.
  bool fillObjects = false;
  /// Before the split, thin parts apart from thick ones go (removeThin): a mounting wire or a
  /// positioning cord on the skin, as bright as bone, that would join the bones it touches
  /// into one object. Tubes thinner than about twice this; 0 = off.
  double thinMm = 0;
};

/// neck, min_volume, joint_contrast, joint_width, joint_share, open_joints, fill, thin (the seeds are a list, not a table row).
const params::Table<SplitParams>& splitParamsTable();

struct SplitResult {
  VolumeU16 objects;                ///< 0 outside, 1..count: largest object first
  std::vector<double> volumesMm3;   ///< per object (index 0 unused)
  double droppedMm3 = 0;            ///< mask volume left out (pieces below the minimum, unseeded pieces)
  int markers = 0;                  ///< markers flooded from (before small objects merged)
  int64_t jointVoxels = 0;          ///< voxels the joint cut marked as joint space
  int jointMerges = 0;              ///< neighbours merged for meeting outside the joint spaces
  double filledMm3 = 0;             ///< cavities added to the objects (fillObjects)
  double openedMm3 = 0;             ///< joint-space volume returned to background (openJoints)
  double thinRemovedMm3 = 0;        ///< thin parts removed before the split (thinMm)
  int count() const { return static_cast<int>(volumesMm3.size()) - 1; }
};

/// Splits `mask` into objects: markers (seeds, or the 26-connected pieces of the mask deeper
/// than neckMm) grow over the mask in order of decreasing depth (priority flood, 26 neighbours),
/// so two bones joined by a thin contact meet at the contact's narrowest place. Mask pieces
/// that no marker reaches become objects of their own. Deterministic (no thread dependence).
/// Throws vellum::Error for a seed outside the grid or on background, and for a joint cut
/// without `ct` (the CT the mask came from, same grid).
SplitResult splitObjects(const Mask& mask, const SplitParams& params = {}, Progress& progress = Progress::none(),
                         const VolumeI16* ct = nullptr);

/// The joint cut's sheet (see SplitParams::jointContrastHu): voxels of `mask` at least
/// contrastHu darker than the brightest voxel within widthMm on each side along some direction,
/// without the pieces (26-connected) smaller than pi * widthMm^2 mm^3.
Mask jointSpaces(const VolumeI16& ct, const Mask& mask, double contrastHu, double widthMm);

/// Fills each object's cavities (holes enclosed in a slice of the object alone along x, y or
/// z, then 3D) with its id, on background voxels only (objects never overwrite each other;
/// larger objects fill first). Returns the voxels added per id (index 0 unused).
std::vector<int64_t> fillObjectHoles(VolumeU16& objects);

}  // namespace vellum::segmentation
