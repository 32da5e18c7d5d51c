#include "app.hpp"

#include <GL/glcorearb.h>
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <imgui.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <sstream>
#include <tuple>

#include "gl_texture.hpp"
#include "label_tools.hpp"
#include "panels.hpp"
#include "script.hpp"
#include "view3d.hpp"
#include "vellum/core/error.hpp"
#include "vellum/io/image_io.hpp"
#include "vellum/io/volume_io.hpp"
#include "window_context.hpp"

namespace vellum::studio {
namespace fs = std::filesystem;

namespace {

StudioApp* appOf(GLFWwindow* w) { return static_cast<StudioApp*>(glfwGetWindowUserPointer(w)); }

// The GLFW callback chain: ImGui's backend sees every event first, then the app. Scripts
// call these same functions (StudioApp::inject*).
void cursorPosCallback(GLFWwindow* w, double x, double y) { appOf(w)->onCursorPos(x, y); }
void mouseButtonCallback(GLFWwindow* w, int button, int action, int mods) {
  ImGui_ImplGlfw_MouseButtonCallback(w, button, action, mods);
  appOf(w)->onMouseButton(button, action, mods);
}
void scrollCallback(GLFWwindow* w, double dx, double dy) {
  ImGui_ImplGlfw_ScrollCallback(w, dx, dy);
  appOf(w)->onScroll(dx, dy);
}
void keyCallback(GLFWwindow* w, int key, int scancode, int action, int mods) {
  ImGui_ImplGlfw_KeyCallback(w, key, scancode, action, mods);
  appOf(w)->onKey(key, action, mods);
}
void charCallback(GLFWwindow* w, unsigned c) { ImGui_ImplGlfw_CharCallback(w, c); }
void dropCallback(GLFWwindow* w, int count, const char** paths) {
  appOf(w)->onDrop(std::vector<std::string>(paths, paths + count));
}

constexpr float kPanelWidth = 330;

ImU32 planeColour(const Vec3& normal) {
  // 3D Slicer's convention: axial red, coronal green, sagittal yellow.
  if (std::abs(normal.z) > 0.5) return IM_COL32(230, 60, 60, 255);
  if (std::abs(normal.y) > 0.5) return IM_COL32(80, 200, 80, 255);
  return IM_COL32(230, 210, 60, 255);
}

}  // namespace

namespace {
Label labelFor(const LabelVolume& labels, uint16_t id, const std::string& defaultName) {
  if (auto l = labels.label(id)) return *l;
  return {id, defaultName, defaultLabelColor(id)};
}
}  // namespace

StudioApp::StudioApp(StudioOptions options) : options_(std::move(options)) {}

StudioApp::~StudioApp() {
  if (!window_) return;
  view3d_.reset();
  for (auto& t : sliceTextures_) t.reset();
  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
  context_.reset();
  glfwDestroyWindow(window_);
  glfwTerminate();
}

void StudioApp::createWindow() {
  glfwSetErrorCallback([](int, const char* msg) { std::cerr << "vellum-studio: GLFW: " << msg << "\n"; });
  if (!glfwInit()) throw Error("GLFW initialisation failed (is DISPLAY set? use xvfb-run -a)");
  for (int minor : {5, 3}) {
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, minor);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
    window_ = glfwCreateWindow(options_.width, options_.height, "Vellum Studio", nullptr, nullptr);
    if (window_) break;
  }
  if (!window_) throw Error("cannot open a GL 4.5/4.3 core window");
  glfwSetWindowUserPointer(window_, this);
  context_ = std::make_unique<WindowContext>(window_);
  glfwSwapInterval(0);  // frame times measure work, not the display's refresh

  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini: same layout every run (and in tests)
  ImGui::StyleColorsDark();
  ImGui_ImplGlfw_InitForOpenGL(window_, false);  // callbacks are chained by hand above
  ImGui_ImplOpenGL3_Init("#version 330");
  glfwSetCursorPosCallback(window_, cursorPosCallback);
  glfwSetMouseButtonCallback(window_, mouseButtonCallback);
  glfwSetScrollCallback(window_, scrollCallback);
  glfwSetKeyCallback(window_, keyCallback);
  glfwSetCharCallback(window_, charCallback);
  glfwSetDropCallback(window_, dropCallback);
  // ImGui reads the pointer only while the window is focused or hovered: it tracks both.
  glfwSetCursorEnterCallback(window_, ImGui_ImplGlfw_CursorEnterCallback);
  glfwSetWindowFocusCallback(window_, ImGui_ImplGlfw_WindowFocusCallback);
  view3d_ = std::make_unique<View3D>(*context_);
  for (auto& t : sliceTextures_) t = std::make_unique<GlTexture>();
}

