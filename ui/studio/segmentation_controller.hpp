#pragma once
// The segmentation controller: owns the Segmentation panel's tools (threshold, brush, active
// label, snake settings), the snake job and the brush stroke in progress, and the label-edit
// commands (threshold, islands, fill, morphology, paint, grow, snake), each one undo step made
// on the task queue's worker. StudioApp hands it the slice clicks and drags of the paint,
// erase, grow and snake tools, polls the snake every frame; the panel and the script's actions
// call it through StudioApp::segmentation().
#include <cstdint>
#include <functional>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "label_tools.hpp"
#include "layout.hpp"
#include "snake_job.hpp"
#include "undo.hpp"
#include "vellum/app/segment_pipeline.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/segmentation/threshold.hpp"

namespace vellum::studio {

class StudioApp;

enum class Tool { Navigate, Paint, Erase, Grow, Snake };

/// Segmentation panel state (not saved in scenes).
struct ToolState {
  Tool tool = Tool::Navigate;
  float brushRadiusMm = 4.f;
  float minIslandMm3 = 100.f;  ///< "Remove islands" keeps components at least this large
  uint16_t activeLabel = 1;
  segmentation::HuInterval threshold = segmentation::presetInterval(segmentation::Preset::Bone);
  bool thresholdPreview = false;
  /// The snake tool's settings (speed, weights, iterations, post-processing), edited through
  /// segmentSettingsTable() like `vellum segment`'s flags; the seed, the bubble radius (the
  /// brush radius) and the HU range (the threshold's) come from the tools above.
  app::SegmentSettings snake = [] {
    app::SegmentSettings r;
    r.method = "snake";
    return r;
  }();
};

class SegmentationController {
 public:
  explicit SegmentationController(StudioApp& app) : app_(app) {}

  ToolState& tools() { return tools_; }
  const ToolState& tools() const { return tools_; }
  SnakeJob& snake() { return snake_; }
  const SnakeJob& snake() const { return snake_; }

  // Commands on the active label (panel buttons, scripts), each one undo step.
  void applyThreshold();
  void keepLargestOfActive();
  void fillHolesOfActive();
  void removeIslandsOfActive();
  void morphologyOfActive(Morphology op);
  /// Sets the threshold range to [Otsu, 3071] HU.
  void otsuThreshold();
  /// Starts the snake from a seed (mm) with the threshold range as its inside and the brush
  /// radius as its bubble (what the Snake tool's click does).
  void startSnake(const Vec3& seedMm);
  /// Adopts a finished snake as one label edit (every frame).
  void pollSnake();

  // Input (window pixels). A left press in a slice: Grow and Snake seed there, Paint and Erase
  // begin a stroke (true: the press is done; false: it acts where it lands through dragInSlice).
  bool pressInSlice(const Pane& pane, double x, double y);
  /// A left drag in a slice with the Paint or Erase tool: the stroke continues.
  void dragInSlice(const Pane& pane, double x, double y);
  /// The button's release: a stroke becomes one undo step.
  void release();
  /// A brush stroke is in progress: the UI thread is writing the labels.
  bool stroking() const { return stroke_.has_value(); }
  /// Ctrl+click in the 3D view on the visible surface, at its source `mm`: Grow and Snake seed
  /// there (true); other tools leave it to the crosshair (false).
  bool seedIn3d(const Vec3& mm);

 private:
  /// A label edit on the task queue's worker: `fn` reads the labels (never writes them) and
  /// returns its footprint delta (locked segments protected, label_tools.hpp); the window
  /// applies it, one undo step.
  using DeltaFn = std::function<LabelDelta(const LabelVolume&, const std::set<uint16_t>& locked, Progress&)>;
  void editInWorker(const std::string& description, DeltaFn fn);
  void pushEdit(LabelDelta delta);
  /// True (and a notice) when the labels are frozen by running tasks: `what` waits.
  bool refuseWhileFrozen(const std::string& what);
  void paintAt(const Pane& pane, double x, double y);
  void growAt(const Pane& pane, double x, double y);
  void growFromPoint(const Vec3& seedMm);

  StudioApp& app_;
  ToolState tools_;
  SnakeJob snake_;
  /// A brush stroke in progress: the voxels it changed (index, previous id) and the label
  /// table before it, made into one undo step on release (no copy of the whole map).
  struct Stroke {
    std::vector<std::pair<uint64_t, uint16_t>> changed;
    std::vector<Label> tableBefore;
  };
  std::optional<Stroke> stroke_;
};

}  // namespace vellum::studio
