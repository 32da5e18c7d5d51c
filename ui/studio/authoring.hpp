#pragma once
// The deformation being authored: a keyframe track of control points (mm), the keyframe being
// edited, the selected point and playback time. Plain data (no GL), saved with the scene as a
// `vellum animate` keyframe file beside it; every edit of the track is one undo step.
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "vellum/core/label_volume.hpp"
#include "vellum/deformation/deformer.hpp"
#include "vellum/deformation/keyframes.hpp"
#include "vellum/deformation/pose.hpp"
#include "vellum/render/render_settings.hpp"

namespace vellum::studio {

enum class PointEnd { Source, Target };

/// The engine parameters a new scene starts with (s = 4, density-aware weights: the
/// interactive setting); exports name them on the `vellum animate` command line.
deformation::DeformParams studioDeformParams();

struct Authoring {
  deformation::KeyframeTrack track;  ///< no keyframes = no deformation
  int keyframe = 0;                  ///< the keyframe whose points are shown and edited
  int selected = -1;                 ///< selected point index, -1 = none
  /// Set while playing or scrubbing: the view shows track.at(time) instead of the keyframe.
  std::optional<double> timeS;
  bool playing = false;
  std::vector<uint16_t> rigidLabels;  ///< label ids that stay rigid (bones); empty = none
  double falloffMm = 10;              ///< `vellum animate --rigid-falloff`
  /// Regions that do not move at all (the joint tool's pose: its fixed labels and boxes).
  deformation::FixedRegions fixed;
  /// Set by the joint tool (joint_tool.hpp): the pose whose keyframes this track's keyframes
  /// are; its bones then take their joints' transforms at the angles of the time shown
  /// (`vellum pose`'s exact bones) instead of the best rigid fit of the map.
  std::shared_ptr<const deformation::Pose> pose;
  /// The joint tool's pose as edited (JointTool::pose: joints, fixed regions, angle keyframes),
  /// what the scene file saves beside the scene; null: no joints. `pose` follows it once the
  /// tool has prepared it.
  std::shared_ptr<const deformation::Pose> joints;
  /// The engine (Deformation panel, generated from deformParamsTable(); saved in the scene).
  deformation::DeformParams engine = studioDeformParams();
  uint64_t revision = 0;              ///< bumped by every change of what is drawn

  bool active() const { return !track.keyframes.empty(); }
  /// The points drawn now: the interpolated ones while playing/scrubbing, else the keyframe's.
  deformation::ControlPoints currentPoints() const;
  /// The edited keyframe's points (throws when there is no keyframe).
  deformation::ControlPoints& editablePoints();
  void touch() { ++revision; }
};

/// The time (s) at which keyframe k is reached: the durations before it.
double keyframeStartS(const deformation::KeyframeTrack& track, int k);
/// Replaces the track by one keyframe holding `points` (sources = targets).
void placePoints(Authoring& a, deformation::ControlPoints points);
/// "Add keyframe" copies the current keyframe (the paper's rule) after it and edits the copy.
void addKeyframe(Authoring& a);
void deleteKeyframe(Authoring& a, int index);
/// Reorders: keyframe `index` swaps its pose with its neighbour `offset` (-1 earlier, +1
/// later) away; the durations stay with their places in the timeline. It stays the edited one.
void moveKeyframe(Authoring& a, int index, int offset);
/// Reorders by dragging: keyframe `from`'s pose moves to place `to`, the poses between shift
/// one place towards `from`; the durations stay with their places. `to` becomes the edited one.
void moveKeyframeTo(Authoring& a, int from, int to);
/// "Key camera": the view's whole camera (field of view included) as a keyframe camera.
deformation::KeyframeCamera keyframeCameraOf(const render::Camera& c);
/// Adds a point (source = target = mm) to every keyframe; it becomes selected.
void addPoint(Authoring& a, const Vec3& mm);
void deletePoint(Authoring& a, int index);

/// True when both tracks have the same keyframes' points (positions and attributes).
bool samePoints(const deformation::KeyframeTrack& a, const deformation::KeyframeTrack& b);
/// The same joints (names, bones, axes as given or "estimate": estimated axes are not
/// compared) and fixed regions: what the joint tool's preparation depends on.
bool sameJoints(const deformation::Pose& a, const deformation::Pose& b);
/// sameJoints() and the same angle track (angles, durations, interpolation, loop).
bool samePose(const deformation::Pose& a, const deformation::Pose& b);

/// Label ids that look like bone by name (femur, tibia, fibula, patella, bone, ...): the
/// default rigid bodies of a label map.
std::vector<uint16_t> boneLikeLabels(const LabelVolume& labels);

}  // namespace vellum::studio
