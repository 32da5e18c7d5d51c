#pragma once
// The control volume ([HVD 1.4] in docs/references.md): the backward map u(v) sampled on an output-space
// grid coarser than the volume by a factor s per axis.
#include <string>

#include "vellum/core/backward_map.hpp"
#include "vellum/core/geometry.hpp"

namespace vellum::deformation {

// The map model is core's (vellum/core/backward_map.hpp); these are its names here.
using vellum::parseUpsampling;
using vellum::RigidSnap;
using vellum::Upsampling;
using vellum::upsamplingName;

/// A backward map whose node grid is the output grid coarsened by `scale` per axis: node
/// (i,j,k) sits on output voxel (i*s, j*s, k*s). synthesize() and MapSampler take the kernel as
/// an argument and the output grid from the caller; renderedMap(), a copy with both set, is what
/// the renderer draws.
struct ControlVolume : BackwardMap {
  int scale = 1;  ///< s
};

/// `cv` with its output grid and kernel set (the rigid snap's class voxels shared, not copied):
/// the GL frame of it shows what CPU synthesis with the same kernel makes.
BackwardMap renderedMap(const ControlVolume& cv, const Geometry& output, Upsampling upsampling = Upsampling::Trilinear);

/// The node grid for an output geometry and factor s (1, 2, 4, ...): dims = ceil((d-1)/s)+1 so
/// that the last node reaches or passes the last voxel; spacing * s; same origin and direction.
Geometry controlGrid(const Geometry& output, int scale);

/// The identity map on a control grid (u = v): what no deformation looks like.
ControlVolume identityControlVolume(const Geometry& output, int scale);

}  // namespace vellum::deformation
