#pragma once
// The 3D pane: the shared VolumeRenderer drawing into the view's own framebuffers on the
// window's context (no read-back: ImGui shows a framebuffer's colour texture), the shape
// meshes first when they are on (render::MeshRenderer; rays stop at their depth).
// Progressive refinement: while the user drags, frames render at 1/2..1/8 of the pane's
// resolution (the factor adapts to keep a render near kInteractiveBudgetMs); when the view rests, the full-resolution picture is rendered a band of rows
// per frame (VolumeRenderer::renderIntoTile, each band sized to the same budget; a band whose
// single row is over budget is cut into column tiles) over the scaled-up coarse picture, so
// the window stays responsive throughout. With the cinematic quality (path traced, DVR presets,
// no meshes) the view at rest instead adds a batch of samples per frame (sized to the same
// budget) to the renderer's progressive picture and shows the running result, until the
// scene's sample count (or time limit); any change of the view starts it again. When one
// sample of the pane is over the budget (llvmpipe), each sample is drawn a band of rows per
// frame and the picture shown as each sample completes.
#include <functional>
#include <future>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "gl_texture.hpp"
#include "scene.hpp"
#include "vellum/deformation/synthesis.hpp"
#include "vellum/illustration/illustration_renderer.hpp"
#include "vellum/render/backward_map.hpp"
#include "vellum/render/mesh_renderer.hpp"
#include "vellum/render/render_target.hpp"
#include "vellum/render/volume_renderer.hpp"

namespace vellum::studio {

/// The renderer settings for `scene` at width x height: the same mapping as `vellum render`
/// flags (camera, preset, --window from renderWindow), so the studio and the CLI agree.
render::RenderSettings renderSettingsFor(const Scene& scene, int width, int height);

/// The orbit camera's unit vectors in LPS (the renderer's model: azimuth about +z from
/// anterior, elevation towards superior).
struct CameraBasis {
  Vec3 right, up, forward;
};
CameraBasis cameraBasis(const render::Camera& camera);

/// Window-pane pixel coordinates (x right, y down) of the physical point p in the 3D view of
/// `scene` at width x height, with the renderer's camera model; nullopt behind the camera.
std::optional<std::pair<double, double>> projectToView(const Scene& scene, int width, int height, const Vec3& p);

/// The first visible point along the ray through pane pixel (px, py) of the 3D view: where
/// the preset's transfer function (shifted by the render window as the renderer does) has
/// accumulated half opacity, or for MIP the maximum along the ray. nullopt when the ray
/// meets nothing visible. Used to seed and to move the crosshair by clicking the 3D view.
/// `map`: the deformation the view draws (nullptr: none); the point returned is where the
/// surface is drawn (output space).
std::optional<Vec3> pickSurface(const Scene& scene, int width, int height, double px, double py,
                                const deformation::MapSampler* map = nullptr);

/// True when the point mm (LPS) is hidden in the 3D view: along the ray from the eye to it, the
/// volume (deformed by `map` when given, as the renderer draws it) reaches half opacity more than
/// one voxel before the point (the pickSurface() criterion). MIP hides nothing.
bool occludedInView(const Scene& scene, const deformation::MapSampler* map, const Vec3& mm);

/// The illustration renderer's settings for `scene` at width x height: the 3D view's camera
/// and jitter, the style's background, the illustration's own ray step (one voxel), as
/// `vellum illustrate` with the same flags.
illustration::IllustrationSettings illustrationSettingsFor(const Scene& scene, int width, int height);


class View3D {
 public:
  static constexpr double kInteractiveBudgetMs = 60;
  /// Tiled refinement: when one full-width row is predicted over the budget (a deformed
  /// real-size volume on llvmpipe), the band is kTileRows rows cut into column tiles.
  static constexpr int kTileRows = 16, kMinTileCols = 8;

