#pragma once
// A hinge's axis from how the joint must move (issue 23): turned about its true axis, the child's
// articular surface slides along the parent's — the talus in the ankle's mortise neither digs
// into the plafond nor lifts off it — so every contact voxel keeps its distance to the other
// bone. Any other axis drives part of the contact into the parent (where the rigid bones must
// then give, or the map fold) or pulls it away. HingeMotion scores an axis by how much those
// distances change over the pose's angles and searches the axis that changes them least. It
// needs no curved surface to fit: only the two bones' voxels, so it also works where the label
// map's joint line is a cut through the joint space rather than the cartilage's dome.
#include <cstdint>
#include <vector>

#include "vellum/core/label_volume.hpp"
#include "vellum/core/progress.hpp"

namespace vellum::deformation {

/// Where the search looked and what it found (the report's `joints[].axis_fit.motion`).
struct MotionFit {
  bool searched = false;
  /// sqrt of the score (HingeMotion::score) at the start axis and at the one found (mm).
  double startRmsMm = 0, rmsMm = 0;
  /// Of the near voxels' turned positions (all angles): the share deeper than one voxel
  /// inside the other bone, at the start axis and at the found one.
  double startInsideFraction = 0, insideFraction = 0;
  double shiftMm = 0;  ///< how far the found axis passes from the start's point (across the axis)
  double turnDeg = 0;  ///< the angle between the found direction and the start's
  double coneDeg = 0, reachMm = 0;  ///< the search's bounds about the start
  std::vector<double> anglesDeg;    ///< the angles scored (the pose's, sampled)
  int64_t contactPoints = 0, nearPoints = 0;  ///< voxels scored (both sides)
};

/// A lift-off or depth beyond this counts as this (mm): a voxel the turn carries far from the
/// joint must not outweigh the whole articular surface.
inline constexpr double kMotionClipMm = 4.0;

/// Near voxels kept per side (evenly thinned): the score's cost grows with them.
inline constexpr size_t kMaxNearVoxels = 40000;

/// The motion score of hinges about one joint, over the contact voxels of both sides.
class HingeMotion {
 public:
  /// `parentIds`: the bone the joint turns against; `movingIds`: every bone it turns (its
  /// child's ids and everything distal, which may collide with the parent as well).
  /// `parentContactMm` / `childContactMm`: the joint's
  /// articular contact voxels of each side (mm; they must stay in contact); `anglesDeg`: the
  /// joint angles to score (0 is skipped). The parent's and the moving bones' signed distance
  /// fields are computed once on the box that any axis within `reachMm` of the contact can
  /// carry the moving bones into, on a grid no finer than 0.7 mm and of at most 16 M voxels
  /// (every n-th voxel); the near voxels (each side's boundary voxels there within their
  /// travel of the other side) are thinned to kMaxNearVoxels. Cancellable through `progress`
  /// before each of the two fields (~0.5-1.5 s each on a 512^2 knee; the studio's joint worker).
  HingeMotion(const LabelVolume& labels, const std::vector<uint16_t>& parentIds, const std::vector<uint16_t>& movingIds,
              std::vector<Vec3> parentContactMm, std::vector<Vec3> childContactMm, std::vector<double> anglesDeg,
              double reachMm, Progress& progress = Progress::none());

  /// How badly the child turning about (point, direction) by the scored angles fits the
  /// parent (mm²): the mean squared change of the contact voxels' distance to the other bone
  /// (a congruent hinge slides them along it: neither in nor away) plus the mean squared depth of the near voxels
  /// inside the other bone, each clipped at kMotionClipMm. The child's voxels turn by +angle,
  /// the parent's by -angle (the same relative motion). 0: a congruent hinge that nothing
  /// collides with.
  double score(const Vec3& point, const Vec3& direction) const;
  /// The share of turned contact voxels deeper than one voxel inside the other bone.
  double insideFraction(const Vec3& point, const Vec3& direction) const;

  /// The axis of least score with its direction within `coneDeg` of `direction` (0: that
  /// direction; 90: any) and its line within `reachMm` of the start line's point nearest the
  /// contact: a coarse grid (directions ~5° apart, positions 3 mm apart across the axis, ~3000
  /// voxels) and a pattern search from its best few distinct axes (down to 0.05 mm and 0.05°,
  /// all voxels). `point` and `direction` become the found axis (point: the line's point
  /// nearest the search's centre).
  /// vellum::Cancelled when `progress` is cancelled (checked per coarse direction and
  /// refinement step).
  MotionFit search(Vec3& point, Vec3& direction, double coneDeg, double reachMm,
                   Progress& progress = Progress::none()) const;

 private:
  /// Over the scored angles and every `stride`-th voxel: the contact voxels' squared change of
  /// distance to the other bone and the near voxels' squared depth inside the other bone (each clipped at kMotionClipMm),
  /// and how many near voxels end deeper than a voxel inside.
  struct Tally {
    double change = 0, depth = 0;
    int64_t contact = 0, near = 0, inside = 0;
    double score() const;
    double insideFraction() const { return near ? double(inside) / double(near) : 0; }
  };
  Tally tally(const Vec3& point, const Vec3& direction, size_t stride) const;
  std::vector<Vec3> contact_[2];        ///< parent's, child's contact voxels (mm): they must stay in contact
  std::vector<float> restDistance_[2];  ///< each contact voxel's signed distance to the other bone at rest
  std::vector<Vec3> near_[2];           ///< each bone's surface voxels the turn may carry into the other (mm)
  VolumeF32 field_[2];                  ///< signed distance (mm, negative inside) to the parent, the moving bones
  std::vector<double> angles_;
  Vec3 centre_{0, 0, 0};  ///< the contact voxels' centroid
  double voxelMm_ = 1;
};

}  // namespace vellum::deformation
