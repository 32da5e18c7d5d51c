#pragma once
// Regions of interest and integer downsampling of volumes: how a scan too large for a command
// (a 1024^3 CT on a 24 GB machine) is reduced on load (io::LoadOptions::region). Geometry is
// kept exact: a cropped volume sits where its voxels were, a downsampled voxel's centre is the
// centre of the block it averages.
#include <array>
#include <cstdint>
#include <optional>

#include "vellum/core/volume.hpp"

namespace vellum {

/// Voxel index box, inclusive at both ends: i in [lo[0], hi[0]], j ..., k ...
struct VoxelBox {
  std::array<int64_t, 3> lo{0, 0, 0};
  std::array<int64_t, 3> hi{0, 0, 0};
  Dims dims() const { return {hi[0] - lo[0] + 1, hi[1] - lo[1] + 1, hi[2] - lo[2] + 1}; }
};

/// What to keep of a volume: a voxel box or a physical box (mm, LPS; the voxels whose
/// centres lie inside its axis-aligned bounds), then every n x n x n block reduced to one voxel.
struct Region {
  std::optional<VoxelBox> cropVoxels;
  std::optional<std::array<Vec3, 2>> cropMm;  ///< two opposite corners
  int downsample = 1;                         ///< 1..16
  bool empty() const { return !cropVoxels && !cropMm && downsample == 1; }
};

/// The voxel box of `region` on `g` (the whole grid when it crops nothing). Throws
/// vellum::Error when the box is empty, outside the grid or reversed.
VoxelBox regionBox(const Geometry& g, const Region& region);

/// The part of `v` inside `box` (bounds-checked), with its geometry.
AnyVolume cropVolume(const AnyVolume& v, const VoxelBox& box);
/// Mean of every n^3 block (partial blocks at the far edges average what they hold), rounded
/// for integer types: for intensities.
AnyVolume downsampleMean(const AnyVolume& v, int n);
/// Most frequent id of every n^3 block (ties: the smallest id): for label maps, whose ids
/// must never be averaged.
VolumeU16 downsampleMode(const VolumeU16& ids, int n);

/// crop + downsample for intensities / for label ids.
AnyVolume applyRegion(const AnyVolume& v, const Region& region);
VolumeU16 applyRegionToLabels(const VolumeU16& ids, const Region& region);

}  // namespace vellum
