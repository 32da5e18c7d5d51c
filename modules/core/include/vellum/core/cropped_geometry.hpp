#pragma once
// The grid of a voxel box cut from a grid. Its own small header: core/region.hpp, where the
// box and the crop live, is included by most of the tree.
#include "vellum/core/region.hpp"

namespace vellum {

/// The grid of `box` cut from `g`: the box's dims, the origin at its first voxel's centre, the
/// same spacing and directions (the voxels sit where they were). The box is not checked.
Geometry croppedGeometry(const Geometry& g, const VoxelBox& box);

}  // namespace vellum