int StudioApp::run() {
  if (!options_.script.empty()) script_ = ScriptRunner::load(options_.script);  // before the window
  createWindow();
  if (!options_.input.empty()) requestOpen(options_.input, options_.labels);
  while (!quitRequested_ && !glfwWindowShouldClose(window_)) {
    if (script_) {
      if (const auto code = script_->step(*this)) {
        exitCode_ = *code;
        break;
      }
    } else if (idle() && !dragPane_) {
      glfwWaitEventsTimeout(0.1);  // nothing to refine: sleep until an event
    }
    frame();
  }
  loader_.cancel();
  return exitCode_;
}

bool StudioApp::idle() const {
  const bool viewPending = scene_.hasVolume() &&
                           std::any_of(panes_.begin(), panes_.end(), [](const Pane& p) { return p.is3d(); }) &&
                           !view3d_->refined();
  return !loader_.busy() && !viewPending && pendingScreenshot_.empty();
}

void StudioApp::frame() {
  const auto t0 = std::chrono::steady_clock::now();
  glfwPollEvents();
  pollLoader();
  ImGui_ImplOpenGL3_NewFrame();
  ImGui_ImplGlfw_NewFrame();
  if (script_) {
    // The backend polls the X pointer, which scripts do not move: give ImGui the injected one.
    ImGuiIO& io = ImGui::GetIO();
    io.MousePos = {static_cast<float>(mouseX_), static_cast<float>(mouseY_)};
    for (int b = 0; b < 3; ++b) io.MouseDown[b] = virtualDown_[b];
  }
  ImGui::NewFrame();

  int w = 0, h = 0;
  glfwGetWindowSize(window_, &w, &h);
  panes_ = layoutPanes(scene_.layout, {kPanelWidth, 0, std::max(1.f, w - kPanelWidth), float(h)});
  drawToolPanel(*this, kPanelWidth, float(h));
  browser_.draw();
  if (errorPopupPending_) {
    ImGui::OpenPopup("Error");
    errorPopupPending_ = false;
  }
  if (ImGui::BeginPopupModal("Error", nullptr, ImGuiWindowFlags_AlwaysAutoResize)) {
    ImGui::PushTextWrapPos(560);
    ImGui::TextUnformatted(errorMessage_.c_str());
    ImGui::PopTextWrapPos();
    if (ImGui::Button("OK", {120, 0})) ImGui::CloseCurrentPopup();
    ImGui::EndPopup();
  }

  bool rendered3d = false;
  if (scene_.hasVolume()) {
    updateSliceTextures();
    for (const Pane& p : panes_)
      if (p.is3d())
        rendered3d = view3d_->update(scene_, int(p.rect.w), int(p.rect.h), interacting3d());
  }
  drawPanes();
  if (hudVisible) drawHud();
  ImGui::Render();

  int fbw = 0, fbh = 0;
  glfwGetFramebufferSize(window_, &fbw, &fbh);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glViewport(0, 0, fbw, fbh);
  glClearColor(0.08f, 0.08f, 0.09f, 1.f);
  glClear(GL_COLOR_BUFFER_BIT);
  ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
  if (!pendingScreenshot_.empty()) captureWindow();
  glfwSwapBuffers(window_);
  lastFrameMs_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  if (options_.logFrames)
    std::printf("frame %ld ms %.2f render3d %d render3d_ms %.2f scale %d interacting %d\n", frameNumber_,
                lastFrameMs_, rendered3d ? 1 : 0, rendered3d ? view3d_->lastRenderMs() : 0.0,
                view3d_->lastScale(), dragPane_ ? 1 : 0);
  ++frameNumber_;
}

