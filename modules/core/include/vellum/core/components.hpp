#pragma once
// Connected components of voxel masks and label volumes: the one labelling of Vellum
// (segmentation's islands and hole filling, deformation's rigid bodies and control-point
// placement, the studio's label tools all call it).
#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include "vellum/core/progress.hpp"
#include "vellum/core/volume.hpp"

namespace vellum {

/// Which neighbours touch: faces (6), faces + edges (18), faces + edges + corners (26).
enum class Connectivity { Face6 = 6, Edge18 = 18, Vertex26 = 26 };

/// Parses 6, 18 or 26; throws vellum::Error otherwise.
Connectivity connectivityFromInt(int n);

/// Inclusive index-space bounding box of a component.
struct IndexBox {
  std::array<int64_t, 3> lo{0, 0, 0}, hi{-1, -1, -1};
  bool empty() const { return hi[0] < lo[0]; }
  bool operator==(const IndexBox&) const = default;
};

/// Component labelling: labels[linear index] = 0 for background, 1..count for the components,
/// numbered in scan order of their first voxel (x fastest), so the result does not depend on
/// the number of threads. Index 0 of sizes, boxes and values is unused.
struct Components {
  Dims dims;
  std::vector<uint32_t> labels;
  std::vector<int64_t> sizes;    ///< voxels per component
  std::vector<IndexBox> boxes;   ///< bounding box per component
  std::vector<uint16_t> values;  ///< the voxel value the component was made of (1 for a mask)
  int64_t count() const { return static_cast<int64_t>(sizes.size()) - 1; }
  /// Label of the largest component (the lowest label among equals); 0 when there is none.
  uint32_t largest() const;
};

/// Components of the non-zero voxels of `mask` (all non-zero values count as one class).
Components connectedComponents(const VolumeU8& mask, Connectivity connectivity = Connectivity::Vertex26,
                               Progress& progress = Progress::none());

/// Components of equal non-zero ids: two touching voxels join when their ids are equal
/// (each part of each label separately; 0 is background).
Components connectedRegions(const VolumeU16& ids, Connectivity connectivity = Connectivity::Vertex26,
                            Progress& progress = Progress::none());

/// A mask (geometry of `like`) of the voxels whose component keep(label) accepts (never label 0).
VolumeU8 selectComponents(const Geometry& like, const Components& c, const std::vector<uint8_t>& keepLabel);

/// Sets to `value` the voxels of the components of `mask`'s non-zero voxels (of its zero
/// voxels when `ofZeros`) that choose(components) marks (a flag per label; label 0 never),
/// in place and without a label per voxel: the Components passed to `choose` have sizes,
/// boxes and values but empty `labels` (4 bytes a voxel less than connectedComponents; at
/// 512x512x350 that is 367 MB). The one labelling underneath, as connectedComponents.
void paintComponents(VolumeU8& mask, bool ofZeros, Connectivity connectivity,
                     const std::function<std::vector<uint8_t>(const Components&)>& choose, uint8_t value);

/// Only the largest component of `mask`.
VolumeU8 keepLargestComponent(const VolumeU8& mask, Connectivity connectivity = Connectivity::Vertex26);

/// Removes the components of `mask` smaller than minVolumeMm3 (one of exactly that volume stays).
VolumeU8 removeSmallIslands(const VolumeU8& mask, double minVolumeMm3,
                            Connectivity connectivity = Connectivity::Vertex26);
/// The same in place (no second mask).
void removeSmallIslandsInPlace(VolumeU8& mask, double minVolumeMm3, Connectivity connectivity = Connectivity::Vertex26);

}  // namespace vellum
