#pragma once
// The joint tool (issue 23 §3): pick a parent and a child bone (label ids: clicks in the slices
// or the 3D view, or typed in the Joints panel), an axis estimated from their contact zone or
// given by two clicked points, then set the joint's angle per keyframe. The tool holds a
// deformation::Pose, the same object `vellum pose` reads from a pose file, and turns it into
// the studio's authoring state with the pose code's own functions (estimateAxes, poseSamples,
// posedPoints): one authoring keyframe per pose keyframe, the bones rigid per id, the fixed
// regions still, the bones' exact joint transforms given to the live map. Saved as a pose
// file, `vellum pose` reproduces the view (the studio writes its command line beside it).
#include <chrono>
#include <filesystem>
#include <functional>
#include <future>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "vellum/app/pose_pipeline.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/deformation/pose.hpp"

namespace vellum::studio {

class StudioApp;
struct Authoring;

/// What a left click in a view picks while the joint tool waits for one.
enum class JointPick { None, Parent, Child, AxisA, AxisB };

class JointTool {
 public:
  JointTool() = default;
  ~JointTool();  ///< cancels and waits for the worker
  JointTool(const JointTool&) = delete;
  JointTool& operator=(const JointTool&) = delete;

  /// The pose being edited: joints (axes filled once prepared), fixed regions, the angle
  /// track (keyframe k holds every joint's angle, as pose files do).
  deformation::Pose pose;
  deformation::PoseOptions options;  ///< `vellum pose`'s point generation flags
  /// `vellum pose --map` (the Joints panel's choice, poseRequestTable()'s "map" row): with the
  /// twist map the exact map shown is the pose's twist map (DeformSession), what `vellum pose
  /// --map twist` writes; angle drags keep the fast MLS preview.
  app::PoseMap map = app::PoseMap::Auto;
  /// The map in effect: the choice, or for auto the pose file's "map" (else twist), as `vellum pose`.
  bool twist() const { return app::twistChosen(map, pose); }
  /// A new choice: the map is solved again (not an undo step: the pose is unchanged).
  void setMap(StudioApp& app, app::PoseMap choice);

  // The joint being made (the panel's fields and the clicks).
  std::string draftName = "joint";
  std::vector<uint16_t> draftParent, draftChild;
  std::optional<Vec3> draftAxisA, draftAxisB;  ///< both set: the axis; else "estimate"
  /// The two clicked points are a rough axis for the motion search to place (the pose's
  /// "axis_hint": the axis within 30 mm that slides the child along the parent), not the axis.
  bool draftAxisIsHint = false;
  JointPick pick = JointPick::None;

  int selected = 0;       ///< the joint the panel's slider turns
  bool dragging = false;  ///< an angle slider is held: the map is solved as during a point drag

  /// True while the axes and control points are made on the worker.
  bool busy() const { return work_.valid(); }
  /// The worker's progress (0..1) and stage.
  double progress() const { return progress_ ? progress_->fraction() : 0.0; }
  void cancel();
  /// The last preparation's error ("" after success); the panel shows it.
  const std::string& error() const { return error_; }
  /// True once the pose's axes and samples are ready (the authoring state follows the pose).
  bool ready() const { return samples_ != nullptr && !busy(); }
  const deformation::PoseSamples* samples() const { return samples_.get(); }