// ---- loading ---------------------------------------------------------------------------

void StudioApp::requestOpen(const fs::path& path, const fs::path& labels, const std::string& seriesUid) {
  if (!loader_.start({path, labels, seriesUid})) showError("a file is still loading; cancel it first");
}

void StudioApp::pollLoader() {
  if (auto r = loader_.take()) adoptLoad(std::move(*r));
}

void StudioApp::adoptLoad(LoadResult r) {
  lastLoadError_ = r.error;
  if (!r.error.empty()) {
    showError(r.error);  // the current scene stays as it was
    return;
  }
  scene_.ct = std::move(r.ct);
  scene_.labels = std::move(r.labels);
  scene_.volumePath = r.volumePath;
  scene_.labelsPath = r.labelsPath;
  scene_.scenePath = r.scenePath;
  scene_.labelsModified = false;
  scene_.series = std::move(r.series);
  scene_.seriesUid = r.seriesUid;
  const fs::path opened = r.scene ? r.scenePath : r.volumePath;
  std::erase(recent_, opened);
  recent_.insert(recent_.begin(), opened);
  if (recent_.size() > 8) recent_.resize(8);
  if (r.scene) {
    applySceneView(*r.scene, scene_);
  } else {
    scene_.resetView();
  }
  undo_.clear();
  tools_.activeLabel = std::max<uint16_t>(1, scene_.labels.table().empty() ? 1 : scene_.labels.table().front().id);
  view3d_->setVolume(scene_.ct);
  markSlicesDirty();
  glfwSetWindowTitle(window_, ("Vellum Studio - " + (r.scene ? r.scenePath : r.volumePath).filename().string()).c_str());
  for (const auto& w : r.warnings) std::cerr << "vellum-studio: warning: " << w << "\n";
}

void StudioApp::showError(const std::string& message) {
  std::cerr << "vellum-studio: " << message << "\n";
  errorMessage_ = message;
  errorPopupPending_ = true;
}

// ---- slices ----------------------------------------------------------------------------

void StudioApp::updateSliceTextures() {
  std::ostringstream key;
  key.precision(10);
  key << scene_.crosshairMm.x << ' ' << scene_.crosshairMm.y << ' ' << scene_.crosshairMm.z << ' '
      << scene_.sliceWindow.center << ' ' << scene_.sliceWindow.width << ' ' << scene_.labelOpacity << ' '
      << tools_.thresholdPreview << ' ' << tools_.threshold.lower << ' ' << tools_.threshold.upper << ' '
      << scene_.hiddenLabels.size();
  for (const Pane& p : panes_) key << ' ' << p.rect.w << 'x' << p.rect.h;
  if (!slicesDirty_ && key.str() == lastSliceKey_) return;
  SliceStyle style;
  style.window = scene_.sliceWindow;
  style.labels = &scene_.labels;
  style.labelOpacity = scene_.labelOpacity;
  style.hidden = &scene_.hiddenLabels;
  if (tools_.thresholdPreview) style.thresholdPreview = tools_.threshold;
  for (const Pane& p : panes_) {
    if (p.is3d()) continue;
    const SlicePlane plane = makePlane(*p.slice, scene_.ct.geometry(), scene_.crosshairMm, int(p.rect.w), int(p.rect.h));
    sliceTextures_[static_cast<size_t>(*p.slice)]->upload(renderSlice(scene_.ct, plane, style));
  }
  slicesDirty_ = false;
  lastSliceKey_ = key.str();
}

