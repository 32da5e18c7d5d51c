#pragma once
// The point-authoring controller: owns the control points' interaction (picking, dragging
// with the Drag tool, the drawn dots and keyframe connector), the track and engine edits that
// make undo steps and the points' placement. StudioApp hands it the left presses, drags and
// releases, lets it draw over each pane; the Deformation panel and the script's actions call
// it through StudioApp::points(). The deformation session (the map the views draw through),
// the rigid bones and the joint tool are the DeformController's (deform_controller.hpp).
#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "authoring.hpp"
#include "layout.hpp"
#include "vellum/deformation/deform_params.hpp"

namespace vellum::studio {

class StudioApp;
struct Scene;

/// Where a control point's end is drawn in a pane (window pixels) and which it is.
struct PointHandle {
  int index = -1;
  PointEnd end = PointEnd::Target;
};

/// What dragging a control point does: move it, or change one of its attributes (vertical:
/// lightness; horizontal a = green->red and vertical b = blue->yellow; vertical: density).
enum class PointTool { Move, Lightness, Hue, Density };

/// The attribute change of a drag by (dx, dy) pixels from `start` with an attribute tool.
void applyAttributeDrag(deformation::PointAttributes& out, const deformation::PointAttributes& start, PointTool tool,
                        double dx, double dy);

class PointController {
 public:
  explicit PointController(StudioApp& app) : app_(app) {}

  /// What a drag on a point does (the Deformation panel's Drag radio buttons).
  PointTool& tool() { return tool_; }
  /// A point is being dragged (the views draw coarse meanwhile; undo waits).
  bool dragging() const { return drag_.has_value(); }

  // Commands (Deformation panel, scripts), each one undo step.
  /// Places the 16 default points (box) or the points from the label map as one keyframe.
  void placeControls(bool fromLabels);
  /// Records a change of the keyframe track as one undo step.
  void editTrack(const std::string& description, const std::function<void(Authoring&)>& fn);
  /// Records a track change already made (continuous drags) as one undo step.
  void pushTrackEdit(const std::string& description, deformation::KeyframeTrack before, int keyframeBefore);
  /// A Deformation-panel engine edit: begin with the parameters before it, end records one
  /// undo step (the track is unchanged).
  void beginEngineEdit(const deformation::DeformParams& before);
  void endEngineEdit();
  /// Window pixel where point `index`'s end is drawn in the first pane that shows it (3D first),
  /// or in the pane named `view` ("3d", "axial", "coronal", "sagittal").
  std::optional<std::pair<double, double>> pointOnScreen(int index, PointEnd end, const std::string& view = "") const;

  // Input (window pixels): a left press on a dot starts dragging it (true; Shift: along one
  // axis), the pointer moves it in `pane` (the pane pressed in), the release makes the undo step.
  bool beginDrag(const Pane& pane, double x, double y, int mods);
  void moveDrag(const Pane& pane, double x, double y);
  void endDrag();
  /// The points over a pane: dots, lines and the selected point's keyframe connector.
  void draw(const Pane& pane);

  /// Where a position (mm) is drawn in a pane (window pixels), or nullopt (behind the eye).
  std::optional<std::pair<double, double>> pointInPane(const Pane& pane, const Vec3& mm) const;

 private:
  std::optional<PointHandle> pickPoint(const Pane& pane, double x, double y) const;
  void drawKeyframeConnector(const Pane& pane);
  /// The app's scene (the points are its authoring).
  Scene& scene() const;

  StudioApp& app_;
  PointTool tool_ = PointTool::Move;
  struct PointDrag {
    PointHandle handle;
    Vec3 startMm;
    double pressX = 0, pressY = 0;
    int mods = 0;
    PointTool tool = PointTool::Move;
    deformation::PointAttributes startAttributes;
    deformation::KeyframeTrack before;
    int keyframeBefore = 0;
  };
  std::optional<PointDrag> drag_;
  std::string occlusionKey_;                  ///< what occlusion_ was computed for
  std::vector<std::array<bool, 2>> occlusion_;  ///< per point: source, target hidden in 3D
  std::optional<deformation::DeformParams> engineEditBefore_;  ///< the state before an engine edit in progress
};

}  // namespace vellum::studio
