#pragma once
// Re-solves the authored deformation for the renderer: one Deformer per volume (its rho-field
// cache makes target-only drags cheap: no ray casting), rigid bodies from the label map, and
// the resulting BackwardMap for VolumeRenderer::setBackwardMap. No GL.
#include <cstdint>
#include <chrono>
#include <functional>
#include <future>
#include <string>
#include <memory>
#include <optional>
#include <vector>

#include "authoring.hpp"
#include "scene.hpp"
#include "vellum/deformation/deformer.hpp"
#include "vellum/deformation/rigidity.hpp"
#include "vellum/deformation/synthesis.hpp"
#include "vellum/render/backward_map.hpp"

namespace vellum::studio {

class DeformSession {
 public:
  DeformSession() = default;
  ~DeformSession();  ///< waits for the workers
  DeformSession(const DeformSession&) = delete;
  DeformSession& operator=(const DeformSession&) = delete;

  /// Re-solves when the points, the volume, the engine parameters, the rigid labels or the
  /// map upsampling (ViewSettings::deformedUpsampling) changed. Nothing heavy runs on the
  /// caller's thread: the deformers are made, the rigid bodies built from the labels and the
  /// maps solved on workers, and a finished result is adopted by a later call.
  /// While `interacting` (a point drag, playback): the exact map (s = 4, what the export
  /// renders) is solved at once when its last solve took at most kLiveExactBudgetMs without
  /// rebuilding rho fields and no source moved since (target drags); otherwise a preview on a
  /// control grid twice as coarse (s = 8, its own Deformer and rho cache) is solved on its
  /// worker, the newest inputs each time it is free, like the 3D view's reduced-resolution
  /// frames. The exact map follows on its worker when the interaction ends and replaces the
  /// preview when done (a solve whose inputs changed meanwhile is dropped and started again).
  /// While new rigid bodies are built the map shown keeps the previous ones. Returns true
  /// when the map changed (the 3D view must render again).
  bool update(const Scene& scene, bool interacting = false);
  /// Where the rigid bodies' copy of the labels is made (see SceneReader); without one (tests)
  /// on the caller's thread.
  void setSceneReader(SceneReader reader) { sceneReader_ = std::move(reader); }
  /// The exact map is solved live while its updates take at most this (the target).
  static constexpr double kLiveExactBudgetMs = 50;
  /// Another budget for the live exact solve (tests whose point is the choice, not the time:
  /// a loaded sanitizer build can take longer than 50 ms for a small grid).
  void setLiveExactBudgetMs(double ms) { liveExactBudgetMs_ = ms; }
  /// True when the map shown is the coarse preview (or an exact solve is still running).
  bool preview() const { return preview_; }
  /// True while the exact map (or the rigid bodies it needs) is being made on a worker.
  bool solving() const { return solve_.valid() || bodiesBuild_.valid() || labelsCopy_.valid() || labelsSettling_; }
  /// True while the exact solve itself runs (the window's frames wait for it a little).
  bool exactSolveRunning() const { return solve_.valid(); }
  /// True while any worker runs (the exact solve, the preview, the rigid bodies): they read
  /// the scene's CT, so a new volume is adopted only once this is false (see cancel()).
  bool busy() const {
    return solve_.valid() || previewWork_.valid() || bodiesBuild_.valid() || labelsCopy_.valid() || labelsSettling_;
  }
  /// Stops the exact solve early (its result is dropped); the others finish on their own.
  void cancel();
  /// What runs, for the status line: "rigid bodies", "exact map", "preview map" (empty: none).
  std::vector<std::string> running() const;
  /// Blocks up to `timeout` for the worker's solve (no-op when none runs): the window's frame
  /// loop waits here instead of spinning, so the solve has the cores.
  void awaitSolve(std::chrono::milliseconds timeout) const {
    if (solve_.valid()) solve_.wait_for(timeout);
  }
  /// The map to draw, or nullptr (no points / identity).
  const render::BackwardMap* map() const { return map_.get(); }
  /// The same, shared: the 3D view prepares it for the GPU on a worker (immutable once made).
  const std::shared_ptr<const render::BackwardMap>& sharedMap() const { return map_; }
  /// The same map for CPU sampling at any output position (the deformed slice views), or
  /// nullptr exactly when map() is: the control volume with its rigid snap, upsampled as
  /// CPU synthesis does it.
  const deformation::MapSampler* sampler() const { return map_ ? sampler_.get() : nullptr; }
  uint64_t mapRevision() const { return mapRevision_; }
  /// Time of the last adopted solve (Deformer update + rigidity + conversion), ms.
  double lastUpdateMs() const { return lastMs_; }
  const deformation::DeformTimings* timings() const { return hasTimings_ ? &timings_ : nullptr; }
  /// Of lastUpdateMs(): the rigid-bone blend (applyRigidity).
  double lastRigidityMs() const { return rigidityMs_; }
  /// Rigid bodies of the current labels (nullptr without rigid labels).
  const deformation::RigidBodies* bodies() const { return bodies_.get(); }
  const std::shared_ptr<const deformation::RigidBodies>& sharedBodies() const { return bodies_; }