void StudioApp::drawPanes() {
  ImDrawList* dl = ImGui::GetBackgroundDrawList();
  for (const Pane& p : panes_) {
    const ImVec2 a{p.rect.x, p.rect.y}, b{p.rect.x + p.rect.w, p.rect.y + p.rect.h};
    dl->AddRectFilled(a, b, IM_COL32(0, 0, 0, 255));
    if (!scene_.hasVolume()) continue;
    if (p.is3d()) {
      const GlTexture& t = view3d_->texture();
      if (t.valid()) dl->AddImage(reinterpret_cast<ImTextureID>(static_cast<intptr_t>(t.id())), a, b);
      dl->AddText({a.x + 6, a.y + 4}, IM_COL32(200, 200, 255, 255),
                  (std::string("3D  ") + render::presetName(scene_.preset)).c_str());
      if (panes_.size() > 1) drawPlanesIn3d(p);
      continue;
    }
    const GlTexture& t = *sliceTextures_[static_cast<size_t>(*p.slice)];
    if (t.valid())
      dl->AddImage(reinterpret_cast<ImTextureID>(static_cast<intptr_t>(t.id())), a,
                   {a.x + float(t.width()), a.y + float(t.height())});
    const SlicePlane plane = makePlane(*p.slice, scene_.ct.geometry(), scene_.crosshairMm, int(p.rect.w), int(p.rect.h));
    const auto [cx, cy] = plane.toPixel(scene_.crosshairMm);
    dl->PushClipRect(a, b, true);
    // Vertical line: the plane whose normal is u; horizontal: the plane whose normal is v.
    dl->AddLine({a.x + float(cx), a.y}, {a.x + float(cx), b.y}, planeColour(plane.u));
    dl->AddLine({a.x, a.y + float(cy)}, {b.x, a.y + float(cy)}, planeColour(plane.v));
    if ((tools_.tool == Tool::Paint || tools_.tool == Tool::Erase) && p.rect.contains(mouseX_, mouseY_))
      dl->AddCircle({float(mouseX_), float(mouseY_)}, float(tools_.brushRadiusMm / plane.mmPerPixel),
                    tools_.tool == Tool::Paint ? IM_COL32(255, 255, 255, 220) : IM_COL32(255, 120, 120, 220), 32);
    dl->PopClipRect();
    dl->AddRect(a, b, planeColour(plane.normal));
    dl->AddText({a.x + 6, a.y + 4}, planeColour(plane.normal), sliceAxisName(*p.slice));
  }
}

void StudioApp::drawPlanesIn3d(const Pane& pane) {
  // The three slice planes as outlines of their cut through the volume's bounding box, drawn
  // over the rendering (not depth-tested) in the slice colours.
  const Geometry& g = scene_.ct.geometry();
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (int c = 0; c < 8; ++c) {
    const Vec3 p = g.indexToPhysical({(c & 1) ? g.dims.x - 0.5 : -0.5, (c & 2) ? g.dims.y - 0.5 : -0.5,
                                      (c & 4) ? g.dims.z - 0.5 : -0.5});
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
  }
  ImDrawList* dl = ImGui::GetBackgroundDrawList();
  dl->PushClipRect({pane.rect.x, pane.rect.y}, {pane.rect.x + pane.rect.w, pane.rect.y + pane.rect.h}, true);
  for (int axis = 0; axis < 3; ++axis) {  // plane normal along x (sagittal), y (coronal), z (axial)
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    std::vector<ImVec2> pts;
    for (int k = 0; k < 4; ++k) {
      Vec3 p = scene_.crosshairMm;
      p[u] = (k == 1 || k == 2) ? hi[u] : lo[u];
      p[v] = (k >= 2) ? hi[v] : lo[v];
      const auto px = projectToView(scene_, int(pane.rect.w), int(pane.rect.h), p);
      if (!px) break;
      pts.push_back({pane.rect.x + float(px->first), pane.rect.y + float(px->second)});
    }
    Vec3 normal;
    normal[axis] = 1;
    if (pts.size() == 4) dl->AddPolyline(pts.data(), 4, planeColour(normal), ImDrawFlags_Closed, 1.f);
  }
  dl->PopClipRect();
}

