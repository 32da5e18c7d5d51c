#pragma once
// StudioApp: the window, the frame loop and the input handlers. Real GLFW events and script
// actions enter through the same on*() handlers; panels and scripts change the scene through
// the same commands.
#include <array>
#include <atomic>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "curve_controller.hpp"
#include "deform_controller.hpp"
#include "file_browser.hpp"
#include "label_tools.hpp"
#include "layout.hpp"
#include "loader.hpp"
#include "mpr.hpp"
#include "point_controller.hpp"
#include "recent_files.hpp"
#include "curve_tool.hpp"
#include "shape_job.hpp"
#include "vellum/app/segment_pipeline.hpp"
#include "snake_job.hpp"
#include "task_queue.hpp"
#include "scene.hpp"
#include "segmentation_controller.hpp"
#include "undo.hpp"
#include "vellum/segmentation/threshold.hpp"

struct GLFWwindow;

namespace vellum::studio {

class View3D;
class WindowContext;
class ScriptRunner;
class Autosaver;
class GlTexture;
struct StudioTools;

struct StudioOptions {
  std::string input;   ///< volume, DICOM folder or scene to open at start
  std::string labels;  ///< label map to open with the volume
  std::string script;  ///< script file (scripted mode)
  int width = 1280, height = 800;
  bool logFrames = false;  ///< one line per frame on stdout (frame and 3D render times)
  /// Autosave interval in seconds; 0 disables. Default: 60 interactive, off for scripts.
  double autosaveSeconds = -1;
};

class StudioApp {
 public:
  explicit StudioApp(StudioOptions options);
  ~StudioApp();
  /// Runs until the window closes or a script quits; returns the exit code.
  int run();
  /// Async-signal-safe: asks the running loop to end (SIGINT/SIGTERM); run() returns 130.
  static void interrupt() noexcept;

  // Input handlers: GLFW callbacks and script actions (window pixel coordinates).
  void onCursorPos(double x, double y);
  void onMouseButton(int button, int action, int mods);
  void onScroll(double dx, double dy);
  void onKey(int key, int action, int mods);
  void onDrop(const std::vector<std::string>& paths);
  /// Feeds an event through the GLFW callback chain (ImGui first, then the app), exactly as
  /// the window system would: what scripts use.
  void injectCursorPos(double x, double y);
  void injectMouseButton(int button, int action, int mods);
  void injectScroll(double dx, double dy);
  void injectKey(int key, int action, int mods);

