#pragma once
// The twist map (issue 23 §4): a pose's backward map that cannot fold by construction. Per
// joint with axis through c along unit a and angle theta, every output point v turns about
// the axis by -theta * w(v) (backward: output -> source), w a weight field on the output grid:
// exactly 1 on the posed child and every bone distal to it, exactly 0 on the parent, the still
// bones and the fixed regions, a blend of the distances to both sides in between. In
// cylindrical coordinates (r, alpha, z) about the axis the map keeps r and z and shifts alpha,
// so det J = 1 - theta * dw/dalpha exactly: it folds nowhere as long as theta * dw/dalpha < 1,
// whatever w does along r and z (a jump of w across a joint space, or between two feet side by
// side along the axis, is a pure shear). The bound is enforced by relaxing w (never on bones or
// fixed regions); a chain composes its joints' twists, each fold-free, so the composition is.
// Where a still and a turning bone touch along the turn (an axis that is not the joint's, or
// labels without a joint space) no w between two locks can keep det J > 0: there the bones' rims
// give (a voxel's shell of both bones around each such place is unlocked and relaxed with the
// tissue, never a fixed region's), so the map stays fold-free and the report says how many bone
// voxels gave.
// Format and measures: docs/deformation.md, "Twist map".
#include <memory>
#include <vector>

#include "vellum/core/backward_map.hpp"
#include "vellum/core/geometry.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/deformation/pose.hpp"
#include "vellum/deformation/rigidity.hpp"