void StudioApp::drawHud() {
  std::ostringstream hud;
  hud.setf(std::ios::fixed);
  hud.precision(1);
  hud << "frame " << lastFrameMs_ << " ms   3D " << view3d_->lastRenderMs() << " ms @1/" << view3d_->lastScale();
  if (scene_.hasVolume()) {
    const Pane* p = paneAt(mouseX_, mouseY_);
    if (p && !p->is3d()) {
      const SlicePlane plane = makePlane(*p->slice, scene_.ct.geometry(), scene_.crosshairMm, int(p->rect.w), int(p->rect.h));
      const Vec3 mm = plane.toMm(mouseX_ - p->rect.x, mouseY_ - p->rect.y);
      const Vec3 ijk = scene_.ct.geometry().physicalToIndex(mm);
      const auto i = std::lround(ijk.x), j = std::lround(ijk.y), k = std::lround(ijk.z);
      hud << "\n(" << mm.x << ", " << mm.y << ", " << mm.z << ") mm  [" << i << ' ' << j << ' ' << k << "]  ";
      if (scene_.ct.geometry().contains(i, j, k)) {
        hud << "HU " << scene_.ct(i, j, k) << "  label " << scene_.labels(i, j, k);
        if (auto l = scene_.labels.label(scene_.labels(i, j, k))) hud << " " << l->name;
      } else {
        hud << "outside";
      }
    }
  }
  if (panes_.empty()) return;
  const float x = panes_.front().rect.x + 8, y = float(options_.height) - 44;
  ImGui::GetForegroundDrawList()->AddRectFilled({x - 4, y - 2}, {x + 520, y + 36}, IM_COL32(0, 0, 0, 150));
  ImGui::GetForegroundDrawList()->AddText({x, y}, IM_COL32(255, 255, 160, 255), hud.str().c_str());
}

// ---- screenshots -------------------------------------------------------------------------

void StudioApp::requestWindowScreenshot(const fs::path& path) { pendingScreenshot_ = path; }

void StudioApp::captureWindow() {
  const fs::path path = std::exchange(pendingScreenshot_, {});
  int w = 0, h = 0;
  glfwGetFramebufferSize(window_, &w, &h);
  RgbaImage img(w, h);
  std::vector<uint8_t> rows(img.pixels.size());
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadBuffer(GL_BACK);
  glReadPixels(0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, rows.data());
  const size_t stride = static_cast<size_t>(w) * 4;
  for (int y = 0; y < h; ++y)  // GL rows are bottom-up
    std::copy_n(rows.data() + static_cast<size_t>(h - 1 - y) * stride, stride, img.pixels.data() + y * stride);
  for (size_t n = 3; n < img.pixels.size(); n += 4) img.pixels[n] = 255;
  try {
    io::saveImage(img, path);
    screenshotError_.reset();
  } catch (const std::exception& e) {
    screenshotError_ = e.what();
  }
}

std::optional<std::string> StudioApp::takeScreenshotError() { return std::exchange(screenshotError_, std::nullopt); }

std::pair<int, int> StudioApp::pane3dSize() const {
  for (const Pane& p : panes_)
    if (p.is3d()) return {int(p.rect.w), int(p.rect.h)};
  return {512, 512};
}

std::string StudioApp::cliCommand(const std::string& out) const {
  const auto [w, h] = pane3dSize();
  return cliRenderCommand(scene_, w, h, out);
}

