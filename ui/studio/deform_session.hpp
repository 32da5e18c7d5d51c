#pragma once
// Re-solves the authored deformation for the renderer: one Deformer per volume (its rho-field
// cache makes target-only drags cheap: no ray casting), rigid bodies from the label map, and
// the resulting BackwardMap for VolumeRenderer::setBackwardMap. No GL.
#include <cstdint>
#include <chrono>
#include <future>
#include <string>
#include <memory>
#include <optional>

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
  ~DeformSession();  ///< waits for a running solve or preview build
  DeformSession(const DeformSession&) = delete;
  DeformSession& operator=(const DeformSession&) = delete;

  /// Re-solves when the points, the volume, the engine parameters, the rigid labels or the
  /// map upsampling (ViewSettings::deformedUpsampling) changed.
  /// While `interacting` (a point drag, playback) the map is solved at once: the exact map
  /// (s = 4, what the export renders) when its last solve took at most kLiveExactBudgetMs
  /// without rebuilding rho fields and no source moved since (target drags: no rho field to
  /// rebuild); otherwise a preview on a control grid twice as coarse (s = 8, its own Deformer
  /// and rho cache), like the 3D view's reduced-resolution frames, and the exact map follows
  /// on a worker thread when the interaction ends; it replaces the preview when it is done (a
  /// solve whose inputs changed meanwhile is dropped and started again). Returns true when
  /// the map changed (the 3D view must render again).
  bool update(const Scene& scene, bool interacting = false);
  /// The exact map is solved live while its updates take at most this (the target).
  static constexpr double kLiveExactBudgetMs = 50;
  /// True when the map shown is the coarse preview (or an exact solve is still running).
  bool preview() const { return preview_; }
  /// True while the exact map is being solved on the worker.
  bool solving() const { return solve_.valid(); }
  /// Blocks up to `timeout` for the worker's solve (no-op when none runs): the window's frame
  /// loop waits here instead of spinning, so the solve has the cores.
  void awaitSolve(std::chrono::milliseconds timeout) const {
    if (solve_.valid()) solve_.wait_for(timeout);
  }
  /// The map to draw, or nullptr (no points / identity).
  const render::BackwardMap* map() const { return map_ ? &*map_ : nullptr; }
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
  /// True when the exact map can be solved live for `points` (see update()).
  bool liveExact(const deformation::ControlPoints& points) const;
  /// Solves `points` on `deformer` with the rigid blend: the work of both paths.
  static Solved solve(deformation::Deformer& deformer, const deformation::ControlPoints& points,
                      const deformation::RigidBodies* bodies, double falloffMm, deformation::Upsampling upsampling,
                      std::string key);
  void adopt(Solved s, bool preview);
  void waitForSolve();
  /// Builds the preview's Deformer on a worker and solves once with it (rho fields, the rigid
  /// bodies' fields on its grid), so that the first drag starts without that wait.
  void prebuildPreview(const Scene& scene, const std::string& key);

  std::unique_ptr<deformation::Deformer> deformer_, previewDeformer_;
  std::future<Solved> solve_;  ///< the exact solve on the worker (it alone uses deformer_ meanwhile)
  std::future<std::unique_ptr<deformation::Deformer>> previewBuild_;  ///< see prebuildPreview()
  bool preview_ = false;
  std::shared_ptr<const deformation::RigidBodies> bodies_;
  std::optional<render::BackwardMap> map_;
  std::shared_ptr<const deformation::MapSampler> sampler_;
  std::string mapKey_;  ///< inputs of the exact map shown ("" = none or a preview)
  std::string previewKey_;  ///< inputs of the preview shown
  double exactUpdateMs_ = 1e300;  ///< the last exact solve, less its rho-field rebuilds
  std::vector<Vec3> exactSources_;  ///< the sources of the last exact solve
  uint64_t volumeGeneration_ = ~0ull, labelsRevision_ = ~0ull;
  std::vector<uint16_t> rigidLabels_;
  std::string engineKey_;  ///< the engine parameters the deformers were made with
  uint64_t mapRevision_ = 0;
  double lastMs_ = 0, rigidityMs_ = 0;
  deformation::DeformTimings timings_;
  bool hasTimings_ = false;
};

}  // namespace vellum::studio