namespace vellum::deformation {

struct TwistParams {
  /// w = dS^p / (dS^p + dM^p) from the distances (mm) to the still set S and the posed moving
  /// set M: p = 2 keeps tissue far from the moving bones nearer to still (a calf 20 mm from the
  /// tibia and 100 mm from the foot turns by 4 % of the angle, not 17 % as with p = 1).
  double power = 2.0;
  /// Distances along the joint's axis count this many times in the blend (axes along a grid
  /// axis only): what lies beside a bone along the axis is a pure shear and barely pulls w.
  /// 32 since s27 (was 4): a fixed box or still bone a few voxels beside a turning bone along
  /// the axis still pulled the tissue between down, steep along the turn, and the rims gave
  /// (feet, real CT, 20°: bone RMS 0.77 -> 0.65 mm about the hand axis, 0.71 -> 0.39 mm and
  /// 9 folded voxels -> 0 about the motion-placed axis; the knee's bones unchanged).
  double axisStretch = 32.0;
  /// The bound: theta * dw/dalpha <= 1 - margin (det J >= margin) wherever w is free.
  double margin = 0.25;
  int maxRounds = 40;    ///< relaxation rounds of the first pass (a third in later ones); each grows the region by a voxel
  int patience = 8;      ///< stop after this many rounds (half in later passes) that cut the total excess by < 2 %
  int relaxSteps = 8;    ///< Jacobi steps in the first round
  int limitSteps = 24;   ///< slope-limiter steps per round (along the circles about the axis)
  int maxRadius = 12;    ///< voxels around the violations that a round relaxes
  /// A blended voxel whose source lands in a body (nearest voxel) takes that body's transform
  /// (as the MLS map's rigid snap): bones show no voxel moved non-rigidly at their rim.
  bool snap = true;
  /// Times a blended voxel whose source lands in a bone joins that bone's lock and the blend
  /// is relaxed again (the last joint's stage only; the snap catches what is left).
  int lockPasses = 8;
  double joinMaxVoxels = 2.0;  ///< a voxel joins only when that moves its source by at most this many voxels
  /// Where det J is still under this after the relaxation (locked on both sides: bones that
  /// touch along the turn), a voxel's shell of the bones around it is unlocked and relaxed again.
  double softenBelow = 0.1;
  int softenPasses = 8;  ///< shells unlocked at most (each pass one voxel deeper where needed)
  /// The final snap only where it moves the source by at most this many voxels: a longer one
  /// is a jump of the map, which folds (such voxels are counted, TwistMap::unsnappedVoxels).
  double snapMaxVoxels = 0.5;
  /// The slope check also reads the map's own central-difference det where w steps steeply
  /// between neighbours (two rotations by different angles differ by more than the linear
  /// estimate 1 - theta dw/dalpha: the grid can fold a voxel where the estimate says 0.25).
  bool gridCheck = true;
  /// Also the dets of the 8 grid cells around such a voxel (one-sided differences, weighted
  /// 0.6): for a map that is then upsampled (TwistFrames at scale > 1), whose voxels inside a
  /// node cell show the cell's fold that the central differences at the nodes step over.
  bool cellCheck = false;
  /// For a map whose samples are turned by the trilinearly interpolated w (the twist kernel,
  /// TwistFrames at scale > 1): the kernel's det at each corner of the 8 cells around a voxel,
  /// 1 - theta * grad w . tangent with grad w the cell's one-sided differences, joins the bound
  /// (everywhere, not only where w steps steeply: far from the axis a gentle w is steep along
  /// the circle).
  bool kernelCheck = false;
  /// With kernelCheck: after each round's limiter, every cell over the bound has its free
  /// corners moved by the least change that brings its kernel det back (the limiter, along the
  /// arcs, does not see a cell's one-sided differences beside a lock, which otherwise stick and
  /// soften the bone's rim).
  bool projectCells = true;
  /// Make the twist kernel (TwistMap::kernel): the nodes' map is then the kernel's at the nodes
  /// (no snap there: the upsampled map's own snap, at full resolution, makes the bones exact).
  bool kernel = false;
};

/// `vellum pose`'s twist options (--twist-power, --twist-margin) as the map's parameters.
inline TwistParams twistParamsOf(const PoseOptions& o) {
  TwistParams p;
  p.power = o.twistPower;
  p.margin = o.twistMargin;
  return p;
}

/// What the twist of one joint did.
struct TwistJointStats {
  std::string name;
  double angleDeg = 0;
  int64_t stillVoxels = 0, movingVoxels = 0;  ///< S and M on the grid (w locked to 0 / 1)
  int64_t overlapVoxels = 0;   ///< posed moving bone over a still one (S wins: a collision)
  int64_t joinedVoxels = 0;    ///< blended voxels whose source lay in a bone, locked to its side
  int64_t violationsBefore = 0;  ///< voxels with theta * dw/dalpha > 1 - margin before relaxing
  double maxSlopeBefore = 0;     ///< the largest theta * dw/dalpha before
  int rounds = 0;
  int64_t relaxedVoxels = 0;     ///< distinct free voxels whose w the relaxation changed
  int64_t violationsAfter = 0;   ///< left (locked on both sides: a true collision)
  int64_t collisionVoxels = 0;   ///< of violationsAfter, with det J <= 0 (theta * dw/dalpha >= 1)
  double maxSlopeAfter = 0;
  int64_t softenedVoxels = 0;    ///< bone rim voxels unlocked where bones touch along the turn
};

struct TwistMap {
  std::vector<float> mapMm;  ///< 3 floats (source mm) per output voxel, x fastest (as upsampleMap())
  std::vector<TwistJointStats> joints;  ///< in the order they were applied (proximal first)
  /// Output voxels whose source lies in a bone but that do not take its transform: the softened
  /// rims, and blended voxels whose snap would jump the source by over joinMaxVoxels.
  int64_t unsnappedVoxels = 0;
  /// With TwistParams::kernel (and at most TwistKernel::kMaxStages stages): the stages and
  /// their weights on the grid, the kernel that upsamples this map.
  std::shared_ptr<const TwistKernel> kernel;
};

/// The backward map of `pose` at `anglesDeg` on `output` (the grid of `bodies`' classes: the
/// volume as deformed, padded or not). Every body of `bodies` whose first id a joint moves
/// follows that joint's composed transform exactly; every other body (still bones, the fixed
/// regions) stays exactly. Memory: the map, plus per joint one float weight field and,
/// while it is built, two distance fields. Cancellable through `progress`.
TwistMap twistMap(const Pose& pose, const std::vector<double>& anglesDeg, const RigidBodies& bodies,
                  const Geometry& output, const TwistParams& params = {}, Progress& progress = Progress::none());

}  // namespace vellum::deformation
