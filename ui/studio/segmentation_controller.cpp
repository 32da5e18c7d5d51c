// SegmentationController: the Segmentation panel's commands and tools (each label edit is one
// undo step, made on the task queue's worker from the labels as the queued edits leave them).
#include "segmentation_controller.hpp"

#include <iostream>
#include <memory>
#include <sstream>

#include "app.hpp"
#include "vellum/core/error.hpp"
#include "vellum/segmentation/label_map.hpp"

namespace vellum::studio {

namespace {
Label labelFor(const LabelVolume& labels, uint16_t id, const std::string& defaultName) {
  if (auto l = labels.label(id)) return *l;
  return {id, defaultName, defaultLabelColor(id)};
}
}  // namespace

void SegmentationController::editInWorker(const std::string& description, DeltaFn fn) {
  Scene& scene = app_.scene();
  if (!scene.hasVolume()) throw Error("no volume is open");
  // The worker reads the labels as they are when this task starts (the tasks before it
  // applied, nothing changing them meanwhile: labelsFrozen() refuses strokes and edits), while
  // the window keeps drawing them: both only read. The delta comes from the operation's own
  // footprint (no copy of the map, issue #22: memory <= 4x the volume); the UI thread applies
  // it between frames, one undo step, so the window never sees a half-written map.
  app_.tasks().push(description, [this, description, fn = std::move(fn), locked = scene.lockedLabels](Progress& p) {
    p.begin(description, 1);
    auto delta = std::make_shared<LabelDelta>(fn(app_.scene().labels, locked, p));
    delta->description = description;
    p.checkCancelled();  // a cancel during the work drops its result
    return TaskQueue::Apply([this, delta] {
      applyDelta(app_.scene().labels, *delta, true);
      pushEdit(std::move(*delta));
    });
  });
}

bool SegmentationController::refuseWhileFrozen(const std::string& what) {
  if (!app_.labelsFrozen()) return false;
  app_.notify(what + " refused: wait for " + app_.tasks().running() + " (or cancel it)");
  return true;
}

void SegmentationController::pushEdit(LabelDelta delta) {
  if (delta.empty()) return;
  app_.undoStack().push(std::move(delta));
  app_.scene().touchLabels();
  app_.markSlicesDirty();
}

void SegmentationController::applyThreshold() {
  if (!app_.scene().hasVolume()) throw Error("no volume is open");
  const auto& t = tools_.threshold;
  std::ostringstream name;
  name << "Threshold " << t.lower << ".." << t.upper;
  // The label as the table has it when the task runs (an earlier queued edit may name it).
  editInWorker("threshold", [this, t, id = tools_.activeLabel, name = name.str()](const LabelVolume& l,
                                                                                   const std::set<uint16_t>& locked, Progress&) {
    return thresholdDelta(l, app_.scene().ct, t, labelFor(l, id, name), locked);
  });
}

void SegmentationController::keepLargestOfActive() {
  editInWorker("keep largest", [id = tools_.activeLabel](const LabelVolume& l, const std::set<uint16_t>& locked,
                                                         Progress&) { return keepLargestDelta(l, id, locked); });
}

void SegmentationController::fillHolesOfActive() {
  editInWorker("fill holes", [id = tools_.activeLabel](const LabelVolume& l, const std::set<uint16_t>& locked,
                                                       Progress&) { return fillHolesDelta(l, id, locked); });
}

void SegmentationController::removeIslandsOfActive() {
  editInWorker("remove islands", [id = tools_.activeLabel, mm3 = tools_.minIslandMm3](
                                     const LabelVolume& l, const std::set<uint16_t>& locked, Progress&) {
    return removeIslandsDelta(l, id, mm3, locked);
  });
}

void SegmentationController::morphologyOfActive(Morphology op) {
  editInWorker(morphologyName(op), [id = tools_.activeLabel, op, r = tools_.brushRadiusMm](
                                       const LabelVolume& l, const std::set<uint16_t>& locked, Progress& p) {
    return morphologyDelta(l, id, op, r, locked, p);
  });
}

void SegmentationController::otsuThreshold() {
  if (!app_.scene().hasVolume()) throw Error("no volume is open");
  tools_.threshold = {otsuHu(app_.scene().ct), 3071};
}

void SegmentationController::startSnake(const Vec3& seedMm) {
  const Scene& scene = app_.scene();
  if (!scene.hasVolume()) throw Error("no volume is open");
  // The request `vellum segment --method snake --lower L --upper U --seed S --radius R` makes,
  // with the panel's snake settings.
  app::SegmentSettings snake = tools_.snake;
  snake.method = "snake";
  snake.lower = tools_.threshold.lower;
  snake.upper = tools_.threshold.upper;
  snake.seedsMm = {seedMm};
  snake.bubbleRadiusMm = tools_.brushRadiusMm;
  if (!snake_.start({scene.ct, std::move(snake), scene.volumeGeneration}))
    throw Error("a snake is already running; cancel it first (Escape)");
}

void SegmentationController::pollSnake() {
  auto out = snake_.take();
  if (!out) return;
  if (!out->error.empty()) {
    std::cerr << "vellum-studio: " << out->error << "\n";
    if (out->error != "snake cancelled") app_.showError(out->error);
    return;
  }
  if (out->volumeGeneration != app_.scene().volumeGeneration) return;  // another volume was opened meanwhile
  if (segmentation::countVoxels(out->mask) == 0) {
    app_.showError("the snake found nothing: is the seed inside the HU range?");
    return;
  }
  std::cout << "snake: " << out->iterations << " iterations" << (out->converged ? ", converged" : "")
            << (out->note.empty() ? "" : "; " + out->note) << std::endl;
  auto mask = std::make_shared<const segmentation::Mask>(std::move(out->mask));
  editInWorker("snake", [mask, id = tools_.activeLabel](const LabelVolume& l, const std::set<uint16_t>& locked,
                                                          Progress&) {
    return maskDelta(l, *mask, labelFor(l, id, "Snake " + std::to_string(id)), locked);
  });
}

void SegmentationController::paintAt(const Pane& pane, double x, double y) {
  Scene& scene = app_.scene();
  const SlicePlane plane = app_.planeOf(pane);
  const uint16_t id = tools_.tool == Tool::Paint ? tools_.activeLabel : 0;
  // Deformed slices: the ball goes around the source of the pixel under the pointer.
  const auto at = app_.sliceSourceMm(plane.toMm(x - pane.rect.x, y - pane.rect.y));
  if (at && stroke_ &&
      paintSphere(scene.labels, *at, tools_.brushRadiusMm, id, scene.lockedLabels, &stroke_->changed) > 0)
    app_.markSlicesDirty();
}

void SegmentationController::growAt(const Pane& pane, double x, double y) {
  const SlicePlane plane = app_.planeOf(pane);
  if (const auto seed = app_.sliceSourceMm(plane.toMm(x - pane.rect.x, y - pane.rect.y))) growFromPoint(*seed);
}

void SegmentationController::growFromPoint(const Vec3& seed) {
  try {
    editInWorker("grow", [this, seed, id = tools_.activeLabel, t = tools_.threshold](
                             const LabelVolume& l, const std::set<uint16_t>& locked, Progress&) {
      return growDelta(l, app_.scene().ct, seed, t, labelFor(l, id, "Region " + std::to_string(id)), locked);
    });
  } catch (const std::exception& e) {
    app_.showError(e.what());
  }
}

// ---- input (moved from StudioApp::onMouseButton / onCursorPos / clickIn3d) ------------------

bool SegmentationController::pressInSlice(const Pane& pane, double x, double y) {
  if (tools_.tool == Tool::Grow) {
    growAt(pane, x, y);
    return true;
  }
  if (tools_.tool == Tool::Snake) {
    const SlicePlane plane = app_.planeOf(pane);
    try {
      if (const auto seed = app_.sliceSourceMm(plane.toMm(x - pane.rect.x, y - pane.rect.y))) startSnake(*seed);
    } catch (const std::exception& e) {
      app_.showError(e.what());
    }
    return true;
  }
  if (tools_.tool != Tool::Navigate) {
    // A worker reads the labels: the stroke would race it (and its delta would undo the
    // stroke), so it is refused with a notice rather than lost silently.
    if (refuseWhileFrozen(tools_.tool == Tool::Paint ? "painting" : "erasing")) return true;
    stroke_ = Stroke{{}, app_.scene().labels.table()};  // the undo step is made on release
  }
  return false;
}

void SegmentationController::dragInSlice(const Pane& pane, double x, double y) {
  if (tools_.tool == Tool::Grow || tools_.tool == Tool::Snake) return;  // the seed click acts once (on press)
  if (stroke_) paintAt(pane, x, y);  // a stroke the press started (not refused)
}

void SegmentationController::release() {
  if (!stroke_) return;
  pushEdit(strokeDelta(std::move(stroke_->changed), std::move(stroke_->tableBefore), app_.scene().labels,
                       tools_.tool == Tool::Paint ? "paint" : "erase"));
  stroke_.reset();
}

bool SegmentationController::seedIn3d(const Vec3& mm) {
  if (tools_.tool == Tool::Grow) {
    growFromPoint(mm);
    return true;
  }
  if (tools_.tool == Tool::Snake) {
    startSnake(mm);
    return true;
  }
  return false;
}

}  // namespace vellum::studio