void StudioApp::save3dScreenshot(const fs::path& path, int width, int height) {
  if (!scene_.hasVolume()) throw Error("no volume is open");
  if (width <= 0 || height <= 0) std::tie(width, height) = pane3dSize();
  if (width > 4096 || height > 4096) throw Error("3D screenshots are limited to 4096x4096");
  io::saveImage(view3d_->renderImage(scene_, width, height), path);
}

// ---- commands ----------------------------------------------------------------------------

void StudioApp::setLayout(Layout l) {
  scene_.layout = l;
  view3d_->invalidate();
  markSlicesDirty();
}

void StudioApp::setPreset(render::Preset p) { scene_.preset = p; }

void StudioApp::resetView() {
  scene_.resetView();
  markSlicesDirty();
}

void StudioApp::pushEdit(LabelDelta delta) {
  if (delta.empty()) return;
  undo_.push(std::move(delta));
  scene_.labelsModified = true;
  markSlicesDirty();
}

bool StudioApp::undo() {
  const bool done = undo_.undo(scene_.labels);
  if (done) scene_.labelsModified = true, markSlicesDirty();
  return done;
}

bool StudioApp::redo() {
  const bool done = undo_.redo(scene_.labels);
  if (done) scene_.labelsModified = true, markSlicesDirty();
  return done;
}


void StudioApp::applyThreshold() {
  if (!scene_.hasVolume()) throw Error("no volume is open");
  const auto& t = tools_.threshold;
  std::ostringstream name;
  name << "Threshold " << t.lower << ".." << t.upper;
  const Label label = labelFor(scene_.labels, tools_.activeLabel, name.str());
  pushEdit(recordEdit(scene_.labels, "threshold", [&](LabelVolume& l) { thresholdInto(l, scene_.ct, t, label); }));
}

void StudioApp::keepLargestOfActive() {
  if (!scene_.hasVolume()) throw Error("no volume is open");
  pushEdit(recordEdit(scene_.labels, "keep largest", [&](LabelVolume& l) { keepLargest(l, tools_.activeLabel); }));
}

void StudioApp::fillHolesOfActive() {
  if (!scene_.hasVolume()) throw Error("no volume is open");
  pushEdit(recordEdit(scene_.labels, "fill holes", [&](LabelVolume& l) { fillHoles(l, tools_.activeLabel); }));
}

void StudioApp::morphologyOfActive(Morphology op) {
  if (!scene_.hasVolume()) throw Error("no volume is open");
  pushEdit(recordEdit(scene_.labels, morphologyName(op), [&](LabelVolume& l) {
    morphology(l, tools_.activeLabel, op, tools_.brushRadiusMm);
  }));
}

void StudioApp::otsuThreshold() {
  if (!scene_.hasVolume()) throw Error("no volume is open");
  tools_.threshold = {otsuHu(scene_.ct), 3071};
}

void StudioApp::saveLabels(const fs::path& path) {
  if (!scene_.hasVolume()) throw Error("no volume is open");
  io::saveLabels(scene_.labels, path);
  scene_.labelsPath = path;
  scene_.labelsModified = false;
}

void StudioApp::saveScene(const fs::path& path) {
  if (!scene_.hasVolume()) throw Error("no volume is open");
  const bool hasLabels = !scene_.labels.table().empty() || scene_.labelsModified;
  if (hasLabels && (scene_.labelsPath.empty() || scene_.labelsModified))
    saveLabels(path.parent_path() / (path.stem().string() + ".labels.nrrd"));
  writeSceneFile(describeScene(scene_), path);
  scene_.scenePath = path;
}

void StudioApp::quit(int code) {
  exitCode_ = code;
  quitRequested_ = true;
}

// ---- input -------------------------------------------------------------------------------