  // Commands (panels, keys and scripts).
  void requestOpen(const std::filesystem::path& path, const std::filesystem::path& labels = {},
                   const std::string& seriesUid = {});
  void setLayout(Layout l);
  void setPreset(render::Preset p);
  /// Sets one view parameter by its table key (viewSettingsTable or renderSettingsTable: the
  /// `vellum render` flag without "--"), as the View panel does; one undo step. Throws
  /// vellum::Error for an unknown key or a bad value.
  void setViewParameter(const std::string& key, const std::string& value);
  /// A View-panel edit: begin with the state before it, end records one undo step.
  void beginViewEdit(const ViewState& before);
  void endViewEdit(const std::string& description);
  /// Camera bookmarks (each one undo step): add the current camera, go to one, delete one.
  void addBookmark(const std::string& name);
  /// Illustration view: shapes made from the label map or read from a `vellum shape` folder
  /// (a worker job; the result replaces the scene's shapes), on/off, the style (each one undo
  /// step). `segment` in setStyleField is a label name, or "default" / "unclassified" / "" (the
  /// style's top-level fields).
  void makeShapes(const std::filesystem::path& folder = {});
  void setIllustration(bool on);
  void setStylePreset(const std::string& name);
  void setStyleField(const std::string& segment, const std::string& key, const std::string& value);
  ShapeJob& shapeJob() { return shapes_; }
  /// Curve analogy by drawing (Illustration panel): curve_controller.hpp.
  CurveController& curves() { return curves_; }
  void goToBookmark(size_t index);
  void deleteBookmark(size_t index);
  void resetView();
  /// A slice view's zoom and pan (Ctrl+wheel or Ctrl+right-drag zooms about the pointer,
  /// middle-drag pans, F fits the view under the pointer again; R resets every view).
  const SliceNavigation& sliceNavigation(SliceAxis axis) const { return sliceNav_[static_cast<size_t>(axis)]; }
  void fitSliceView(SliceAxis axis);
  /// The plane a slice pane shows: makePlane's fit, zoomed and panned.
  SlicePlane planeOf(const Pane& pane) const;
  /// Sets the slice window to a windowPresets() entry by name (one undo step).
  void setWindowPreset(const std::string& name);
  /// Undoes / redoes the last edit (queued behind running label edits; not during a drag).
  bool undo() { return undoStep(false); }
  bool redo() { return undoStep(true); }
  // Deformation authoring: the control points, track and engine edits (point_controller.hpp);
  // the deformation session, rigid bones, joint tool, playback and the movie export
  // (deform_controller.hpp).
  PointController& points() { return points_; }
  DeformController& deform() { return deform_; }
  /// Where the timeline drew each keyframe's block in the last frame (window pixels: x, y,
  /// width, height); its rightmost kKeyframeHandlePx are the duration handle.
  static constexpr float kKeyframeHandlePx = 6;
  std::vector<std::array<float, 4>>& keyframeBlocks() { return keyframeBlocks_; }
  /// The window's size in screen pixels (what scripted coordinates refer to).
  std::pair<int, int> windowSize() const;
  /// The `vellum render` command for the 3D view at its pane size (512² without a 3D pane).
  std::string cliCommand(const std::string& out) const;
  /// Saves the scene (and the label map next to it when it has no file or was edited). The
  /// label map is written by a task (after the queued edits); `then` runs once all is written.
  void saveScene(const std::filesystem::path& path, std::function<void()> then = {});
  void saveLabels(const std::filesystem::path& path, std::function<void()> then = {});
  /// Window screenshot after the next completed frame, or a 3D render (size 0 = pane size).
  void requestWindowScreenshot(const std::filesystem::path& path);
  void save3dScreenshot(const std::filesystem::path& path, int width = 0, int height = 0);
  /// Writes the slice image last drawn in `axis`'s pane (the texture's pixels, without the
  /// crosshair, dots and text drawn over it). Throws when that slice is not shown.
  void saveSliceScreenshot(const std::filesystem::path& path, SliceAxis axis) const;
  /// The backward map the slice views are drawn through, or nullptr (no deformation shown, or
  /// View > Deformed slices off).
  const deformation::MapSampler* sliceMap() const;
  /// Where a position picked in a slice view lies in the undeformed volume (what label edits
  /// change): through sliceMap() when the slices are deformed; nullopt where the deformed
  /// volume is background.
  std::optional<Vec3> sliceSourceMm(const Vec3& mm) const;
  /// Time of the last slice re-render (all slice panes), ms.
  double lastSlicesMs() const { return lastSlicesMs_; }
  void quit(int code);
  void showError(const std::string& message);

  // Modal dialogs (app_dialogs.cpp), answered by their buttons or by a script's "dialog".
  /// The title of the modal dialog that is open ("" when none): the error box, the autosave
  /// recovery, the unsaved-changes question or the file browser.
  std::string openDialog() const;
  bool errorBoxOpen() const { return errorOpen_; }
  /// Answers the open dialog as its button named `answer` (lower case) does: "ok" (error);
  /// "recover", "discard", "later" (recovery); "save", "discard", "cancel" (unsaved
  /// changes); "cancel" (file browser). Throws vellum::Error for no dialog or another answer.
  void answerDialog(const std::string& answer);
  /// Answers the file browser with `path`, as typing it and pressing Open/Save does.
  void answerFileBrowser(const std::filesystem::path& path);
  /// Asks the window to close, as its close button does (Ctrl+Q, File > Quit, the script's
  /// "close"): the frame loop quits, or asks Save / Discard / Cancel when unsaved changes.
  void requestClose();
  /// Edits since the scene was opened or saved (undo steps, label edits, a recovered autosave);
  /// mouse navigation is none, as for undo.
  bool unsavedChanges() const;
  /// Saves to the scene's file, or asks for one (the Save As browser) when it has none; `then`
  /// runs after a successful save. Errors go to the error box.
  void saveSceneOrAsk(std::function<void()> then = {});

  /// The 3D view draws again (the camera changed outside a view edit: tracing's plate view).
  void invalidate3d();
  void markSlicesDirty() { slicesDirty_ = true; }

