#pragma once
// Label edits of the segmentation panel and the brush, each returning the undo delta of
// what it changed. Thin wrappers over the segmentation module (no algorithm lives here).
#include <functional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "undo.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/segmentation/mask.hpp"
#include "vellum/segmentation/threshold.hpp"

namespace vellum::studio {

/// Runs `edit` on `labels` and returns what it changed (a transient copy of the whole map is
/// diffed: for tests and small maps; the studio's commands use the footprint deltas below).
/// Locked segments are protected: voxels whose id before or after the edit is in `locked`
/// are put back, so no edit adds to, removes from or paints over a locked segment.
LabelDelta recordEdit(LabelVolume& labels, const std::string& description,
                      const std::function<void(LabelVolume&)>& edit, const std::set<uint16_t>& locked = {});
/// The same without touching `labels`: the delta `edit` would make (from a whole copy).
LabelDelta diffEdit(const LabelVolume& labels, const std::string& description,
                    const std::function<void(LabelVolume&)>& edit, const std::set<uint16_t>& locked = {});

// Footprint deltas (issue #22: memory <= 4x the volume while editing). Each label operation
// reads `labels` (never writes them, never copies them) and returns the undo delta of what it
// would change, built from its own footprint: the voxels it may change (a threshold's
// predicate on the CT, a grown or snake mask, the box around a segment for islands, fill holes
// and morphology). A worker computes it while the window keeps drawing the unchanged labels;
// the window then applies it (applyDelta(labels, delta, true)). Voxels whose id before or
// after is in `locked` are left as they are. The delta's description is left empty.
LabelDelta thresholdDelta(const LabelVolume& labels, const VolumeI16& ct, const segmentation::HuInterval& interval,
                          const Label& label, const std::set<uint16_t>& locked = {});
/// `mask` (the labels' geometry) becomes `label` everywhere it is set (grow, snake).
LabelDelta maskDelta(const LabelVolume& labels, const segmentation::Mask& mask, const Label& label,
                     const std::set<uint16_t>& locked = {});
LabelDelta keepLargestDelta(const LabelVolume& labels, uint16_t id, const std::set<uint16_t>& locked = {});
LabelDelta removeIslandsDelta(const LabelVolume& labels, uint16_t id, double minVolumeMm3,
                              const std::set<uint16_t>& locked = {});
LabelDelta fillHolesDelta(const LabelVolume& labels, uint16_t id, const std::set<uint16_t>& locked = {});
/// `grown` (optional) receives the grown voxel count (0: the seed's value is outside the interval).
LabelDelta growDelta(const LabelVolume& labels, const VolumeI16& ct, const Vec3& seedMm,
                     const segmentation::HuInterval& interval, const Label& label,
                     const std::set<uint16_t>& locked = {}, int64_t* grown = nullptr);

// The same operations applied to `labels` (their footprint delta, applied).
/// Voxels of `ct` inside `interval` become `label` (overwriting other ids).
void thresholdInto(LabelVolume& labels, const VolumeI16& ct, const segmentation::HuInterval& interval,
                   const Label& label);
/// Sets every voxel whose centre lies within radiusMm of centerMm to `id` (0 erases),
/// except voxels of locked segments (and nothing when `id` itself is locked).
/// Returns the number of voxels changed.
/// `changed` (optional) receives each changed voxel's linear index and previous id: a brush
/// stroke's undo step is made from them (strokeDelta) instead of a copy of the whole map.
int64_t paintSphere(LabelVolume& labels, const Vec3& centerMm, double radiusMm, uint16_t id,
                    const std::set<uint16_t>& locked = {},
                    std::vector<std::pair<uint64_t, uint16_t>>* changed = nullptr);
/// The undo step of a stroke already painted into `labels`: the voxels it changed (index,
/// previous id; each voxel at most once, as paintSphere reports them for one id) and the
/// label table before it. Equal to diffLabels(copy before, labels) without the copy.
LabelDelta strokeDelta(std::vector<std::pair<uint64_t, uint16_t>> changed, std::vector<Label> tableBefore,
                       const LabelVolume& labels, std::string description);
/// Keeps only the largest 26-connected component of `id` (the others become background).
void keepLargest(LabelVolume& labels, uint16_t id);
/// Removes the 26-connected islands of `id` smaller than minVolumeMm3 (to background).
void removeIslands(LabelVolume& labels, uint16_t id, double minVolumeMm3);
/// Fills the cavities of `id` (background only; other segments are kept).
void fillHoles(LabelVolume& labels, uint16_t id);
/// Region growing (connected threshold, 6-connected) from a seed in mm into `label`.
/// Returns the grown voxel count (0 when the seed's value lies outside the interval).
int64_t growFromSeed(LabelVolume& labels, const VolumeI16& ct, const Vec3& seedMm,
                     const segmentation::HuInterval& interval, const Label& label);

enum class Morphology { Dilate, Erode, Open, Close };
const char* morphologyName(Morphology m);
/// The footprint delta of a ball morphology of `id` (computed on the segment's box grown by
/// twice the radius: nothing outside it can change).
LabelDelta morphologyDelta(const LabelVolume& labels, uint16_t id, Morphology op, double radiusMm,
                           const std::set<uint16_t>& locked = {}, Progress& progress = Progress::none());
/// Ball morphology of `id` with radiusMm. Growing fills background only; shrinking clears to 0.
void morphology(LabelVolume& labels, uint16_t id, Morphology op, double radiusMm,
                Progress& progress = Progress::none());
/// The upper of two multi-Otsu thresholds (three classes) over the CT's histogram above
/// -900 HU: air is left out, so the classes are fat, soft tissue and bone, and the value
/// separates bone from soft tissue.
double otsuHu(const VolumeI16& ct);

}  // namespace vellum::studio
