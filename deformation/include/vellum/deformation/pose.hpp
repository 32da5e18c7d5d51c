#pragma once
// Joints and poses (issue 23 §3): a pose file names joints (a parent bone, a child bone — label
// ids — and a hinge axis), keyframed joint angles, and the regions that stay put. The control
// points are generated from the label map, not typed: well-spread samples rigidly attached to
// every bone and fixed region, plus sparse box anchors; their targets come from composing the
// joint rotations along the chain (everything distal follows the child). The deformation
// itself is the ordinary MLS + rigid-bone engine (deformer.hpp, rigidity.hpp). Positions in mm
// (physical LPS), angles in degrees. Format: docs/deformation.md, "Pose file".
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "vellum/core/label_volume.hpp"
#include "vellum/core/params.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/core/rigid_fit.hpp"
#include "vellum/deformation/control_point.hpp"
#include "vellum/deformation/joint_motion.hpp"
#include "vellum/deformation/keyframes.hpp"
#include "vellum/deformation/rigidity.hpp"

namespace vellum::deformation {

/// How an "estimate" axis was found (estimateAxes()). A hinge's axis is the axis of its
/// articular surfaces (the talar dome under the plafond, the femoral condyles): one robust
/// least-squares cylinder axis for the two bones' surface voxels in the contact zone; a
/// ball-like joint (a sphere fits clearly better) turns about the sphere's centre along the
/// contact patch's widest direction; a flat contact falls back to the zone's centroid and
/// widest direction, with a warning.
struct AxisFit {
  /// How the axis was found: "cylinder", "sphere", "contact" (the fallback), "motion" (the
  /// motion search from an "axis_hint"); empty: the axis was given.
  std::string method;
  std::string surfaceMethod;  ///< the surface fit's model when one counts ("cylinder", "sphere"), else empty
  std::string surface;  ///< the surfaces that count (fit a curved model): "both", "child", "parent"
  double radiusMm = 0;  ///< the cylinder's or sphere's radius: the child's when it counts (the axis
                        ///< passes through its centre), else the parent's
  double axisGapMm = -1;  ///< between the parent's and the child's fitted axes (centres); -1: one side
  double rmsMm = 0;     ///< RMS distance of the inlier surface voxels from the fitted surface
  double inlierFraction = 0;  ///< of the counting surfaces' voxels: within 1.5 voxels of it, facing along it
  double arcDeg = 0;    ///< cylinder: the angle the inlier surface spans about the axis
  int64_t surfacePoints = 0;  ///< surface voxels of both bones in the contact zone (facing each other)
  /// 0..1: the share of the giving surface's voxels on the model, times how much of a
  /// hinge's arc they span (arc / 90°, at most 1; a sphere: 1), times how clearly it beats a
  /// plane (2 x (1 - cost / plane cost), at most 1). 0 when refused or not fitted.
  double confidence = 0;
  /// Why a curved fit was refused (method "contact" then): each a short reason. A confident
  /// wrong axis is worse than the honest fallback.
  std::vector<std::string> refusals;
  uint16_t partner = 0;  ///< the child id whose contact with the parent was fitted (the most voxels in the zone)
  /// Per child id touching the parent: its voxels within `contactMm` of the parent.
  std::vector<std::pair<uint16_t, int64_t>> contactVoxels;
  std::string warning;  ///< why the estimate is doubtful (empty when the fit is good)
  /// The motion search (joint_motion.hpp) that placed the axis, from the joint's "axis_hint"
  /// (method "motion" then; motion.searched false without a hint).
  MotionFit motion;
};

struct Joint {
  std::string name;
  std::vector<uint16_t> parent;  ///< the parent bone's label ids (it holds the axis)
  std::vector<uint16_t> child;   ///< the child bone's label ids (each id stays one rigid body)
  /// Two points on the hinge axis (mm); a positive angle turns the child right-handed about
  /// axisA -> axisB. Filled by estimateAxes() when `estimateAxis`.
  Vec3 axisA{0, 0, 0}, axisB{0, 0, 0};
  bool estimateAxis = false;  ///< "axis": "estimate": from the parent/child contact zone
  /// "axis_hint" (with "estimate"): two points (mm) on a rough axis (through the malleoli's
  /// tips, say). The estimate is then the motion search's (joint_motion.hpp): the axis within
  /// kHintReachMm of it, its direction within "axis_hint_cone" degrees (hintConeDeg, 0..45,
  /// default 0: the hint's direction is kept; anatomy names it, the label map rarely does).
  bool hasAxisHint = false;
  Vec3 hintA{0, 0, 0}, hintB{0, 0, 0};
  double hintConeDeg = 0;
  AxisFit fit;                ///< how estimateAxes() found the axis
  int proximal = -1;  ///< the joint whose child holds this joint's parent (chains), -1: a root joint
};

/// How far from an "axis_hint" the motion search looks for the axis (mm), and the joint angles
/// it scores (degrees: a hinge's working range, either way).
inline constexpr double kHintReachMm = 30.0;
inline const std::vector<double> kHintAnglesDeg{-20, -15, -10, -5, 5, 10, 15, 20};

struct Pose {
  std::vector<Joint> joints;
  FixedRegions fixed;  ///< "fixed_labels", "fixed_boxes": they do not move at all
  /// The angles (deg) over time: a keyframe track whose point i carries joint i's angle in
  /// its source.x, so that the angles are timed and interpolated exactly like control points
  /// (durations, linear / smooth / eased, loop: keyframes.hpp).
  KeyframeTrack angles;
  /// "map": the map the pose asks for ("twist", "mls"); empty: the command's default
  /// (`vellum pose --map`; twist_map.hpp).
  std::string map;

