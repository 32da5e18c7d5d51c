#pragma once
// Binary masks and the small shared vocabulary of the segmentation module.
#include <cstdint>
#include <optional>
#include <vector>

#include "vellum/core/components.hpp"
#include "vellum/core/volume.hpp"

namespace vellum::segmentation {

/// A binary segmentation: 1 inside, 0 outside, with the geometry of the image it came from.
using Mask = VolumeU8;

// 6/18/26 connectivity lives in core (core/components.hpp) with the one component labelling.
using vellum::Connectivity;
using vellum::connectivityFromInt;

/// An empty mask (all 0) on `g`.
Mask makeMask(const Geometry& g);

/// Number of non-zero voxels (parallel).
int64_t countVoxels(const Mask& m);

/// Volume of one voxel in mm³ (|det direction| * spacing product).
double voxelVolumeMm3(const Geometry& g);

/// Volume of the mask in mm³.
double maskVolumeMm3(const Mask& m);

/// Integer voxel index.
struct Index3 {
  int64_t i = 0, j = 0, k = 0;
  bool operator==(const Index3&) const = default;
};

/// The voxel whose centre is nearest to `pointMm`, or nullopt when the point lies outside
/// the grid (more than half a voxel beyond the outermost centres).
std::optional<Index3> nearestVoxel(const Geometry& g, const Vec3& pointMm);

/// Seeds in mm -> voxel indices; throws vellum::Error naming the first seed outside the grid.
std::vector<Index3> seedsToVoxels(const Geometry& g, const std::vector<Vec3>& seedsMm);

/// Throws vellum::Error (naming `what`) when the two geometries differ by more than 1e-4 mm.
void requireSameGeometry(const Geometry& a, const Geometry& b, const char* what);

/// Voxel-wise logical operations (same geometry required).
Mask maskAnd(const Mask& a, const Mask& b);
Mask maskOr(const Mask& a, const Mask& b);
Mask maskNot(const Mask& a);

/// Mask of the voxels of `labels` whose id satisfies `pred` (e.g. truth extraction).
template <class Pred>
Mask maskFromIds(const VolumeU16& labels, Pred pred) {
  Mask m(labels.geometry(), 0, 0.0);
  const auto& src = labels.voxels();
  auto& dst = m.voxels();
  for (size_t n = 0; n < src.size(); ++n) dst[n] = pred(src[n]) ? 1 : 0;
  return m;
}

}  // namespace vellum::segmentation