  /// Adds the draft joint (parent and child ids, axis two points or "estimate") to the pose
  /// (every keyframe gets its angle 0) and prepares it on the worker. Error for an empty
  /// bone, a duplicate name or a chain linkJoints() refuses.
  void addDraftJoint(StudioApp& app);
  void removeJoint(StudioApp& app, int index);
  /// The fixed regions (they do not move at all), then prepared again.
  void setFixed(StudioApp& app, deformation::FixedRegions fixed);
  /// Joint `index`'s angle (deg) in the edited keyframe; cheap (no worker): the points move,
  /// the map follows through the deformation session. One undo step, or, between
  /// beginAngleDrag() and endAngleDrag() (the panel's slider held), part of the drag's one step.
  void setAngle(StudioApp& app, int index, double deg);
  void beginAngleDrag(const StudioApp& app);
  void endAngleDrag(StudioApp& app);
  /// The edited keyframe's angle of joint `index`.
  double angle(const StudioApp& app, int index) const;
  /// A keyframe after the edited one with its angles (the keyframe timeline's rule); edited next.
  void addKeyframe(StudioApp& app);
  void selectKeyframe(StudioApp& app, int k);
  void setDuration(StudioApp& app, double seconds);
  /// Reads a pose file (loadPose) and prepares it.
  void load(StudioApp& app, const std::filesystem::path& path);
  /// Writes the pose file; with `command`, also the `vellum pose` line that renders the
  /// edited keyframe (--frame-time) into `out` with the studio's engine settings.
  void save(const StudioApp& app, const std::filesystem::path& path, const std::filesystem::path& command = {},
            const std::filesystem::path& out = {}) const;
  /// The `vellum pose` arguments for `poseFile` -> `out` at the edited keyframe's time.
  std::string poseArguments(const StudioApp& app, const std::filesystem::path& poseFile,
                            const std::filesystem::path& out) const;
  /// Takes `pose` (undo/redo of a pose edit, a scene opened) with `keyframe` edited: when only
  /// its angles differ from the pose now, the axes and samples stay (cheap); else it is
  /// prepared again. Not an undo step.
  void restore(StudioApp& app, deformation::Pose pose, int keyframe);
  /// A track edit of the Deformation panel (or a script) while joints exist: `fn` runs on the
  /// pose's own angle track (keyframe k holds every joint's angle), so that adding, deleting
  /// or moving a keyframe and its duration, interpolation and loop change the pose: one undo
  /// step (a pose edit), saved with the scene's pose file, the posed track made again from it.
  /// Error, nothing changed, for an edit of the points themselves or a keyframe camera: the
  /// points are generated from the bones (generatedPointsNote()).
  void editTrack(StudioApp& app, const std::string& description, const std::function<void(Authoring&)>& fn);
  /// Why the Deformation panel's point edits are refused while joints exist.
  static const char* generatedPointsNote();
  /// Adopts a finished preparation (the frame loop calls it).
  void poll(StudioApp& app);
  /// The time (s) of the edited keyframe in the pose's track.
  double keyframeTime(const StudioApp& app) const;

 private:
  struct Prepared {
    deformation::Pose pose;
    std::shared_ptr<const deformation::PoseSamples> samples;
  };
  /// Starts estimateAxes + poseSamples on a copy of the labels (a running one is cancelled).
  void prepare(StudioApp& app);
  /// Copies the pose as edited into the scene (Authoring::joints: what the scene file saves).
  void publish(StudioApp& app) const;
  /// The pose's keyframes as the authoring track (points posed by posedPoints), its rigid and
  /// fixed ids, and the pose for the exact bones.
  void apply(StudioApp& app) const;

  std::future<Prepared> work_;
  /// The pose and edited keyframe when the angle slider was pressed (its release makes the undo step).
  std::optional<std::pair<deformation::Pose, int>> angleDragBefore_;
  std::chrono::steady_clock::time_point started_;  ///< of the running preparation
  uint64_t generation_ = 0;  ///< Scene::volumeGeneration the samples were made for
  std::shared_ptr<Progress> progress_;
  std::shared_ptr<const deformation::PoseSamples> samples_;
  std::string error_;
};

/// The script's "joint" action (one key per call; see script.cpp): "add" {name, parent,
/// child, axis: [[x,y,z],[x,y,z]] | "estimate"}, "pick": "parent" | "child" | "axis1" |
/// "axis2" (a "click" then picks), "add_picked": NAME, "angle" {joint: NAME | index, deg},
/// "keyframe": "add" | {select, duration}, "fixed" {labels, boxes}, "save" {path, command,
/// out}, "load": PATH, "remove": index, "map": "auto" | "twist" | "mls". Error for anything else.
void jointScriptAction(StudioApp& app, const nlohmann::json& action);
/// The CT resampled through the map the studio shows (the deformation session's exact map,
/// as the deformed slices sample it), written as a volume file: what `vellum pose --out`
/// writes for the same pose, engine and time.
void saveShownVolume(StudioApp& app, const std::filesystem::path& path);

/// The Joints panel (panel_joints.cpp).
void jointsSection(StudioApp& app);

}  // namespace vellum::studio
