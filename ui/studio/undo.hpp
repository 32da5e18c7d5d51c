#pragma once
// Undo/redo of label edits as compressed deltas: runs of consecutive voxels whose old and
// new ids are each constant (a threshold or a brush stroke is a few thousand runs, not a
// copy of the 256³ label map), plus the label table before and after.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "authoring.hpp"
#include "view_settings.hpp"

#include "vellum/core/label_volume.hpp"

namespace vellum::studio {

struct LabelDelta {
  struct Run {
    uint64_t start = 0;   ///< linear voxel index of the first voxel
    uint32_t length = 0;
    uint16_t before = 0;
    uint16_t after = 0;
  };
  std::string description;
  std::vector<Run> runs;
  std::vector<Label> tableBefore, tableAfter;

  bool empty() const { return runs.empty() && tableBefore == tableAfter; }
  /// Bytes held (for the memory line in the panel and for tests).
  size_t bytes() const { return runs.size() * sizeof(Run); }
};

/// The runs where `before` and `after` differ (same size required).
LabelDelta diffLabels(const LabelVolume& before, const LabelVolume& after, std::string description);
/// Writes the delta's `after` (redo) or `before` (undo) ids and table into `labels`.
void applyDelta(LabelVolume& labels, const LabelDelta& delta, bool forward);

/// An edit of the authored keyframe track (points placed, dragged, added, deleted; keyframes
/// added, deleted, retimed): the track before and after. A track is small (points x keyframes),
/// so whole copies are simpler than deltas.
struct TrackEdit {
  std::string description;
  deformation::KeyframeTrack before, after;
  int keyframeBefore = 0, keyframeAfter = 0;
  /// The engine parameters (Deformation panel) before and after.
  deformation::DeformParams engineBefore = studioDeformParams(), engineAfter = studioDeformParams();
  /// The rigid bones (label ids, falloff) before and after; unset: this edit left them alone.
  struct Rigid {
    std::vector<uint16_t> labels;
    double falloffMm = 10;
  };
  std::optional<Rigid> rigidBefore, rigidAfter;
  size_t bytes() const;
};

/// An edit of the view settings (View panel: layout, windows, preset, shading, camera numbers;
/// camera bookmarks added, renamed, deleted or recalled): the view state before and after.
/// Navigating with the mouse (orbit, pan, zoom, window/level drags) is not an edit, as in
/// 3D Slicer and Blender: Ctrl+Z must not spend itself on camera moves.
struct ViewEdit {
  std::string description;
  ViewState before, after;
  size_t bytes() const { return sizeof(ViewEdit); }
};

/// A change of the scene's shape folder (the curve analogy's result replacing its input):
/// undo and redo load the other folder.
struct ShapesEdit {
  std::string description;
  std::filesystem::path before, after;
  size_t bytes() const { return sizeof(ShapesEdit); }
};

/// An edit of the joint tool's pose (a joint added or removed, an angle set or dragged, fixed
/// regions, pose keyframes, a pose file loaded): the pose before and after and the edited
/// keyframe. Undo and redo hand the other pose to the joint tool (takePoseToRestore()), which
/// makes the authoring state from it.
struct PoseEdit {
  std::string description;
  deformation::Pose before, after;
  int keyframeBefore = 0, keyframeAfter = 0;
  size_t bytes() const;
};

/// A pose and its edited keyframe to give back to the joint tool.
struct PoseToRestore {
  deformation::Pose pose;
  int keyframe = 0;
};

using UndoEntry = std::variant<LabelDelta, TrackEdit, ViewEdit, ShapesEdit, PoseEdit>;

class UndoStack {
 public:
  /// Records an edit that has already been applied; clears the redo side.
  void push(LabelDelta delta);
  void push(TrackEdit edit);
  void push(ViewEdit edit);
  void push(ShapesEdit edit);
  /// Dropped when the pose and keyframe did not change.
  void push(PoseEdit edit);
  /// After an undo/redo of a ShapesEdit: the folder to load (once), else nullopt.
  std::optional<std::filesystem::path> takeShapesToLoad() { return std::exchange(shapesToLoad_, std::nullopt); }
  /// After an undo/redo of a PoseEdit: the pose to give the joint tool (once), else nullopt.
  std::optional<PoseToRestore> takePoseToRestore() { return std::exchange(poseToRestore_, std::nullopt); }
  bool canUndo() const { return !undo_.empty(); }
  bool canRedo() const { return !redo_.empty(); }
  /// Reverts the last edit on `labels` (`authoring` for track edits, `view` for view edits:
  /// one of those missing throws); false when there is none.
  bool undo(LabelVolume& labels, Authoring* authoring = nullptr, ViewState* view = nullptr);
  bool redo(LabelVolume& labels, Authoring* authoring = nullptr, ViewState* view = nullptr);
  /// undo() when `forward` is false, redo() when true.
  bool step(bool forward, LabelVolume& labels, Authoring* authoring = nullptr, ViewState* view = nullptr);
  /// True when the last undo/redo changed the labels (false: the track or the view).
  bool lastWasLabels() const { return lastWasLabels_; }
  /// True when the last undo/redo changed the view state.
  bool lastWasView() const { return lastWasView_; }
  void clear();
  /// Counts every push, undo and redo (never reset): the document changed since a save when
  /// this differs from its value then (undoing back to the saved state still counts).
  uint64_t changes() const { return changes_; }
  const std::vector<UndoEntry>& undoEntries() const { return undo_; }
  size_t bytes() const;

 private:
  std::vector<UndoEntry> undo_, redo_;
  bool lastWasLabels_ = true, lastWasView_ = false;
  std::optional<std::filesystem::path> shapesToLoad_;
  std::optional<PoseToRestore> poseToRestore_;
  uint64_t changes_ = 0;
  void record(UndoEntry entry);
  void apply(const UndoEntry& e, LabelVolume& labels, Authoring* authoring, ViewState* view, bool forward);
};

}  // namespace vellum::studio
