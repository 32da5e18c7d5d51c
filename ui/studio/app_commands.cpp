// StudioApp: commands of the panels, keys and scripts (each label edit is one undo step).
#include <GLFW/glfw3.h>

#include <algorithm>
#include <chrono>
#include <thread>
#include <iostream>
#include <sstream>

#include "app.hpp"
#include "label_tools.hpp"
#include "vellum/segmentation/label_map.hpp"
#include "view3d.hpp"
#include "vellum/core/error.hpp"
#include "vellum/io/output_policy.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/core/params.hpp"

namespace vellum::studio {
namespace fs = std::filesystem;

// ---- commands ----------------------------------------------------------------------------

void StudioApp::viewChanged() {
  view3d_->invalidate();
  markSlicesDirty();
}

void StudioApp::invalidate3d() { view3d_->invalidate(); }

void StudioApp::pushViewEdit(const std::string& description, const ViewState& before) {
  undo_.push(ViewEdit{description, before, scene_.viewState()});
  viewChanged();
}

void StudioApp::setLayout(Layout l) {
  const ViewState before = scene_.viewState();
  scene_.view.layout = l;
  pushViewEdit("layout", before);
}

void StudioApp::setPreset(render::Preset p) {
  const ViewState before = scene_.viewState();
  scene_.render.preset = p;
  pushViewEdit("preset", before);
}

void StudioApp::setViewParameter(const std::string& key, const std::string& value) {
  const ViewState before = scene_.viewState();
  const auto& notInScene = renderKeysNotInScene();
  if (const auto* f = params::findField(viewSettingsTable(), key)) {
    params::parse(*f, scene_.view, value);
  } else if (const auto* r = params::findField(render::renderSettingsTable(), key);
             r && std::find(notInScene.begin(), notInScene.end(), key) == notInScene.end()) {
    params::parse(*r, scene_.render, value);
  } else {
    throw Error("unknown view parameter '" + key + "'");
  }
  pushViewEdit(key, before);
}

void StudioApp::beginViewEdit(const ViewState& before) {
  if (!viewEditBefore_) viewEditBefore_ = before;
}

void StudioApp::endViewEdit(const std::string& description) {
  const ViewState before = viewEditBefore_.value_or(scene_.viewState());
  viewEditBefore_.reset();
  pushViewEdit(description, before);
}

void StudioApp::addBookmark(const std::string& name) {
  const ViewState before = scene_.viewState();
  std::string n = name;
  if (n.empty()) n = "view " + std::to_string(scene_.bookmarks.size() + 1);
  scene_.bookmarks.push_back({n, scene_.render.camera});
  pushViewEdit("add bookmark", before);
}

void StudioApp::goToBookmark(size_t index) {
  if (index >= scene_.bookmarks.size()) throw Error("no camera bookmark " + std::to_string(index));
  const ViewState before = scene_.viewState();
  scene_.render.camera = scene_.bookmarks[index].camera;
  pushViewEdit("go to bookmark", before);
}

void StudioApp::deleteBookmark(size_t index) {
  if (index >= scene_.bookmarks.size()) throw Error("no camera bookmark " + std::to_string(index));
  const ViewState before = scene_.viewState();
  scene_.bookmarks.erase(scene_.bookmarks.begin() + static_cast<std::ptrdiff_t>(index));
  pushViewEdit("delete bookmark", before);
}

void StudioApp::resetView() {
  scene_.resetView();
  sliceNav_ = {};
  markSlicesDirty();
}

void StudioApp::fitSliceView(SliceAxis axis) {
  sliceNav_[static_cast<size_t>(axis)] = {};
  markSlicesDirty();
}

SlicePlane StudioApp::planeOf(const Pane& pane) const {
  return navigated(makePlane(*pane.slice, scene_.ct.geometry(), scene_.crosshairMm, int(pane.rect.w), int(pane.rect.h)),
                   sliceNav_[static_cast<size_t>(*pane.slice)]);
}

void StudioApp::setWindowPreset(const std::string& name) {
  for (const WindowPreset& p : windowPresets())
    if (name == p.name) {
      const ViewState before = scene_.viewState();
      scene_.view.sliceWindow = {p.center, p.width};
      pushViewEdit("window " + name, before);
      return;
    }
  std::string names;
  for (const WindowPreset& p : windowPresets()) names += std::string(names.empty() ? "" : ", ") + p.name;
  throw Error("unknown window preset '" + name + "' (" + names + ")");
}

void StudioApp::holdTasks(bool on) {
  if (!on) {
    *holding_ = false;
    return;
  }
  *holding_ = true;
  tasks_.push("held task", [holding = holding_](Progress& p) {
    p.begin("held task", 1);
    while (*holding) {
      p.checkCancelled();
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return TaskQueue::Apply();
  });
}

void StudioApp::notify(const std::string& message) {
  std::cerr << "vellum-studio: " << message << "\n";
  notice_ = message;
  noticeUntil_ = glfwGetTime() + 4;
}

void StudioApp::pollTasks() {
  tasks_.poll([this](const std::string& error) {
    lastTaskError_ = error;
    if (error.size() >= 9 && error.compare(error.size() - 9, 9, "cancelled") == 0) notify(error);
    else showError(error);
  });
}

bool StudioApp::undoStep(bool forward) {
  if (points_.dragging() || deform_.dragging()) return false;  // not in the middle of a drag
  if (labelsFrozen()) {  // after the running edits, in order
    tasks_.push(forward ? "redo" : "undo",
                [this, forward](Progress&) { return TaskQueue::Apply([this, forward] { undoStep(forward); }); });
    return true;
  }
  ViewState view = scene_.viewState();
  if (!undo_.step(forward, scene_.labels, &scene_.authoring, &view)) return false;
  if (undo_.lastWasLabels()) scene_.touchLabels();
  if (undo_.lastWasView()) scene_.setViewState(view), view3d_->invalidate();
  if (const auto folder = undo_.takeShapesToLoad()) makeShapes(*folder);
  if (auto pose = undo_.takePoseToRestore()) {
    try {
      deform_.restorePose(pose->pose, pose->keyframe);
    } catch (const std::exception& e) {  // the pose is restored; its preparation failed
      notify(std::string("joint tool: ") + e.what());
    }
  }
  markSlicesDirty();
  return true;
}

bool StudioApp::readSceneOnWorker(const std::string& name, std::function<void(const Scene&)> read) {
  if (segmentation_.stroking()) return false;  // the stroke writes the labels on this thread
  tasks_.push(name, [this, read = std::move(read)](Progress&) {
    read(scene_);
    return TaskQueue::Apply{};
  });
  return true;
}

void StudioApp::makeShapes(const fs::path& folder) {
  if (!scene_.hasVolume()) throw Error("no volume is open");
  if (shapes_.pending()) throw Error("shapes are already being made; cancel first");
  // The job's copies of the CT and labels (hundreds of MB on a real scan) are made by the task
  // queue's worker, from the labels as the queued edits leave them.
  tasks_.push("copying the volume for shapes", [this, folder](Progress&) {
    auto request = std::make_shared<ShapeRequest>(ShapeRequest{scene_.ct, scene_.labels, folder, scene_.volumeGeneration});
    return TaskQueue::Apply([this, request] {
      if (!shapes_.start(std::move(*request))) showError("shapes are already being made; cancel first");
    });
  });
}

void StudioApp::pollShapes() {
  auto out = shapes_.take();
  if (!out) return;
  if (!out->error.empty()) {
    std::cerr << "vellum-studio: " << out->error << "\n";
    if (out->error != "shapes cancelled") showError(out->error);
    return;
  }
  if (out->volumeGeneration != scene_.volumeGeneration) return;  // another volume meanwhile
  scene_.shapes = std::move(out->shapes);
  scene_.shapeMeshes = std::move(out->meshes);
  scene_.shapesPath = out->folder;
  ++scene_.shapesRevision;
  if (!scene_.illustration.enabled) setIllustration(true);  // what the user made them for
}

void StudioApp::setIllustration(bool on) {
  const ViewState before = scene_.viewState();
  scene_.illustration.enabled = on;
  pushViewEdit(on ? "illustration on" : "illustration off", before);
}

void StudioApp::setStylePreset(const std::string& name) {
  const ViewState before = scene_.viewState();
  scene_.illustration.style = illustration::stylePreset(name);
  pushViewEdit("style " + name, before);
}

void StudioApp::setStyleField(const std::string& segment, const std::string& key, const std::string& value) {
  const ViewState before = scene_.viewState();
  illustration::Style& style = scene_.illustration.style;
  if (segment.empty()) {
    const auto* f = params::findField(illustration::styleTable(), key);
    if (!f) throw Error("unknown style field '" + key + "'");
    params::parse(*f, style, value);
  } else {
    const auto* f = params::findField(illustration::segmentStyleTable(), key);
    if (!f || key == "match") throw Error("unknown segment style field '" + key + "'");
    params::parse(*f, ownStyleRow(style, segment), value);
  }
  pushViewEdit("style " + key, before);
}

void StudioApp::saveLabels(const fs::path& path, std::function<void()> then) {
  if (!scene_.hasVolume()) throw Error("no volume is open");
  // The output policy: the labels never replace the CT, nor a folder or file of another kind.
  io::OutputPlan().input(scene_.volumePath, "the open volume").output(path, "the label map").check();
  // Written by the worker after the queued edits, the labels unchanged meanwhile.
  tasks_.push("saving labels", [this, path, then = std::move(then)](Progress&) {
    io::saveLabels(scene_.labels, path);
    return TaskQueue::Apply([this, path, then] {
      scene_.labelsPath = path;
      scene_.labelsModified = false;
      if (then) then();
    });
  });
}

void StudioApp::saveScene(const fs::path& path, std::function<void()> then) {
  if (!scene_.hasVolume()) throw Error("no volume is open");
  if (labelsFrozen()) {  // after the queued edits: the labels they make are the ones saved
    tasks_.push("saving scene", [this, path, then](Progress&) {
      return TaskQueue::Apply([this, path, then] { saveScene(path, then); });
    });
    return;
  }
  const bool hasLabels = !scene_.labels.table().empty() || scene_.labelsModified;
  io::OutputPlan().input(scene_.volumePath, "the open volume").json(path, "the scene").check();
  // The scene file is described when it is written (after the label map, on the UI thread).
  auto writeScene = [this, path, then] {
    writeSceneFile(describeScene(scene_), path);
    scene_.scenePath = path;
    savedChanges_ = undo_.changes();
    if (then) then();
  };
  if (hasLabels && (scene_.labelsPath.empty() || scene_.labelsModified))
    saveLabels(path.parent_path() / (path.stem().string() + ".labels.nrrd"), writeScene);
  else
    writeScene();
}

void StudioApp::quit(int code) {
  exitCode_ = code;
  quitRequested_ = true;
}


}  // namespace vellum::studio
