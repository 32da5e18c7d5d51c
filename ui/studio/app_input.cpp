// StudioApp: the input handlers. GLFW callbacks and script actions both arrive here (after
// ImGui's backend has seen the event), so scripts exercise what a user's mouse does.
#include <GLFW/glfw3.h>
#include <imgui.h>

#include <algorithm>
#include <cmath>

#include "app.hpp"
#include "studio_tools.hpp"
#include "label_tools.hpp"
#include "deform_session.hpp"
#include "view3d.hpp"
#include "vellum/core/error.hpp"

namespace vellum::studio {
namespace fs = std::filesystem;

bool StudioApp::interacting3d() const {
  return (dragPane_ && dragPane_->is3d()) || points_.dragging() || scene_.authoring.playing ||
         glfwGetTime() < zoomInteractionUntil_;
}

const Pane* StudioApp::paneAt(double x, double y) const {
  for (const Pane& p : panes_)
    if (p.rect.contains(x, y)) return &p;
  return nullptr;
}

void StudioApp::onCursorPos(double x, double y) {
  const double dx = x - mouseX_, dy = y - mouseY_;
  mouseX_ = x;
  mouseY_ = y;
  if (!dragPane_ || !scene_.hasVolume()) return;
  if (points_.dragging()) {
    points_.moveDrag(*dragPane_, x, y);
    return;
  }
  if (curves_.extendStroke(*dragPane_, x, y)) return;  // tracing C0 in the 3D view's pixels
  const Pane& pane = *dragPane_;
  const bool shift = dragMods_ & GLFW_MOD_SHIFT;
  if (!pane.is3d()) {
    if (dragButton_ == GLFW_MOUSE_BUTTON_LEFT) {
      if (segmentation_.tools().tool == Tool::Navigate) {
        const SlicePlane plane = planeOf(pane);
        scene_.crosshairMm = plane.toMm(x - pane.rect.x, y - pane.rect.y);
        markSlicesDirty();
      } else {
        segmentation_.dragInSlice(pane, x, y);  // paint, erase (grow and snake seed on press)
      }
    } else if (dragButton_ == GLFW_MOUSE_BUTTON_MIDDLE) {  // pan: the picture follows the pointer
      SliceNavigation& nav = sliceNav_[static_cast<size_t>(*pane.slice)];
      nav = pannedBy(makePlane(*pane.slice, scene_.ct.geometry(), scene_.crosshairMm, int(pane.rect.w), int(pane.rect.h)),
                     nav, dx, dy);
      markSlicesDirty();
    } else if (dragButton_ == GLFW_MOUSE_BUTTON_RIGHT && (dragMods_ & GLFW_MOD_CONTROL)) {
      // Zoom about the press point: up magnifies, 1 % per pixel.
      SliceNavigation& nav = sliceNav_[static_cast<size_t>(*pane.slice)];
      nav = zoomedAbout(makePlane(*pane.slice, scene_.ct.geometry(), scene_.crosshairMm, int(pane.rect.w), int(pane.rect.h)),
                        nav, std::exp(-dy * 0.01), pressX_ - pane.rect.x, pressY_ - pane.rect.y);
      markSlicesDirty();
    } else if (dragButton_ == GLFW_MOUSE_BUTTON_RIGHT) {  // window/level: right widens, down raises the level
      scene_.view.sliceWindow.width = std::max(1.0, scene_.view.sliceWindow.width + dx * 4);
      scene_.view.sliceWindow.center += dy * 2;
    }
    return;
  }
  render::Camera& cam = scene_.render.camera;
  if ((dragButton_ == GLFW_MOUSE_BUTTON_LEFT && shift) || dragButton_ == GLFW_MOUSE_BUTTON_MIDDLE) {
    // Pan: the look-at point moves against the drag so the volume follows the mouse.
    const CameraBasis b = cameraBasis(cam);
    const Vec3 e = scene_.ct.geometry().extent();
    const double mmPerPixel = norm(e) / (cam.zoom * std::max(1.f, pane.rect.h));
    cam.panMm -= b.right * (dx * mmPerPixel);
    cam.panMm += b.up * (dy * mmPerPixel);
  } else if (dragButton_ == GLFW_MOUSE_BUTTON_LEFT) {  // orbit (trackball-style)
    cam.azimuthDeg -= dx * 0.5;
    cam.elevationDeg = std::clamp(cam.elevationDeg + dy * 0.5, -89.0, 89.0);
  } else if (dragButton_ == GLFW_MOUSE_BUTTON_RIGHT) {
    scene_.render.windowWidth = std::max(10.0, scene_.render.windowWidth + dx * 8);
    scene_.render.windowCenter += dy * 4;
  }
}

void StudioApp::onMouseButton(int button, int action, int mods) {
  if (action == GLFW_RELEASE) {
    segmentation_.release();  // a brush stroke becomes one undo step
    if (button == dragButton_) {
      points_.endDrag();
      curves_.endStroke();
      dragPane_.reset();
      dragButton_ = -1;
    }
    return;
  }
  if (ImGui::GetIO().WantCaptureMouse || !scene_.hasVolume()) return;
  const Pane* pane = paneAt(mouseX_, mouseY_);
  if (!pane) return;
  if (button == GLFW_MOUSE_BUTTON_LEFT && deform_.click(*pane, mouseX_, mouseY_)) return;  // the joint tool's pick
  // The ruler or angle tool takes left clicks in the slices.
  if (!pane->is3d() && button == GLFW_MOUSE_BUTTON_LEFT &&
      studioTools_->measure.click(*pane->slice, planeOf(*pane).toMm(mouseX_ - pane->rect.x, mouseY_ - pane->rect.y)))
    return;
  if (pane->is3d() && button == GLFW_MOUSE_BUTTON_LEFT && (mods & GLFW_MOD_CONTROL)) {
    clickIn3d(*pane, mouseX_, mouseY_);  // Ctrl+click picks the visible surface
    return;
  }
  dragPane_ = *pane;
  dragButton_ = button;
  dragMods_ = mods;
  pressX_ = mouseX_;
  pressY_ = mouseY_;
  if (button == GLFW_MOUSE_BUTTON_LEFT && curves_.beginStroke(*pane, mouseX_, mouseY_)) return;  // a new C0
  // A press on a control point's dot drags that point (Shift: along one axis) in any tool.
  if (button == GLFW_MOUSE_BUTTON_LEFT && points_.beginDrag(*pane, mouseX_, mouseY_, mods)) return;
  if (!pane->is3d() && button == GLFW_MOUSE_BUTTON_LEFT) {
    // Grow and Snake seed here, Paint and Erase begin a stroke (or are refused).
    if (segmentation_.pressInSlice(*pane, mouseX_, mouseY_)) return;
    onCursorPos(mouseX_, mouseY_);  // a click acts where it lands
  }
}

void StudioApp::clickIn3d(const Pane& pane, double x, double y) {
  // The surface as the view draws it, through the deformation when one is shown.
  const deformation::MapSampler* map = deform_.session().sampler();
  const auto p = pickSurface(scene_, int(pane.rect.w), int(pane.rect.h), x - pane.rect.x, y - pane.rect.y, map);
  if (!p) return;  // nothing visible under the pointer
  // Labels live in the undeformed volume: seeds go to the picked point's source. The crosshair
  // goes where the slices show that tissue: the point itself in deformed slices.
  const std::optional<Vec3> source = map ? map->sourceMm(*p) : p;
  if (!source) return;
  try {
    if (!segmentation_.seedIn3d(*source)) {  // Grow and Snake seed there
      scene_.crosshairMm = map && scene_.view.deformedSlices ? *p : *source;  // the slices jump there
      markSlicesDirty();
    }
  } catch (const std::exception& e) {
    showError(e.what());
  }
}

void StudioApp::onScroll(double, double dy) {
  if (ImGui::GetIO().WantCaptureMouse || !scene_.hasVolume()) return;
  const Pane* pane = paneAt(mouseX_, mouseY_);
  if (!pane) return;
  if (pane->is3d()) {
    scene_.render.camera.zoom = std::clamp(scene_.render.camera.zoom * std::pow(1.1, dy), 0.1, 50.0);
    zoomInteractionUntil_ = glfwGetTime() + 0.3;
  } else if (ctrlDown_) {  // Ctrl+wheel: zoom about the pointer
    SliceNavigation& nav = sliceNav_[static_cast<size_t>(*pane->slice)];
    nav = zoomedAbout(makePlane(*pane->slice, scene_.ct.geometry(), scene_.crosshairMm, int(pane->rect.w), int(pane->rect.h)),
                      nav, std::pow(1.1, dy), mouseX_ - pane->rect.x, mouseY_ - pane->rect.y);
    markSlicesDirty();
  } else {  // one voxel through the slices per notch
    const SlicePlane plane = makePlane(*pane->slice, scene_.ct.geometry(), scene_.crosshairMm, 1, 1);
    const Vec3& sp = scene_.ct.geometry().spacing;
    scene_.crosshairMm += plane.normal * (dy * std::min({sp.x, sp.y, sp.z}));
    markSlicesDirty();
  }
}

void StudioApp::onKey(int key, int action, int mods) {
  if (key == GLFW_KEY_LEFT_CONTROL || key == GLFW_KEY_RIGHT_CONTROL) ctrlDown_ = action != GLFW_RELEASE;
  if (action == GLFW_RELEASE || ImGui::GetIO().WantTextInput) return;
  const bool ctrl = mods & GLFW_MOD_CONTROL, shift = mods & GLFW_MOD_SHIFT;
  try {
    if (ctrl && key == GLFW_KEY_Z) {
      shift ? redo() : undo();
    } else if (ctrl && key == GLFW_KEY_Y) {
      redo();
    } else if (ctrl && key == GLFW_KEY_O) {
      browser_.open(FileBrowser::Mode::Open, "Open volume or scene", [this](const fs::path& p) { requestOpen(p); });
    } else if (ctrl && key == GLFW_KEY_S) {
      saveSceneOrAsk();
    } else if (ctrl && key == GLFW_KEY_Q) {
      requestClose();
    } else if (!ctrl && key == GLFW_KEY_R) {
      resetView();
    } else if (!ctrl && key == GLFW_KEY_F) {  // fit the slice view under the pointer
      if (const Pane* p = paneAt(mouseX_, mouseY_); p && p->slice) fitSliceView(*p->slice);
    } else if (!ctrl && key >= GLFW_KEY_1 && key <= GLFW_KEY_3) {
      setLayout(key == GLFW_KEY_1 ? Layout::ThreeD : key == GLFW_KEY_2 ? Layout::TwoByTwo : Layout::OneByThree);
    } else if (key == GLFW_KEY_ESCAPE) {
      // Escape cancels what runs (a snake, a load); with nothing running, back to Navigate.
      if (deform_.exporting()) deform_.cancelExport();
      else if (tasks_.busy()) tasks_.cancel();
      else if (segmentation_.snake().busy()) segmentation_.snake().cancel();
      else if (loader_.busy()) loader_.cancel();
      else segmentation_.tools().tool = Tool::Navigate;
    }
  } catch (const std::exception& e) {
    showError(e.what());
  }
}

void StudioApp::onDrop(const std::vector<std::string>& paths) {
  if (!paths.empty()) requestOpen(paths.front());
}


}  // namespace vellum::studio

namespace vellum::studio {
std::pair<int, int> StudioApp::windowSize() const {
  int w = 0, h = 0;
  glfwGetWindowSize(window_, &w, &h);
  return {w, h};
}
}  // namespace vellum::studio
