// StudioApp: the window, ImGui set-up, the frame loop and adopting finished loads.
#include "app.hpp"
#include "joint_tool.hpp"
#include "studio_tools.hpp"

#include <GL/glcorearb.h>
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <imgui.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <ctime>
#include <cstdio>
#include <iostream>
#include <sstream>
#include <tuple>

#include "autosave.hpp"
#include "deform_session.hpp"
#include "gl_texture.hpp"
#include "panels.hpp"
#include "script.hpp"
#include "view3d.hpp"
#include "vellum/core/error.hpp"
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

constexpr float kPanelWidth = kToolPanelWidth;

volatile std::sig_atomic_t gInterrupted = 0;

}  // namespace


StudioApp::StudioApp(StudioOptions options)
    : studioTools_(std::make_unique<StudioTools>()), options_(std::move(options)) {
  deform_.session().setSceneReader([this](const std::string& name, std::function<void(const Scene&)> read) {
    return readSceneOnWorker(name, std::move(read));
  });
}

StudioApp::~StudioApp() {
  if (!window_) return;
  deform_.cancelExport();  // GL objects: before the context goes
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

void StudioApp::interrupt() noexcept { gInterrupted = 1; }

int StudioApp::run() {
  if (!options_.script.empty()) script_ = ScriptRunner::load(options_.script);  // before the window
  else recent_ = RecentFiles(RecentFiles::defaultStorage());  // scripts leave the user's list alone
  createWindow();
  autosaver_ = std::make_unique<Autosaver>(options_.autosaveSeconds >= 0 ? options_.autosaveSeconds
                                           : script_                     ? 0.0
                                                                         : 60.0);
  autosaver_->setSceneReader([this](const std::string& name, std::function<void(const Scene&)> read) {
    return readSceneOnWorker(name, std::move(read));
  });
  if (!options_.input.empty()) {
    if (script_) script_->openFirst(options_.input, options_.labels);  // a failure fails the script
    else requestOpen(options_.input, options_.labels);
  }
  while (!quitRequested_) {
    if (glfwWindowShouldClose(window_)) onWindowClose();
    if (quitRequested_) break;
    if (gInterrupted) {
      exitCode_ = 130;
      break;
    }
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
  segmentation_.snake().cancel();
  shapes_.cancel();
  tasks_.cancel();
  tasks_.wait();  // it reads the scene, which goes with this object
  if (!unsavedChanges()) autosaver_->removeOwn();  // everything is saved: the autosave is stale
  autosaver_.reset();  // waits for a write in progress
  return exitCode_;
}

bool StudioApp::idle() const { return pendingWork().empty(); }

std::string StudioApp::pendingWork() const {
  const bool viewPending = scene_.hasVolume() &&
                           std::any_of(panes_.begin(), panes_.end(), [](const Pane& p) { return p.is3d(); }) &&
                           !view3d_->refined();
  const std::pair<bool, const char*> items[] = {
      {loader_.pending(), "load"}, {pendingLoad_.has_value(), "load result"}, {bool(upload3d_), "3D upload"},
      {view3d_->mapPending(), "3D map"}, {view3d_->lightPending(), "3D light"}, {tasks_.busy(), "task"},
      {segmentation_.snake().pending(), "snake"}, {shapes_.pending(), "shapes"}, {viewPending, "3D refinement"},
      {!pendingScreenshot_.empty(), "screenshot"}, {deform_.exporting(), "export"},
      {deform_.session().preview(), "deformation preview"}, {deform_.busy(), "deformation"},
      {curves_.busy(), "curve analogy"}, {scene_.authoring.playing, "playback"}};
  std::string out;
  for (const auto& [on, name] : items)
    if (on) out += (out.empty() ? "" : ", ") + std::string(name);
  return out;
}

namespace {
double threadCpuMs() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return 1e3 * double(t.tv_sec) + 1e-6 * double(t.tv_nsec);
}
}  // namespace

void StudioApp::frame() {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  const double cpu0 = threadCpuMs();
  auto lap = [last = t0]() mutable {
    const auto now = Clock::now();
    const double ms = std::chrono::duration<double, std::milli>(now - last).count();
    last = now;
    return ms;
  };
  glfwPollEvents();
  pollWorkers();
  const double pollMs = lap();
  beginUiFrame();
  const double uiMs = lap();
  slicesRendered_ = false;
  FrameViews views = scene_.hasVolume() ? updateViews() : FrameViews{};
  views.pollMs = pollMs;
  views.uiMs = uiMs;
  views.viewsMs = lap();
  drawPanes();
  if (hudVisible) drawHud();
  drawStatus();
  ImGui::Render();
  views.panesMs = lap();
  presentFrame();
  views.presentMs = lap();
  views.cpuMs = threadCpuMs() - cpu0;
  lastFrameMs_ = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  if (options_.logFrames) logFrame(views);
  ++frameNumber_;
}

void StudioApp::pollWorkers() {
  pollTasks();
  pollLoader();
  segmentation_.pollSnake();
  pollShapes();
  curves_.poll();
  deform_.poll();
  const double now = glfwGetTime();
  deform_.tick(lastTickS_ > 0 ? now - lastTickS_ : 0.0);
  deform_.followCamera();
  lastTickS_ = now;
  if (unsavedChanges()) autosaver_->tick(scene_, scene_.labelsRevision, glfwGetTime());  // nothing to keep otherwise
}

// ImGui's frame: the tool panel, the file browser, the error popup; the panes laid out.
void StudioApp::beginUiFrame() {
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
  panes_ = layoutPanes(scene_.view.layout, {kPanelWidth, 0, std::max(1.f, w - kPanelWidth), float(h)});
  keyframeBlocks_.clear();  // the timeline records them again if it is drawn
  drawToolPanel(*this, kPanelWidth, float(h));
  pollStudioTools(*this);
  drawFigureDialog(*this);
  browser_.draw();
  drawDialogs();
}

// The deformation map, the slice textures and the 3D view brought up to date.
StudioApp::FrameViews StudioApp::updateViews() {
  FrameViews v;
  // Not in the frame that adopted the load (it draws the new slices): from the next one on.
  if (upload3d_ && upload3d_->adopted++ > 0 &&
      view3d_->uploadVolumeStep(scene_.ct, upload3d_->prepared, kUploadBytesPerFrame))
    upload3d_.reset();
  // The light source when lighting is on (made on a worker from scene_.ct, the drawn volume's
  // once its upload is done; a load waits for it in pollLoader).
  if (!upload3d_) view3d_->stepLight(scene_);
  const DeformSession& session = deform_.session();
  v.mapUpdated = deform_.updateMap(points_.dragging() || scene_.authoring.playing, !interacting3d());
  if (v.mapUpdated) view3d_->setBackwardMap(session.sharedMap(), session.mapRevision());
  {
    // The map's CPU part is made on a worker; its textures are uploaded here in slabs sized
    // to the frame budget from the last slab's time: a fixed 32 MB slab of the rigid snap's
    // class volume took 100-170 ms of this thread at 512^2 x 150-350 (more under load).
    const auto t0 = std::chrono::steady_clock::now();
    view3d_->stepMap(mapUploadBytes_);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    if (ms > kMapUploadBudgetMs) mapUploadBytes_ = std::max(kMinMapUploadBytes, mapUploadBytes_ / 2);
    else if (ms > 1 && ms < kMapUploadBudgetMs / 4)  // a slab went up (not just a worker's wait)
      mapUploadBytes_ = std::min(kUploadBytesPerFrame, mapUploadBytes_ * 2);
  }
  updateSliceTextures();  // after the map: deformed slices show this frame's map
  view3d_->setShapes(scene_.shapes, scene_.shapesRevision);
  view3d_->setMeshes(scene_.shapeMeshes, scene_.hiddenLabels, scene_.shapesRevision);
  view3d_->setLabels(scene_.labels, scene_.hiddenLabels, scene_.labelsRevision,
                     scene_.render.labelBlend > 0 || scene_.render.onlyLabel > 0);
  // While the exact map is being solved the 3D view keeps its last frame instead of refining
  // a picture the map is about to replace: the solve gets both cores, and no refinement is
  // thrown away.
  const bool holdFor3d = session.exactSolveRunning() && !interacting3d();
  for (const Pane& p : panes_)
    if (p.is3d() && !holdFor3d)
      v.rendered3d = view3d_->update(scene_, int(p.rect.w), int(p.rect.h), interacting3d());
  return v;
}

void StudioApp::presentFrame() {
  int fbw = 0, fbh = 0;
  glfwGetFramebufferSize(window_, &fbw, &fbh);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glViewport(0, 0, fbw, fbh);
  glClearColor(0.08f, 0.08f, 0.09f, 1.f);
  glClear(GL_COLOR_BUFFER_BIT);
  ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
  if (!pendingScreenshot_.empty()) captureWindow();
  glfwSwapBuffers(window_);
}

// --log-frames: one line per frame (docs/studio.md; ui/studio/bench/frame_stats.py reads it).
void StudioApp::logFrame(const FrameViews& v) {
  const bool map = v.mapUpdated;
  const DeformSession& session = deform_.session();
  std::printf("frame %ld ms %.2f render3d %d render3d_ms %.2f scale %d interacting %d map_ms %.2f mls_ms %.2f rho_ms %.2f rigid_ms %.2f slices_ms %.2f deformed_slices %d step %d map_pending %d t_ms %.1f poll_ms %.1f ui_ms %.1f views_ms %.1f panes_ms %.1f present_ms %.1f cpu_ms %.1f\n",
              frameNumber_, lastFrameMs_, v.rendered3d ? 1 : 0, v.rendered3d ? view3d_->lastRenderMs() : 0.0,
              view3d_->lastScale(), dragPane_ ? 1 : 0, map ? session.lastUpdateMs() : 0.0,
              map ? session.timings()->mapMs : 0.0, map ? session.timings()->rhoCacheMs : 0.0,
              map ? session.lastRigidityMs() : 0.0, slicesRendered_ ? lastSlicesMs_ : 0.0, sliceMap() ? 1 : 0,
              view3d_->lastStepFactor(), view3d_->mapPending() ? 1 : 0, 1000 * glfwGetTime(), v.pollMs, v.uiMs,
              v.viewsMs, v.panesMs, v.presentMs, v.cpuMs);
  std::fflush(stdout);  // the log is read while the studio runs
}

// ---- loading ---------------------------------------------------------------------------

void StudioApp::requestOpen(const fs::path& path, const fs::path& labels, const std::string& seriesUid) {
  LoadRequest request{path, labels, seriesUid, true};
  if (!loader_.start(request)) showError("a file is still loading; cancel it first");
}

void StudioApp::pollLoader() {
  if (!pendingLoad_)
    if (auto r = loader_.take()) pendingLoad_ = std::move(*r);
  if (!pendingLoad_) return;
  // The current volume and labels are read by workers: the queued tasks finish first (a save
  // among them must not be lost), the deformation's solves are only caches and stop, and the
  // 3D view's upload of the CT finishes (it reads scene_.ct, not a copy).
  if (pendingLoad_->error.empty() && (tasks_.busy() || deform_.session().busy() || upload3d_ || view3d_->lightPending())) {
    deform_.session().cancel();
    return;
  }
  LoadResult r = std::move(*pendingLoad_);
  pendingLoad_.reset();
  adoptLoad(std::move(r));
}

void StudioApp::adoptLoad(LoadResult r) {
  lastLoadError_ = r.error;
  if (!r.error.empty()) {
    recovering_.reset();
    showError(r.error);  // the current scene stays as it was
    return;
  }
  scene_.ct = std::move(r.ct);
  ++scene_.volumeGeneration;
  scene_.labels = std::move(r.labels);
  scene_.volumePath = r.volumePath;
  scene_.labelsPath = r.labelsPath;
  scene_.scenePath = r.scenePath;
  scene_.labelsModified = false;
  scene_.series = std::move(r.series);
  scene_.seriesUid = r.seriesUid;
  scene_.authoring = Authoring{};
  scene_.authoring.rigidLabels = boneLikeLabels(scene_.labels);
  scene_.shapes = std::move(r.shapes);
  scene_.shapeMeshes = std::move(r.shapeMeshes);
  scene_.shapesPath = r.shapesPath;
  ++scene_.shapesRevision;
  if (r.scene) {
    applySceneView(*r.scene, scene_);
  } else {
    scene_.resetView();
  }
  undo_.clear();
  // A scene file describes the whole session: the joint tool takes its joints, or none.
  if (r.scene && (r.scene->pose || !deform_.joints().pose.joints.empty())) {
    try {
      deform_.restorePose(r.scene->pose ? r.scene->pose->pose : deformation::Pose{}, scene_.authoring.keyframe);
    } catch (const std::exception& e) {
      notify(std::string("joint tool: ") + e.what());  // e.g. a pose without its label map
    }
  }
  segmentation_.tools().activeLabel = std::max<uint16_t>(1, scene_.labels.table().empty() ? 1 : scene_.labels.table().front().id);
  // The 3D view's textures are uploaded a slab per frame from the next frame on (the slices
  // show the new volume at once).
  if (r.prepared) upload3d_ = Upload3d{r.prepared};
  else upload3d_.reset(), view3d_->setVolume(scene_.ct);
  markSlicesDirty();
  afterLoad(r);
  const fs::path& opened = scene_.scenePath.empty() ? scene_.volumePath : scene_.scenePath;
  recent_.add(opened);
  glfwSetWindowTitle(window_, ("Vellum Studio - " + opened.filename().string()).c_str());
  for (const auto& w : r.warnings) std::cerr << "vellum-studio: warning: " << w << "\n";
}

bool StudioApp::autosaveSettled() {
  return !autosaver_ || !unsavedChanges() || autosaver_->settled(scene_, scene_.labelsRevision);
}

void StudioApp::showError(const std::string& message) {
  std::cerr << "vellum-studio: " << message << "\n";
  errorMessage_ = message;
  errorOpen_ = true;
}

void StudioApp::injectCursorPos(double x, double y) { cursorPosCallback(window_, x, y); }
void StudioApp::injectMouseButton(int button, int action, int mods) {
  if (button >= 0 && button < 3) virtualDown_[static_cast<size_t>(button)] = action == GLFW_PRESS;
  mouseButtonCallback(window_, button, action, mods);
}
void StudioApp::injectScroll(double dx, double dy) { scrollCallback(window_, dx, dy); }
void StudioApp::injectKey(int key, int action, int mods) { keyCallback(window_, key, 0, action, mods); }

}  // namespace vellum::studio