 private:
  struct Solved {
    render::BackwardMap map;
    std::shared_ptr<const deformation::MapSampler> sampler;
    deformation::DeformTimings timings;
    double ms = 0, rigidityMs = 0;
    double fieldsMs = 0;  ///< of ms: the rigid bodies' fields on the grid (once per grid)
    std::string key;  ///< the inputs it was solved for
    std::vector<Vec3> sources;  ///< the points' sources (their rho fields are now cached)
  };
  /// The inputs of one solve, copied for its worker.
  struct SolveInputs {
    deformation::ControlPoints points;
    std::shared_ptr<const deformation::RigidBodies> bodies;
    double falloffMm = 10;
    deformation::Upsampling upsampling = deformation::Upsampling::Trilinear;
    std::string key;
    /// Known bone transforms (a joint tool pose: RigidBodies order, backward); empty: fitted.
    std::vector<std::optional<RigidTransform>> prescribed;
    /// The joint tool's twist map (its pose's map "twist"; the exact solve only, never the
    /// preview): the pose at `twistAngles`, its bones on the exact grid's nodes from
    /// `nodeLabels` (`rigidLabels`, `fixed`), snapped to `bodies` (deformation::TwistFrames).
    std::shared_ptr<const deformation::Pose> twistPose;
    std::vector<double> twistAngles;
    std::shared_ptr<const LabelVolume> nodeLabels;
    std::vector<uint16_t> rigidLabels;
    deformation::FixedRegions fixed;
  };
  /// True when the exact map can be solved live for `points` (see update()).
  bool liveExact(const deformation::ControlPoints& points) const;
  /// Solves `points` on `deformer` with the rigid blend: the work of both paths.
  static Solved solve(deformation::Deformer& deformer, const SolveInputs& in, Progress& progress);
  /// How a solve shares the machine: the exact map in the worker arena (inWorkerArena) at the
  /// workers' lowered priority; a drag's preview, which the user waits for, on all the cores
  /// at the window's priority; the preview engine made ready for the next drag like the exact map.
  enum class SolveKind { Exact, DragPreview, Background };
  /// On a worker: makes *slot from `ct` (when empty) and solves with it. The UI thread leaves
  /// *slot alone until the future is ready.
  static std::future<Solved> solveOnWorker(std::unique_ptr<deformation::Deformer>* slot, const VolumeI16* ct,
                                           deformation::DeformParams params, SolveInputs in,
                                           std::shared_ptr<Progress> progress, SolveKind kind = SolveKind::Exact);
  /// `exact`: for the exact map (the twist map when the pose asks for it), else the preview's.
  SolveInputs inputs(const Scene& scene, const std::string& key, bool exact) const;
  /// The labels at the exact grid's nodes (the twist map's bones), made on the UI thread when
  /// first needed for these labels and grid (1/s^3 of the labels), kept until they change.
  mutable std::shared_ptr<const LabelVolume> nodeLabels_;
  mutable std::string nodeLabelsKey_;
  void adopt(Solved s, bool preview);
  void waitForSolve();
  void waitForPreview();

  std::unique_ptr<deformation::Deformer> deformer_, previewDeformer_;
  std::future<Solved> solve_;  ///< the exact solve on the worker (it alone uses deformer_ meanwhile)
  std::shared_ptr<Progress> solveProgress_;  ///< cancels the exact solve
  /// The preview's worker (it alone uses previewDeformer_ meanwhile): a solve during a drag,
  /// or, when idle, one that makes the preview's Deformer, rho fields and body fields ready
  /// for the next drag (its map is not shown).
  std::future<Solved> previewWork_;
  bool previewForDrag_ = false;  ///< previewWork_ was started by a drag (its map is shown)
  bool preview_ = false;
  std::shared_ptr<const deformation::RigidBodies> bodies_;
  /// The copy of the labels the next rigid bodies are built from, made by sceneReader_ (a
  /// broken promise: the copy was dropped, e.g. a cancelled task; asked again).
  struct LabelsCopy {
    std::shared_ptr<const LabelVolume> labels;
    uint64_t revision = 0;
  };
  std::future<LabelsCopy> labelsCopy_;
  /// The labels' revision last seen and when it changed (edits settle before a rebuild).
  uint64_t seenLabelsRevision_ = ~0ull;
  std::chrono::steady_clock::time_point labelsChangedAt_{};
  static constexpr double kSettleLabelsS = 0.5;
  bool labelsSettling_ = false;  ///< edited labels waiting to settle before the bodies are rebuilt
  SceneReader sceneReader_;
  double liveExactBudgetMs_ = kLiveExactBudgetMs;
  /// Starts building the rigid bodies from `labels` on a worker.
  void buildBodies(std::shared_ptr<const LabelVolume> labels, uint64_t revision);
  /// Rigid bodies being built from a copy of the labels, and what they are built for.
  std::future<std::shared_ptr<const deformation::RigidBodies>> bodiesBuild_;
  uint64_t buildingRevision_ = 0;
  std::vector<uint16_t> buildingLabels_;
  std::shared_ptr<const render::BackwardMap> map_;
  std::shared_ptr<const deformation::MapSampler> sampler_;
  std::string mapKey_;  ///< inputs of the exact map shown ("" = none or a preview)
  std::string previewKey_;  ///< inputs of the preview shown
  double exactUpdateMs_ = 1e300;  ///< the last exact solve, less its rho-field rebuilds
  std::vector<Vec3> exactSources_;  ///< the sources of the last exact solve
  uint64_t volumeGeneration_ = ~0ull, labelsRevision_ = ~0ull;  ///< labelsRevision_: of bodies_
  std::vector<uint16_t> rigidLabels_;  ///< of bodies_
  std::string fixedKey_, buildingFixedKey_;  ///< the fixed regions of bodies_ / of the build
  deformation::FixedRegions buildingFixed_;
  std::string engineKey_;  ///< the engine parameters the deformers were made with
  uint64_t mapRevision_ = 0;
  double lastMs_ = 0, rigidityMs_ = 0;
  deformation::DeformTimings timings_;
  bool hasTimings_ = false;
};

}  // namespace vellum::studio