void StudioApp::injectCursorPos(double x, double y) { cursorPosCallback(window_, x, y); }
void StudioApp::injectMouseButton(int button, int action, int mods) {
  if (button >= 0 && button < 3) virtualDown_[static_cast<size_t>(button)] = action == GLFW_PRESS;
  mouseButtonCallback(window_, button, action, mods);
}
void StudioApp::injectScroll(double dx, double dy) { scrollCallback(window_, dx, dy); }
void StudioApp::injectKey(int key, int action, int mods) { keyCallback(window_, key, 0, action, mods); }

bool StudioApp::interacting3d() const {
  return (dragPane_ && dragPane_->is3d()) || glfwGetTime() < zoomInteractionUntil_;
}

const Pane* StudioApp::paneAt(double x, double y) const {
  for (const Pane& p : panes_)
    if (p.rect.contains(x, y)) return &p;
  return nullptr;
}

void StudioApp::paintAt(const Pane& pane, double x, double y) {
  const SlicePlane plane = makePlane(*pane.slice, scene_.ct.geometry(), scene_.crosshairMm, int(pane.rect.w), int(pane.rect.h));
  const uint16_t id = tools_.tool == Tool::Paint ? tools_.activeLabel : 0;
  if (paintSphere(scene_.labels, plane.toMm(x - pane.rect.x, y - pane.rect.y), tools_.brushRadiusMm, id) > 0)
    markSlicesDirty();
}

void StudioApp::growAt(const Pane& pane, double x, double y) {
  const SlicePlane plane = makePlane(*pane.slice, scene_.ct.geometry(), scene_.crosshairMm, int(pane.rect.w), int(pane.rect.h));
  const Vec3 seed = plane.toMm(x - pane.rect.x, y - pane.rect.y);
  const Label label = labelFor(scene_.labels, tools_.activeLabel, "Region " + std::to_string(tools_.activeLabel));
  try {
    pushEdit(recordEdit(scene_.labels, "grow", [&](LabelVolume& l) { growFromSeed(l, scene_.ct, seed, tools_.threshold, label); }));
  } catch (const std::exception& e) {
    showError(e.what());  // e.g. a seed outside the volume
  }
}

void StudioApp::onCursorPos(double x, double y) {
  const double dx = x - mouseX_, dy = y - mouseY_;
  mouseX_ = x;
  mouseY_ = y;
  if (!dragPane_ || !scene_.hasVolume()) return;
  const Pane& pane = *dragPane_;
  const bool shift = dragMods_ & GLFW_MOD_SHIFT;
  if (!pane.is3d()) {
    if (dragButton_ == GLFW_MOUSE_BUTTON_LEFT) {
      if (tools_.tool == Tool::Grow) {
        // The seed click grows once (on press); dragging does nothing more.
      } else if (tools_.tool == Tool::Navigate) {
        const SlicePlane plane = makePlane(*pane.slice, scene_.ct.geometry(), scene_.crosshairMm, int(pane.rect.w), int(pane.rect.h));
        scene_.crosshairMm = plane.toMm(x - pane.rect.x, y - pane.rect.y);
        markSlicesDirty();
      } else {
        paintAt(pane, x, y);
      }
    } else if (dragButton_ == GLFW_MOUSE_BUTTON_RIGHT) {  // window/level: right widens, down raises the level
      scene_.sliceWindow.width = std::max(1.0, scene_.sliceWindow.width + dx * 4);
      scene_.sliceWindow.center += dy * 2;
    }
    return;
  }
  render::Camera& cam = scene_.camera;
  if ((dragButton_ == GLFW_MOUSE_BUTTON_LEFT && shift) || dragButton_ == GLFW_MOUSE_BUTTON_MIDDLE) {
    // Pan: the look-at point moves against the drag so the volume follows the mouse.
    const double az = cam.azimuthDeg * M_PI / 180, el = cam.elevationDeg * M_PI / 180;
    const Vec3 right{std::cos(az), std::sin(az), 0};
    const Vec3 forward = -Vec3{std::cos(el) * std::sin(az), -std::cos(el) * std::cos(az), std::sin(el)};
    const Vec3 up = cross(right, forward);
    const Vec3 e = scene_.ct.geometry().extent();
    const double mmPerPixel = norm(e) / (cam.zoom * std::max(1.f, pane.rect.h));
    cam.panMm -= right * (dx * mmPerPixel);
    cam.panMm += up * (dy * mmPerPixel);
  } else if (dragButton_ == GLFW_MOUSE_BUTTON_LEFT) {  // orbit (trackball-style)
    cam.azimuthDeg -= dx * 0.5;
    cam.elevationDeg = std::clamp(cam.elevationDeg + dy * 0.5, -89.0, 89.0);
  } else if (dragButton_ == GLFW_MOUSE_BUTTON_RIGHT) {
    scene_.renderWindow.width = std::max(10.0, scene_.renderWindow.width + dx * 8);
    scene_.renderWindow.center += dy * 4;
  }
}

