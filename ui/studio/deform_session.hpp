#pragma once
// Re-solves the authored deformation for the renderer: one Deformer per volume (its rho-field
// cache makes target-only drags cheap: no ray casting), rigid bodies from the label map, and
// the resulting BackwardMap for VolumeRenderer::setBackwardMap. No GL.
#include <cstdint>
#include <memory>
#include <optional>

#include "authoring.hpp"
#include "scene.hpp"
#include "vellum/deformation/deformer.hpp"
#include "vellum/deformation/rigidity.hpp"
#include "vellum/render/backward_map.hpp"

namespace vellum::studio {

class DeformSession {
 public:
  /// Re-solves when the points, the volume, the engine parameters or the rigid labels changed. While `interacting`
  /// (a point drag, playback) the map is solved on a control grid twice as coarse (s = 8, its
  /// own Deformer and rho cache), like the 3D view's reduced-resolution frames; once the
  /// interaction ends the exact map (s = 4, what the export renders) replaces it. Returns true
  /// when the map changed (the 3D view must render again).
  bool update(const Scene& scene, bool interacting = false);
  /// True when the map shown is the coarse preview.
  bool preview() const { return preview_; }
  /// The map to draw, or nullptr (no points / identity).
  const render::BackwardMap* map() const { return map_ ? &*map_ : nullptr; }
  uint64_t mapRevision() const { return mapRevision_; }
  /// Time of the last re-solve (Deformer update + rigidity + conversion), ms.
  double lastUpdateMs() const { return lastMs_; }
  const deformation::DeformTimings* timings() const;
  /// Of lastUpdateMs(): the rigid-bone blend (applyRigidity).
  double lastRigidityMs() const { return rigidityMs_; }
  /// Rigid bodies of the current labels (nullptr without rigid labels).
  const deformation::RigidBodies* bodies() const { return bodies_ ? &*bodies_ : nullptr; }

 private:
  std::unique_ptr<deformation::Deformer> deformer_, previewDeformer_;
  bool preview_ = false;
  const deformation::Deformer* lastDeformer_ = nullptr;
  std::optional<deformation::RigidBodies> bodies_;
  std::optional<render::BackwardMap> map_;
  uint64_t volumeGeneration_ = ~0ull, labelsRevision_ = ~0ull, authoringRevision_ = ~0ull;
  std::vector<uint16_t> rigidLabels_;
  double falloffMm_ = -1;
  std::string engineKey_;  ///< the engine parameters the deformers were made with
  uint64_t mapRevision_ = 0;
  double lastMs_ = 0, rigidityMs_ = 0;
};

}  // namespace vellum::studio