  /// When the current context is a GLFW window's (the studio's), a hidden window sharing its
  /// objects is made too: uploadVolumeStep() fills the volume's textures on a worker thread
  /// there. Otherwise (tests' headless contexts) uploads go a slab per call on this context.
  explicit View3D(render::GlContext& context);
  ~View3D();
  View3D(const View3D&) = delete;
  View3D& operator=(const View3D&) = delete;
  void setVolume(const VolumeI16& ct);
  /// Once per window, before its first volume (while that loads): draws a tiny volume with
  /// `scene`'s settings, plain and deformed (rigid snap, output box), so that the shaders are
  /// compiled — and llvmpipe's code for them generated — before the first picture instead of
  /// in its first 3D frames (0.3-1.2 s each at load on this machine). Does nothing once done
  /// or while a volume is shown.
  void warmUp(const Scene& scene);
  /// The same with the renderer's CPU part made on a worker (Loader); true once complete
  /// (until then the view draws nothing). With the upload context the textures are allocated
  /// and filled on a worker thread (a call only polls it: llvmpipe's allocation alone took
  /// 0.3-0.5 s a texture at 512^2 x 350, in the frame that made it); otherwise a slab of about
  /// `maxBytes` per call. Once it returned true, call it again only for another volume.
  bool uploadVolumeStep(std::shared_ptr<const AnyVolume> ct, std::shared_ptr<const render::VolumeRenderer::Prepared> prepared,
                        size_t maxBytes);
  /// The same from the scene's own CT (no copy of it for the 3D view, issue #22: memory <= 4x
  /// the volume): `ct` must stay alive and unchanged until a call returned true (the studio
  /// adopts no other volume while an upload runs). Headless, the slab path copies it.
  bool uploadVolumeStep(const VolumeI16& ct, std::shared_ptr<const render::VolumeRenderer::Prepared> prepared,
                        size_t maxBytes);
  /// Draws the volume through a deformation (nullptr: none); `revision` identifies the map, so
  /// a new one renders again (coarse while the user drags, then refined). After
  /// uploadVolumeStep() the map's CPU part (VolumeRenderer::prepareBackwardMap: seconds at
  /// 512^3 with a rigid snap) is made on a worker and uploaded by stepMap() in slabs; until it
  /// is drawn the view keeps drawing the previous map. Otherwise (setVolume) at once.
  void setBackwardMap(std::shared_ptr<const render::BackwardMap> map, uint64_t revision);
  /// Once per frame: adopts a map prepared on the worker, uploading about `maxBytes` of it;
  /// true when a new map is drawn from now on.
  bool stepMap(size_t maxBytes);
  /// True while a map set by setBackwardMap() is not drawn yet (preparing or uploading).
  bool mapPending() const { return nextMap_ || preparing_.valid() || uploading_ != nullptr; }
  /// The renderer's light source on demand: a volume from uploadVolumeStep() comes without it
  /// (the Loader's, issue #22: 21 MiB at 512^2 x 350 held for nothing while lighting is off).
  /// Once per frame: when `scene` draws lit (lighting, or the cinematic mode's volume shadows)
  /// and the drawn volume has none, starts making it from scene.ct on a worker (0.1-0.5 s at
  /// real size); once made, hands it to the renderer and draws again. Until then the view
  /// draws unlit. scene.ct must be the drawn volume's and stay as it is while lightPending().
  void stepLight(const Scene& scene);
  bool lightPending() const { return lightJob_.valid(); }
  /// True when the renderer holds a light source (made at once after setVolume()).
  bool hasLight() const { return renderer_->hasLightSource(); }
  /// True when `scene` draws lit and the light source is not there yet (drawn unlit).
  bool unlit(const Scene& scene) const { return hasVolume_ && wantsLight(scene) && !hasLight(); }
  /// Label colours for the 3D view (RenderSettings::labelBlend): re-uploaded when `revision`
  /// or the hidden set changes and the blend is on; cheap to call every frame.
  void setLabels(const LabelVolume& labels, const std::set<uint16_t>& hidden, uint64_t revision, bool wanted);
  /// The shapes the illustration view draws (null: none); `revision` identifies them.
  void setShapes(std::shared_ptr<const illustration::ShapeScene> shapes, uint64_t revision);
  /// The segment meshes drawn when ViewSettings::meshesIn3d is on (null: none), uploaded when
  /// `revision` changes; meshes whose label ids are all hidden are left out. Cheap every frame.
  void setMeshes(std::shared_ptr<const SegmentMeshes> meshes, const std::set<uint16_t>& hidden, uint64_t revision);
  /// True when `scene` is drawn as an illustration (enabled and shapes present).
  bool illustrating(const Scene& scene) const { return scene.illustration.enabled && shapes_ != nullptr; }
  /// True when `scene` draws the meshes (render presets, meshes on, one of them visible).
  bool drawingMeshes(const Scene& scene) const;
  /// Renders when the view changed (or to refine after interaction). Returns true if it
  /// rendered this frame.
  bool update(const Scene& scene, int paneWidth, int paneHeight, bool interacting);
  /// A full-resolution render at any size up to 4096² (screenshots): with meshes off the
  /// pixels of `vellum render`.
  RgbaImage renderImage(const Scene& scene, int width, int height);
  /// The GL texture to show (0: nothing yet): the view's own framebuffer colour, drawn in
  /// place by the renderer (no read-back), or the illustration's uploaded image.
  unsigned textureId() const { return shown_; }
  /// The picture shown now, read back (row 0 = top; tests): empty for the illustration's.
  RgbaImage readShown();
  /// True when that texture's row 0 is the bottom (a framebuffer's), false for an upload.
  bool textureBottomUp() const { return shownBottomUp_; }
  /// True when the displayed image is full resolution and up to date.
  bool refined() const { return refined_; }
  /// Wall milliseconds of the last 3D render (meshes + volume, or a band), waited for.
  double lastRenderMs() const { return lastMs_; }
  int lastScale() const { return lastScale_; }
  /// The ray step of the last reduced-resolution frame, in multiples of the scene's.
  int lastStepFactor() const { return lastStepFactor_; }
  /// While refining: the fraction of rows done (0..1); 1 when refined or not refining.
  double refineProgress() const {
    return refining_ && refineHeight_ > 0 ? double(refineRow_) / refineHeight_ : 1.0;
  }
  /// True when `scene` refines by path tracing at rest (cinematic quality, a DVR preset, no
  /// illustration or meshes).
  bool cinematic(const Scene& scene) const;
  /// Cinematic at rest: the samples per pixel of the picture shown (0 when not path traced).
  int cinematicSamples() const { return cinematic_ ? renderer_->cinematicSamples() : 0; }
  /// Cinematic at rest: the fraction of the denoise guide drawn (0..1; 1 when none is needed).
  double cinematicGuideProgress() const {
    return cinematic_ && guideRowsLeft_ > 0 ? double(guideRow_) / double(guideRow_ + guideRowsLeft_) : 1.0;
  }
  /// Sum of the band renders of the last completed (or running) refinement.
  double refineMs() const { return refineMs_; }
  /// Tiles (or whole-width bands) the last completed (or running) refinement drew.
  int refineTiles() const { return refineTiles_; }
  /// The per-frame budget refinement tiles are sized to (tests make it tiny to force tiles).
  void setRefineBudgetMs(double ms) { budgetMs_ = ms; }
  void invalidate() {
    refined_ = refining_ = cinematic_ = false;
    lastKey_.clear();
  }

