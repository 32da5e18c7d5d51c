#pragma once
// Where control points start ([HVD 1.5] in docs/references.md): the paper's default on the bounding box with
// an inner offset, and (beyond the paper) points placed from a segmentation. Sources = targets.
#include <optional>
#include <vector>

#include "vellum/core/label_volume.hpp"
#include "vellum/deformation/control_point.hpp"
#include "vellum/deformation/keyframes.hpp"

namespace vellum::deformation {

/// `count` points on the volume's box, inset by `insetFraction` of the extent on every side
/// (all distinct, spanning 3D for count >= 4, symmetric where count allows):
///  - 1: the centre; 2..7: well-spread corners (opposite pair, then tetrahedra);
///  - >= 8: the 8 corners, then groups of 4 points on the 4 parallel edges of an axis, the
///    groups apportioned to the axes by edge length and spaced evenly along each edge, then
///    (count - 8) mod 4 points on the centres of the faces across the longest axis(es).
/// The paper's default 16 on a 180x180x220 mm knee: corners + midpoints of the 4 z edges and
/// of the 4 x edges. Throws for count < 1 or > 100000.
ControlPoints boxControlPoints(const Geometry& geometry, int count = 16, double insetFraction = 0.1);

/// Points from a label map: for every 26-connected component (>= 8 voxels) of every label, its
/// centroid and the two surface points at the ends of its principal axis; plus the 8 corners
/// of the inset box as anchors. Points closer than one voxel to an earlier one are skipped.
ControlPoints labelControlPoints(const LabelVolume& labels, double insetFraction = 0.1);

/// The demo's animation: 16 box points; the points below the joint (z below `pivotMm`) swing
/// by the flexion angle about the medio-lateral (x index) axis through `pivotMm` while those
/// above stay: rest -> flex +angle -> flex angle/2 -> rest (looped), smooth interpolation,
/// `seconds` long. Pivot default: the volume's centre; the phantom's knee flexes about
/// phantom::flexionAxisPointMm() (the demo passes it).
KeyframeTrack kneeBendTrack(const Geometry& geometry, double angleDeg = 15.0, double seconds = 2.0,
                            std::optional<Vec3> pivotMm = std::nullopt);

}  // namespace vellum::deformation
