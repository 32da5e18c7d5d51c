#include "deform_session.hpp"

#include <algorithm>
#include <chrono>

#include "vellum/animation/movie.hpp"
#include "vellum/deformation/deform_params.hpp"

namespace vellum::studio {
using namespace vellum::deformation;

const DeformTimings* DeformSession::timings() const { return lastDeformer_ ? &lastDeformer_->timings() : nullptr; }

bool DeformSession::update(const Scene& scene, bool interacting) {
  const Authoring& a = scene.authoring;
  if (!scene.hasVolume() || !a.active() || a.currentPoints().empty()) {
    const bool had = map_.has_value();
    map_.reset();
    authoringRevision_ = ~0ull;
    if (had) ++mapRevision_;
    return had;
  }
  const std::string engineKey = params::cliArguments(deformParamsTable(), a.engine);
  const bool newVolume = scene.volumeGeneration != volumeGeneration_ || engineKey != engineKey_;
  const bool newBodies = newVolume || scene.labelsRevision != labelsRevision_ || a.rigidLabels != rigidLabels_;
  const bool exactDue = preview_ && !interacting;  // the drag ended: replace the preview
  if (!newBodies && !exactDue && a.revision == authoringRevision_ && a.falloffMm == falloffMm_) return false;
  const auto t0 = std::chrono::steady_clock::now();
  if (newVolume || !deformer_) {
    deformer_ = std::make_unique<Deformer>(AnyVolume(scene.ct), a.engine);
    previewDeformer_.reset();
    volumeGeneration_ = scene.volumeGeneration;
    engineKey_ = engineKey;
  }
  if (interacting && !previewDeformer_) {
    DeformParams p = a.engine;
    p.controlScale = std::min(2 * p.controlScale, 16);  // the table's limit
    previewDeformer_ = std::make_unique<Deformer>(AnyVolume(scene.ct), p);
  }
  Deformer& deformer = interacting ? *previewDeformer_ : *deformer_;
  lastDeformer_ = &deformer;
  preview_ = interacting;
  if (newBodies) {
    bodies_.reset();
    if (!a.rigidLabels.empty() && !scene.labels.ids().empty() && scene.labels.geometry().dims == scene.ct.geometry().dims)
      bodies_ = RigidBodies::fromLabels(scene.labels, a.rigidLabels);
    labelsRevision_ = scene.labelsRevision;
    rigidLabels_ = a.rigidLabels;
  }
  deformer.setPoints(a.currentPoints());
  ControlVolume cv = deformer.update();
  const auto t1 = std::chrono::steady_clock::now();
  if (bodies_) applyRigidity(cv, *bodies_, {a.falloffMm});
  rigidityMs_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t1).count();
  map_ = animation::toBackwardMap(cv);
  authoringRevision_ = a.revision;
  falloffMm_ = a.falloffMm;
  ++mapRevision_;
  lastMs_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return true;
}

}  // namespace vellum::studio