 private:
  render::GlContext& context_;
  std::unique_ptr<render::VolumeRenderer> renderer_;
  std::unique_ptr<illustration::IllustrationRenderer> illustrator_;  ///< made on first use
  std::unique_ptr<render::MeshRenderer> meshRenderer_;                ///< made on first use
  std::shared_ptr<const illustration::ShapeScene> shapes_;
  std::shared_ptr<const SegmentMeshes> meshes_;
  std::vector<bool> meshVisible_;
  std::string labelsKey_;  ///< the labels (revision + hidden ids) uploaded as the tint
  uint64_t shapesRevision_ = 0, meshesRevision_ = 0;
  GlTexture texture_;                   ///< the illustration's image
  render::FramebufferTarget coarse_;    ///< reduced-resolution frames (meshes + volume)
  render::FramebufferTarget full_;      ///< the refined picture, filled band by band
  render::FramebufferTarget meshLayer_; ///< full-resolution meshes: colour + opaque depth
  unsigned shown_ = 0;
  bool shownBottomUp_ = false;
  bool hasVolume_ = false, hasMap_ = false;
  /// The hidden GLFW window whose context shares this one's objects (null: none), current only
  /// on the worker that fills the volume's textures.
  void* uploadWindow_ = nullptr;
  using VolumeTextures = std::shared_ptr<render::VolumeRenderer::VolumeTextures>;
  std::future<VolumeTextures> volumeJob_;  ///< the worker's textures, for jobFor_
  std::shared_ptr<const render::VolumeRenderer::Prepared> jobFor_;
  Dims jobDims_;
  /// `make` (on the worker, its context current) makes the textures of a volume of `dims`.
  bool uploadOnWorker(std::function<VolumeTextures()> make, Dims dims,
                      std::shared_ptr<const render::VolumeRenderer::Prepared> prepared);
  /// Headless uploadVolumeStep(const VolumeI16&): the copy the slab path steps through.
  std::shared_ptr<const AnyVolume> stepSource_;
  bool warmed_ = false;
  /// The volume's CPU part (from uploadVolumeStep), which map preparation needs; null after
  /// setVolume().
  std::shared_ptr<const render::VolumeRenderer::Prepared> volumePrepared_;
  struct MapRequest {
    std::shared_ptr<const render::BackwardMap> map;
    uint64_t revision = 0;
  };
  std::future<std::shared_ptr<const render::VolumeRenderer::LightSource>> lightJob_;
  std::shared_ptr<const render::VolumeRenderer::Prepared> lightFor_;  ///< the volume lightJob_ lights
  bool wantsLight(const Scene& scene) const;
  /// renderImage(): the light source made at once when `scene` needs it (a screenshot or
  /// figure is `vellum render`'s picture, never an unlit stand-in).
  void lightNow(const Scene& scene);
  std::optional<MapRequest> nextMap_;  ///< the newest map, waiting for the worker
  std::future<std::shared_ptr<const render::VolumeRenderer::PreparedBackwardMap>> preparing_;
  uint64_t preparingRevision_ = 0, uploadingRevision_ = 0;
  bool preparingStale_ = false;  ///< preparing_ was made for a volume or map since dropped
  std::shared_ptr<const render::VolumeRenderer::PreparedBackwardMap> uploading_;
  void dropPendingMaps();
  bool refined_ = false;
  std::string lastKey_;
  uint64_t mapRevision_ = 0;
  int scale_ = 4, lastScale_ = 1;
  int stepFactor_ = 1, lastStepFactor_ = 1;  ///< coarse frames' ray step (x the scene's) beyond 1/16  // first drag starts at 1/4: 1/2 is over budget at 256³
  /// The coarse resolution and step are learnt per kind of view: those of the other kind
  /// (deformed when coarseDeformed_ is false) wait here. A deformed ray costs an order more
  /// than a plain one on llvmpipe (0.04-0.09 ms per pixel on the deformed real CT), so the first
  /// deformed coarse frame drawn at the plain view's 1/8 took 0.1 s quiet, 0.7-4 s loaded; the
  /// deformed view starts at 1/16.
  int otherScale_ = 16, otherStepFactor_ = 1;
  bool coarseDeformed_ = false;
  double lastMs_ = 0;
  /// The coarse frames' first resolution and ray step for a new volume of `dims`.
  void startScales(const Dims& dims);
  void renderCoarse(const Scene& scene, int paneWidth, int paneHeight, const std::string& key);
  /// Meshes (when drawn) then the volume into `target`, whole: the coarse frames.
  void drawFrame(const Scene& scene, render::FramebufferTarget& target, int stepFactor = 1);
  void startRefinement(const Scene& scene, int paneWidth, int paneHeight);
  /// Cinematic at rest: one batch of samples added and the running picture shown.
  bool refineCinematic(const Scene& scene, int paneWidth, int paneHeight);
  bool cinematic_ = false;      ///< the renderer's progressive picture is this view's (lastKey_)
  int cinematicBatch_ = 1;      ///< samples per frame, sized to the budget from the last batch
  int cinematicRow_ = 0;        ///< banded: the next row of the sample in progress (0: none)
  double msPerRow_ = 0;         ///< one sample's cost per pane row, learnt (0: not yet)
  double lastResolveMs_ = 0;    ///< the last running picture's read-back, denoise and upload
  double cinematicMs_ = 0;      ///< wall time since the picture began (the time limit)
  int guideRow_ = 0, guideRowsLeft_ = 0;  ///< the denoise guide's next band, rows still to draw
  double msPerGuideRow_ = 0;    ///< the guide's ray cast per pane row, learnt (0: not yet)
  RgbaImage cinematicImage_;    ///< the running picture shown (readShown)
  // Banded refinement state.
  bool refining_ = false;
  int refineRow_ = 0, refineHeight_ = 0;
  int refineCol_ = 0, bandRows_ = 0;  ///< within a tiled band: the next column, the band's rows
  int refineTiles_ = 0;
  double budgetMs_ = kInteractiveBudgetMs;
  /// The rate was learnt without (false) or with a deformation; when that changes the first
  /// tile is the smallest, a probe whose rate is taken as it is (a deformed ray costs several
  /// times an undeformed one: the old rate made a first deformed tile of 0.4-0.6 s).
  bool rateDeformed_ = false, probe_ = false;
  RgbaImage coarseImage_;         ///< the last reduced-resolution frame (row cost predictor)
  std::vector<double> rowCost_;   ///< predicted relative cost of each full-resolution row
  std::vector<uint8_t> hit_;      ///< per coarse pixel: 1 where the ray met something
  /// Predicted relative cost of each column of rows [row0, row1) (rowCost_'s model, per pixel).
  std::vector<double> columnCosts(int row0, int row1, int width) const;
  double msPerCost_ = 0.01;       ///< learnt from each band
  double refineMs_ = 0;
  std::vector<double> predictRowCosts(const RgbaImage& coarse, int height) const;
};

}  // namespace vellum::studio
