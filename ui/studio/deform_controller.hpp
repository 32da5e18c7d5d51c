#pragma once
// The deformation controller: owns the deformation session (the map the views draw through,
// solved on its workers), the joint tool (its pose, its preparation worker, its picks and axes
// drawn over the panes) and the deformation's configuration commands: the rigid bones and the
// pose edits, each one undo step. StudioApp asks it for the frame's map, hands it the left
// clicks while the joint tool waits for a pick and lets it draw over each pane, and ticks
// playback and the movie export; panels and script actions call it through
// StudioApp::deform(). The control points themselves are the PointController's
// (point_controller.hpp).
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "layout.hpp"
#include "vellum/deformation/pose.hpp"

namespace vellum::animation {
struct MovieSpec;
}

namespace vellum::studio {

class StudioApp;
class DeformSession;
class ExportJob;
class JointTool;

class DeformController {
 public:
  explicit DeformController(StudioApp& app);
  ~DeformController();  ///< waits for the session's and the joint tool's workers
  DeformController(const DeformController&) = delete;
  DeformController& operator=(const DeformController&) = delete;

  /// The deformation session: the map shown, its solves and timings (deform_session.hpp).
  DeformSession& session() { return *session_; }
  const DeformSession& session() const { return *session_; }
  /// The joint tool (joint_tool.hpp).
  JointTool& joints() { return *joints_; }
  const JointTool& joints() const { return *joints_; }

  // Frame loop.
  /// Brings the map up to date (`interacting`: a point drag or playback; a joint angle drag
  /// counts too); true when it changed. While the exact map is solved on its worker and the
  /// 3D view is not being moved (`waitForExact`), waits for it up to 40 ms first.
  bool updateMap(bool interacting, bool waitForExact);
  /// Adopts the joint tool's finished preparation.
  void poll();
  /// True while a worker runs (the session's solves, a preview, the joint tool).
  bool busy() const;
  /// A joint angle is being dragged (undo waits, the map is solved as during a point drag).
  bool dragging() const;
  /// A left click in `pane` while the joint tool waits for a pick: picks the bone or axis
  /// point under it (true: the click was the tool's).
  bool click(const Pane& pane, double x, double y);
  /// The joints' axes and the draft axis points over a pane.
  void draw(const Pane& pane);
  /// Advances playback by `dtS` seconds and the running export by a frame.
  void tick(double dtS);
  /// While playing or scrubbing a track with keyframed cameras, the 3D view follows them.
  void followCamera();

  // Playback and the movie export.
  void play(bool on);
  /// Starts exporting the track as PNG frames (`out` ending in /) or an MP4 on a worker with
  /// its own headless context, through animation::MovieRenderer (what `vellum animate` runs;
  /// with the joint tool's twist map, what `vellum pose --movie` runs: the twist map's frames).
  /// `orbitDeg` turns the camera's azimuth over the animation (turntables; `--camera-orbit`);
  /// `padMm` grows the movie's box as `--pad-mm` does (-1: automatic over every keyframe).
  void startExport(const std::filesystem::path& out, double fps, int width, int height, double orbitDeg = 0,
                   double padMm = -1);
  /// Stops the export (its GL objects go: before the window's context).
  void cancelExport();
  bool exporting() const { return export_ != nullptr; }
  /// (frames done, frame count) of the running export.
  std::pair<int, int> exportProgress() const;
  /// The last export's error ("" after success).
  const std::string& lastExportError() const { return exportError_; }
  /// The command that writes the same frames as the last export: `vellum animate`, or `vellum
  /// pose --movie` for the joint tool's twist map.
  const std::string& lastExportCommand() const { return exportCommand_; }

  // Commands, each one undo step.
  /// The rigid bones (label ids kept rigid, falloff in mm) set to `labels` / `falloffMm` (the
  /// Deformation panel's checkboxes, the falloff slider's finished drag, the script's
  /// `rigid_labels`). `before` is the state the step undoes to (default: now).
  void setRigid(std::vector<uint16_t> labels, double falloffMm, const std::string& description,
                std::optional<std::pair<std::vector<uint16_t>, double>> before = std::nullopt);
  /// Records the joint tool's pose change from `before` (joints, fixed regions, angles; the
  /// edited keyframe `keyframeBefore`) to its pose now as one undo step (JointTool calls it).
  void pushPoseEdit(const std::string& description, deformation::Pose before, int keyframeBefore);
  /// Undo/redo of a pose edit, and a scene opened with joints (or without: `pose` empty):
  /// the joint tool takes `pose` (prepared again when its joints or fixed regions differ),
  /// the authoring state follows.
  void restorePose(const deformation::Pose& pose, int keyframe);

 private:
  StudioApp& app_;
  std::unique_ptr<DeformSession> session_;
  std::unique_ptr<JointTool> joints_;
  std::unique_ptr<ExportJob> export_;
  /// The output policy for an export to `out` with a JSON file beside it; makes the folder.
  void prepareExportFolder(const std::filesystem::path& out, const animation::MovieSpec& spec,
                           const std::filesystem::path& besideJson, const char* besideWhat);
  std::string exportError_, exportCommand_;
};

}  // namespace vellum::studio