void StudioApp::onMouseButton(int button, int action, int mods) {
  if (action == GLFW_RELEASE) {
    if (strokeBefore_) {
      pushEdit(diffLabels(*strokeBefore_, scene_.labels, tools_.tool == Tool::Paint ? "paint" : "erase"));
      strokeBefore_.reset();
    }
    if (button == dragButton_) dragPane_.reset(), dragButton_ = -1;
    return;
  }
  if (ImGui::GetIO().WantCaptureMouse || !scene_.hasVolume()) return;
  const Pane* pane = paneAt(mouseX_, mouseY_);
  if (!pane) return;
  dragPane_ = *pane;
  dragButton_ = button;
  dragMods_ = mods;
  if (!pane->is3d() && button == GLFW_MOUSE_BUTTON_LEFT) {
    if (tools_.tool == Tool::Grow) {
      growAt(*pane, mouseX_, mouseY_);
      return;
    }
    if (tools_.tool != Tool::Navigate) strokeBefore_ = scene_.labels;  // diffed on release
    onCursorPos(mouseX_, mouseY_);  // a click acts where it lands
  }
}

void StudioApp::onScroll(double, double dy) {
  if (ImGui::GetIO().WantCaptureMouse || !scene_.hasVolume()) return;
  const Pane* pane = paneAt(mouseX_, mouseY_);
  if (!pane) return;
  if (pane->is3d()) {
    scene_.camera.zoom = std::clamp(scene_.camera.zoom * std::pow(1.1, dy), 0.1, 50.0);
    zoomInteractionUntil_ = glfwGetTime() + 0.3;
  } else {  // one voxel through the slices per notch
    const SlicePlane plane = makePlane(*pane->slice, scene_.ct.geometry(), scene_.crosshairMm, 1, 1);
    const Vec3& sp = scene_.ct.geometry().spacing;
    scene_.crosshairMm += plane.normal * (dy * std::min({sp.x, sp.y, sp.z}));
    markSlicesDirty();
  }
}

void StudioApp::onKey(int key, int action, int mods) {
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
      if (scene_.scenePath.empty())
        browser_.open(FileBrowser::Mode::Save, "Save scene as", [this](const fs::path& p) { saveScene(p); });
      else
        saveScene(scene_.scenePath);
    } else if (!ctrl && key == GLFW_KEY_R) {
      resetView();
    } else if (!ctrl && key >= GLFW_KEY_1 && key <= GLFW_KEY_3) {
      setLayout(key == GLFW_KEY_1 ? Layout::ThreeD : key == GLFW_KEY_2 ? Layout::TwoByTwo : Layout::OneByThree);
    } else if (key == GLFW_KEY_ESCAPE) {
      tools_.tool = Tool::Navigate;
    }
  } catch (const std::exception& e) {
    showError(e.what());
  }
}

void StudioApp::onDrop(const std::vector<std::string>& paths) {
  if (!paths.empty()) requestOpen(paths.front());
}

}  // namespace vellum::studio