  // State for panels and scripts.
  Scene& scene() { return scene_; }
  /// The segmentation tools and their label edits (segmentation_controller.hpp).
  SegmentationController& segmentation() { return segmentation_; }
  Loader& loader() { return loader_; }
  /// The queued edits (label operations, label and scene files) and the task running.
  TaskQueue& tasks() { return tasks_; }
  /// True while tasks read the label map and CT on a worker: edits then queue behind them
  /// (panel buttons, undo) or are refused with a notice (brush strokes, label table edits).
  bool labelsFrozen() const { return tasks_.busy(); }
  /// Runs `read` on the task queue's worker after the queued edits, where the scene's labels
  /// do not change (labelsFrozen): what copies the label map for a worker (rigid bodies,
  /// autosave) instead of copying it on the UI thread (0.1-0.3 s at 512^2 x 350). `name` is
  /// shown while it runs. False (nothing queued) while a brush stroke writes the labels.
  bool readSceneOnWorker(const std::string& name, std::function<void(const Scene&)> read);
  /// The autosave holds the session as it is now, or has nothing to keep (scripts wait on it).
  bool autosaveSettled();
  /// The last task's error or "<task> cancelled" ("" until one failed); scripts check it.
  const std::string& lastTaskError() const { return lastTaskError_; }
  void clearTaskError() { lastTaskError_.clear(); }
  /// A one-line message shown for a few seconds over the views (and on stderr): what was
  /// refused and why. Not modal.
  void notify(const std::string& message);
  const std::string& notice() const { return notice_; }
  /// Scripts (tests): queues a task that holds the worker until released, a stand-in for an
  /// edit that takes long on a real scan, so what happens meanwhile can be tested.
  void holdTasks(bool on);
  /// What runs on workers now, one line each ("remove islands 40%"), for the status line.
  std::vector<std::string> runningWork() const;
  UndoStack& undoStack() { return undo_; }
  FileBrowser& fileBrowser() { return browser_; }
  bool loading() const { return loader_.pending() || pendingLoad_.has_value(); }
  /// Nothing pending: no load or snake running, 3D view refined, no screenshot waiting.
  bool idle() const;
  /// What keeps idle() false, comma-separated ("" when idle): a script's timeout names it.
  std::string pendingWork() const;
  /// The last load's error ("" after success); scripts check it.
  const std::string& lastLoadError() const { return lastLoadError_; }
  bool hudVisible = true;
  const std::vector<Pane>& panes() const { return panes_; }
  std::optional<std::string> takeScreenshotError();
  bool screenshotPending() const { return !pendingScreenshot_.empty(); }
  double lastFrameMs() const { return lastFrameMs_; }
  const View3D* view3d() const { return view3d_.get(); }
  /// Files opened successfully, most recent first (at most 8; kept across interactive sessions).
  const std::vector<std::filesystem::path>& recentFiles() const { return recent_.paths(); }
  /// Ruler and angle, Export figure (studio_tools.hpp).
  StudioTools& studioTools() { return *studioTools_; }

 private:
  void createWindow();
  void frame();
  /// What a frame did, for the frame log.
  struct FrameViews {
    bool mapUpdated = false, rendered3d = false;
    /// Wall ms of the frame's parts (poll, ui, views, panes, present) and the UI thread's CPU
    /// ms in the frame: a long frame with little CPU waited (starved or blocked).
    double pollMs = 0, uiMs = 0, viewsMs = 0, panesMs = 0, presentMs = 0, cpuMs = 0;
  };
  void pollWorkers();
  void beginUiFrame();
  FrameViews updateViews();
  void presentFrame();
  void logFrame(const FrameViews& v);
  void pollLoader();
  void adoptLoad(LoadResult r);
  void updateSliceTextures();
  void drawPanes();
  void drawHud();
  void captureWindow();
  const Pane* paneAt(double x, double y) const;
  void pollTasks();
  void drawStatus();
  /// Ctrl+click in the 3D view: the crosshair (Navigate) or a seed (Grow, Snake) on the
  /// visible surface under the pointer.
  void clickIn3d(const Pane& pane, double x, double y);
  std::pair<int, int> pane3dSize() const;
  void drawPlanesIn3d(const Pane& pane);
  PointController points_{*this};
  double lastTickS_ = 0;
  std::unique_ptr<StudioTools> studioTools_;
  std::vector<std::array<float, 4>> keyframeBlocks_;

