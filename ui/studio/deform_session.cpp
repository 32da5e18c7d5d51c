#include "deform_session.hpp"

#include <chrono>

#include "vellum/animation/movie.hpp"

namespace vellum::studio {
using namespace vellum::deformation;

DeformParams studioDeformParams() { return DeformParams{}; }

const DeformTimings* DeformSession::timings() const { return deformer_ ? &deformer_->timings() : nullptr; }

bool DeformSession::update(const Scene& scene) {
  const Authoring& a = scene.authoring;
  if (!scene.hasVolume() || !a.active() || a.currentPoints().empty()) {
    const bool had = map_.has_value();
    map_.reset();
    authoringRevision_ = ~0ull;
    if (had) ++mapRevision_;
    return had;
  }
  const bool newVolume = scene.volumeGeneration != volumeGeneration_;
  const bool newBodies = newVolume || scene.labelsRevision != labelsRevision_ || a.rigidLabels != rigidLabels_;
  if (!newBodies && a.revision == authoringRevision_ && a.falloffMm == falloffMm_) return false;
  const auto t0 = std::chrono::steady_clock::now();
  if (newVolume || !deformer_) {
    deformer_ = std::make_unique<Deformer>(AnyVolume(scene.ct), studioDeformParams());
    volumeGeneration_ = scene.volumeGeneration;
  }
  if (newBodies) {
    bodies_.reset();
    if (!a.rigidLabels.empty() && !scene.labels.ids().empty() && scene.labels.geometry().dims == scene.ct.geometry().dims)
      bodies_ = RigidBodies::fromLabels(scene.labels, a.rigidLabels);
    labelsRevision_ = scene.labelsRevision;
    rigidLabels_ = a.rigidLabels;
  }
  deformer_->setPoints(a.currentPoints());
  ControlVolume cv = deformer_->update();
  if (bodies_) applyRigidity(cv, *bodies_, {a.falloffMm});
  map_ = animation::toBackwardMap(cv);
  authoringRevision_ = a.revision;
  falloffMm_ = a.falloffMm;
  ++mapRevision_;
  lastMs_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return true;
}

}  // namespace vellum::studio