  /// Angles (deg) per joint at time t (s).
  std::vector<double> anglesAt(double timeS) const;
  /// The time of the last keyframe (the pose `vellum pose` makes by default).
  double lastKeyframeTimeS() const;
  /// Every bone id of every joint (parents and children), sorted, unique.
  std::vector<uint16_t> boneIds() const;
  /// The joint whose child holds `id`, or -1 (a bone that no joint moves stays still).
  int jointMoving(uint16_t id) const;
};

/// Reads a pose file. vellum::FileError naming the file and the field, one line (through
/// core/json_input.hpp: size, depth and syntax checked before anything is used).
Pose loadPose(const std::filesystem::path& path);
/// Writes `pose` as a pose file loadPose() reads back (atomically): joints with "axis":
/// "estimate" stay so (the reader estimates them again from the same labels), the others
/// carry their two axis points; keyframes name every joint's angle. What the studio's joint
/// tool saves for `vellum pose`.
void savePose(const Pose& pose, const std::filesystem::path& path);

/// Settings of the point generation and the measures: `vellum pose` flags (poseOptionsTable()).
struct PoseOptions {
  double sampleSpread = 1.0;   ///< bone samples at centroid +- spread * sigma along each principal axis
  /// Also one sample per cell of this size (mm) on every moving or parent bone (0 = none): a
  /// bone's own points then lie nearer to its voxels than its neighbours' do, so the MLS map
  /// inside it follows its transform, not a blend with the bone next to it.
  double sampleStepMm = 8.0;
  int anchors = 8;             ///< still anchors on the volume's inset box (boxControlPoints); 0 = none
  double anchorInset = 0.1;    ///< their inset, fraction of the box
  double contactMm = 3.0;      ///< "axis": "estimate": parent/child voxels this close form the contact zone
  double maxStepDeg = 2.0;     ///< movies: generated keyframes at most this many degrees apart
  int measureStride = 1;       ///< joint measures visit every N-th voxel per axis
  /// The twist map (twist_map.hpp): w = dS^p / (dS^p + dM^p), and its slope bound's margin.
  double twistPower = 2.0;
  double twistMargin = 0.25;
};
const params::Table<PoseOptions>& poseOptionsTable();

/// Rotation by `angleDeg` about the axis through a -> b (right-handed), as a rigid transform.
RigidTransform rotationAbout(const Vec3& a, const Vec3& b, double angleDeg);

/// Per joint, the transform of its child bone at `anglesDeg` (rest -> posed): its own rotation
/// about its rest axis, then its proximal joints' (the chain: distal first).
std::vector<RigidTransform> jointTransforms(const Pose& pose, const std::vector<double>& anglesDeg);

/// Links the chain (Joint::proximal) and checks the joints against each other: Error for a
/// bone that two joints move, a joint whose parent is the child of two joints, a cycle, a bone
/// both moved and fixed, a degenerate axis. loadPose() calls it.
void linkJoints(Pose& pose);

/// Fills the axes of the joints with "axis": "estimate" from the label map (and Joint::fit):
/// the contact zone = parent and child voxels within `contactMm` of the other bone. Of the
/// child's ids the one with the most voxels in it is the articular partner (the talus, not the
/// calcaneus a tibial lip touches); only its zone with the parent is fitted: the two sides'
/// surface voxels that face each other (with outward normals) go to fitArticularSurfaces()
/// (robustly: voxels beyond 1.5 voxels of the surface or not facing along it, such as a
/// malleolus's flat side facets, are outliers). No fit, or a refused one: the zone's centroid
/// and widest direction, method "contact", warned with the reasons. A joint with an
/// "axis_hint": the motion search's axis near it (joint_motion.hpp). Error when a zone is
/// empty; vellum::Cancelled when `progress` is cancelled (checked per slab and per candidate).
void estimateAxes(Pose& pose, const LabelVolume& labels, double contactMm, Progress& progress = Progress::none());

/// The axis fit alone, on the parent's and the child's articular surface voxels (mm) and their
/// outward unit normals, `bandMm` the inlier band: one cylinder axis for both surfaces (each
/// its own radius and centre; each surface judged on its own, so a flat tibial plateau neither
/// steers nor vetoes the condyles' cylinder) or a sphere per surface. Returns the axis through `point` along unit
/// `direction` and how it was found; fit.method is empty when neither fits a curved surface
/// (too few voxels, a flat patch) or the hinge fit is refused (fit.refusals: an edge, surfaces
/// that do not nest or share no axis): estimateAxes() then falls back to the contact zone.
struct AxisEstimate {
  Vec3 point{0, 0, 0}, direction{1, 0, 0};
  AxisFit fit;
};
AxisEstimate fitArticularSurfaces(const std::vector<Vec3>& parentMm, const std::vector<Vec3>& parentNormals,
                                  const std::vector<Vec3>& childMm, const std::vector<Vec3>& childNormals,
                                  double bandMm);

/// The generated control points' sources and what moves them.
struct PoseSamples {
  std::vector<Vec3> sources;  ///< mm
  std::vector<int> joint;     ///< per source: the joint whose transform moves it, -1 still
  int bonePoints = 0, fixedPoints = 0, anchorPoints = 0;
};
/// Samples on every bone of the pose (the voxel of the id nearest to its centroid and to
/// centroid +- spread * sigma along its three principal axes, and per cell of sampleStepMm the
/// voxel nearest the cell's centre), on every fixed id (the principal samples),
/// the corners and centre of every fixed box (clipped to the volume), and `anchors` box points.
/// Points within half a voxel of an earlier one are skipped. Error for a bone id with no voxel.
PoseSamples poseSamples(const Pose& pose, const LabelVolume& labels, const PoseOptions& options);

/// The control points at `anglesDeg`: sources as sampled, targets moved by their joint.
ControlPoints posedPoints(const PoseSamples& samples, const Pose& pose, const std::vector<double>& anglesDeg);

/// Voxels of a bone that a joint moves lying in a fixed box: the box wins (they stay put), so
/// the bone is cut at the box's face and its rim beside the cut must give when it turns (the
/// feet bench's box x >= 253 mm holds 1 voxel of the right calcaneus). One entry per box and
/// id, boxes in the pose's order.
struct FixedBoxCut {
  size_t box = 0;  ///< index into pose.fixed.boxesMm
  uint16_t id = 0;
  int64_t voxels = 0;
};
std::vector<FixedBoxCut> fixedBoxCuts(const Pose& pose, const LabelVolume& labels);

/// Per rigid body (bodies() order) its known transform at `anglesDeg`, BACKWARD (output ->
/// source, as applyRigidity's `prescribed` takes it): the inverse of its joint's composed
/// transform for a moving bone, the identity for a still bone of the pose; unset for the fixed
/// body and bodies the pose does not name.
std::vector<std::optional<RigidTransform>> knownBodyTransforms(const Pose& pose, const RigidBodies& bodies,
                                                               const std::vector<double>& anglesDeg);

/// A control-point keyframe track over the pose's keyframes, for `vellum animate`'s renderer:
/// linear between generated keyframes at most `maxStepDeg` apart in every joint (points on a
/// turning bone then travel close to their arc, not its chord), same total duration and loop.
KeyframeTrack poseTrack(const PoseSamples& samples, const Pose& pose, double maxStepDeg);

/// How well a deformed volume holds a pose, from its backward map (3 floats per output voxel,
/// source mm, x fastest: upsampleMap()) and the label map on the source grid.
struct JointMeasure {
  std::string name;
  double requestedDeg = 0;  ///< the joint's angle
  /// The child's best rigid fit relative to the parent's, turned about the joint axis
  /// (twist angle; NaN when either bone has no sample).
  double achievedDeg = 0;
  /// The child's fit against its requested (composed) transform: the angle between the two
  /// rotations and the distance between where they put the child's centroid.
  double childRotationErrorDeg = 0, childPositionErrorMm = 0;
  double parentRotationDeg = 0;  ///< the parent's fitted rotation angle (0 for a still parent)
  int64_t childSamples = 0, parentSamples = 0;
};
/// Fits (Kabsch, source -> output) each joint's whole parent and child bone (all their ids)
/// over the output voxels whose source lies in them (nearest voxel), every `stride`-th voxel.
std::vector<JointMeasure> measureJoints(const std::vector<float>& mapMm, const Geometry& output,
                                        const LabelVolume& labels, const Pose& pose,
                                        const std::vector<double>& anglesDeg, int stride = 1);

}  // namespace vellum::deformation