  StudioOptions options_;
  GLFWwindow* window_ = nullptr;
  std::unique_ptr<WindowContext> context_;
  std::unique_ptr<View3D> view3d_;
  std::unique_ptr<ScriptRunner> script_;
  std::unique_ptr<Autosaver> autosaver_;
  std::array<std::unique_ptr<GlTexture>, 3> sliceTextures_;
  std::array<RgbaImage, 3> sliceImages_;  ///< what the textures hold (screenshots of a slice)
  std::array<int, 3> sliceScale_{1, 1, 1};  ///< pane pixels per texture pixel (2 during point drags)
  double lastSlicesMs_ = 0;
  bool slicesRendered_ = false;  ///< in this frame (--log-frames)
  Scene scene_;
  SegmentationController segmentation_{*this};  ///< before tasks_: its queued edits refer to it
  UndoStack undo_;
  /// After scene_ (its workers read the CT) and undo_ (its edits are undo steps).
  DeformController deform_{*this};
  bool undoStep(bool forward);
  std::optional<ViewState> viewEditBefore_;
  void pushViewEdit(const std::string& description, const ViewState& before);
  void viewChanged();  ///< layout, preset ... changed: redraw slices and the 3D view
  Loader loader_;
  /// A finished load waiting for the workers that read the current volume to stop.
  std::optional<LoadResult> pendingLoad_;
  /// The adopted volume's 3D textures still being uploaded, a slab per frame.
  /// The 3D view's upload of scene_.ct, which stays as it is until the upload is done (no
  /// load is adopted meanwhile: the worker reads it).
  struct Upload3d {
    std::shared_ptr<const render::VolumeRenderer::Prepared> prepared;
    int adopted = 0;  ///< frames since the load was adopted
  };
  std::optional<Upload3d> upload3d_;
  static constexpr size_t kUploadBytesPerFrame = size_t{32} << 20;  ///< ~50 ms on llvmpipe
  /// The deformation map's slab per frame (updateViews), halved above the budget, doubled
  /// well under it, between 2 MB and kUploadBytesPerFrame.
  size_t mapUploadBytes_ = size_t{8} << 20;
  static constexpr size_t kMinMapUploadBytes = size_t{2} << 20;
  static constexpr double kMapUploadBudgetMs = 40;
  TaskQueue tasks_;
  std::shared_ptr<std::atomic<bool>> holding_ = std::make_shared<std::atomic<bool>>(false);
  std::string lastTaskError_, notice_;
  double noticeUntil_ = 0;
  ShapeJob shapes_;
  void pollShapes();
  CurveController curves_{*this};
  FileBrowser browser_;
  std::vector<Pane> panes_;
  RecentFiles recent_;
  bool slicesDirty_ = true;
  std::array<std::string, 3> paneSliceKeys_;  ///< per slice axis: what its texture shows
  int sliceDragReduce_ = 2;                   ///< deformed slices' reduction during point drags
  static constexpr double kSliceDragBudgetMs = 60;
  std::string lastLoadError_;
  std::string errorMessage_;
  bool errorOpen_ = false;
  // Dialogs (app_dialogs.cpp). One of the two questions at a time; the error box goes first.
  enum class Dialog { None, Recovery, Unsaved };
  Dialog dialog_ = Dialog::None;
  std::filesystem::path recoveryPath_;  ///< the autosave the Recovery dialog offers
  /// A Recover in progress: the autosave being opened and the scene file it stands for.
  struct Recovering {
    std::filesystem::path autosave, scenePath;
  };
  std::optional<Recovering> recovering_;
  /// undo_.changes() when the scene was last opened or saved (kNeverSaved: a recovered autosave).
  uint64_t savedChanges_ = 0;
  static constexpr uint64_t kNeverSaved = ~uint64_t{0};
  void drawDialogs();
  /// The window's close flag is up: quit, or ask about unsaved changes (and keep the window).
  void onWindowClose();
  /// After a successful load: a recovered autosave becomes the unsaved session, any other
  /// scene is offered its newer autosave.
  void afterLoad(const LoadResult& r);

  std::array<SliceNavigation, 3> sliceNav_;
  bool ctrlDown_ = false;  ///< from key events (scroll events carry no modifiers)

  // Mouse state (window pixels).
  double mouseX_ = 0, mouseY_ = 0, pressX_ = 0, pressY_ = 0;
  int dragButton_ = -1, dragMods_ = 0;
  std::optional<Pane> dragPane_;  ///< a copy: panes_ is rebuilt every frame
  std::array<bool, 3> virtualDown_{false, false, false};

  std::filesystem::path pendingScreenshot_;
  std::optional<std::string> screenshotError_;
  bool quitRequested_ = false;
  int exitCode_ = 0;
  double lastFrameMs_ = 0;
  long frameNumber_ = 0;
  /// Wheel zoom counts as interaction for a moment, so a burst of notches renders coarse.
  double zoomInteractionUntil_ = 0;
  bool interacting3d() const;
};

/// Runs a panel's command, turning its error into the error box (a panel never crashes the app).
inline void guarded(StudioApp& app, const std::function<void()>& fn) {
  try {
    fn();
  } catch (const std::exception& e) {
    app.showError(e.what());
  }
}

}  // namespace vellum::studio
