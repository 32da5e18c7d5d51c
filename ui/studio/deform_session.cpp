#include "deform_session.hpp"

#include <algorithm>
#include <chrono>
#include <sstream>

#include "vellum/animation/movie.hpp"
#include "vellum/deformation/deform_params.hpp"

namespace vellum::studio {
using namespace vellum::deformation;

DeformSession::~DeformSession() {
  waitForSolve();
  if (previewBuild_.valid()) previewBuild_.wait();
}

void DeformSession::waitForSolve() {
  if (solve_.valid()) solve_.wait(), solve_ = {};
}

namespace {
DeformParams previewParams(const DeformParams& exact) {
  DeformParams p = exact;
  p.controlScale = std::min(2 * p.controlScale, 16);  // the table's limit
  return p;
}
}  // namespace

void DeformSession::prebuildPreview(const Scene& scene, const std::string& key) {
  if (previewDeformer_ || previewBuild_.valid()) return;
  const Authoring& a = scene.authoring;
  previewBuild_ = std::async(std::launch::async, [volume = AnyVolume(scene.ct), params = previewParams(a.engine),
                                                  points = a.currentPoints(), bodies = bodies_, falloff = a.falloffMm,
                                                  upsampling = scene.view.deformedUpsampling, key] {
    auto deformer = std::make_unique<Deformer>(volume, params);
    solve(*deformer, points, bodies.get(), falloff, upsampling, key);
    return deformer;
  });
}

DeformSession::Solved DeformSession::solve(Deformer& deformer, const ControlPoints& points, const RigidBodies* bodies,
                                           double falloffMm, Upsampling upsampling, std::string key) {
  const auto t0 = std::chrono::steady_clock::now();
  Solved s;
  deformer.setPoints(points);
  ControlVolume cv = deformer.update();
  if (bodies) {  // the bodies' fields on this grid: built once per grid, timed apart
    const auto tf = std::chrono::steady_clock::now();
    bodies->gridFields(cv.grid);
    s.fieldsMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - tf).count();
  }
  const auto t1 = std::chrono::steady_clock::now();
  if (bodies) applyRigidity(cv, *bodies, {falloffMm});
  s.rigidityMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t1).count();
  s.map = deformation::renderedMap(cv, deformer.outputGeometry(), upsampling);
  s.sampler = std::make_shared<const MapSampler>(std::move(cv), deformer.outputGeometry(), upsampling);  // last use
  s.timings = deformer.timings();
  s.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  s.key = std::move(key);
  for (const auto& p : points) s.sources.push_back(p.source);
  return s;
}

bool DeformSession::liveExact(const ControlPoints& points) const {
  if (!(exactUpdateMs_ <= kLiveExactBudgetMs) || points.size() != exactSources_.size()) return false;
  for (size_t i = 0; i < points.size(); ++i)
    if (points[i].source != exactSources_[i]) return false;  // a rho field to rebuild: preview
  return true;
}

void DeformSession::adopt(Solved s, bool preview) {
  map_ = std::move(s.map);
  sampler_ = std::move(s.sampler);
  mapKey_ = preview ? "" : s.key;
  preview_ = preview;
  timings_ = s.timings;
  hasTimings_ = true;
  lastMs_ = s.ms;
  rigidityMs_ = s.rigidityMs;
  if (!preview) {
    exactUpdateMs_ = s.ms - s.timings.rhoCacheMs - s.fieldsMs;  // what the next target move costs
    exactSources_ = std::move(s.sources);
  }
  ++mapRevision_;
}

bool DeformSession::update(const Scene& scene, bool interacting) {
  const Authoring& a = scene.authoring;
  if (!scene.hasVolume() || !a.active() || a.currentPoints().empty()) {
    waitForSolve();
    const bool had = map_.has_value();
    map_.reset();
    sampler_.reset();
    mapKey_.clear();
    preview_ = false;
    if (had) ++mapRevision_;
    return had;
  }
  const std::string engineKey = params::cliArguments(deformParamsTable(), a.engine);
  const bool newVolume = scene.volumeGeneration != volumeGeneration_ || engineKey != engineKey_;
  if (newVolume || !deformer_) {
    waitForSolve();  // the worker may be using the old deformer
    if (previewBuild_.valid()) previewBuild_.wait(), previewBuild_ = {};  // built for the old one
    deformer_ = std::make_unique<Deformer>(AnyVolume(scene.ct), a.engine);
    previewDeformer_.reset();
    exactUpdateMs_ = 1e300;  // unknown until the new deformer has solved once
    exactSources_.clear();
    volumeGeneration_ = scene.volumeGeneration;
    engineKey_ = engineKey;
    labelsRevision_ = ~0ull;
  }
  if (scene.labelsRevision != labelsRevision_ || a.rigidLabels != rigidLabels_) {
    bodies_.reset();
    if (!a.rigidLabels.empty() && !scene.labels.ids().empty() && scene.labels.geometry().dims == scene.ct.geometry().dims)
      bodies_ = std::make_shared<const RigidBodies>(RigidBodies::fromLabels(scene.labels, a.rigidLabels));
    labelsRevision_ = scene.labelsRevision;
    rigidLabels_ = a.rigidLabels;
  }
  // Everything the map depends on.
  std::ostringstream k;
  k.precision(17);
  const Upsampling upsampling = scene.view.deformedUpsampling;
  k << volumeGeneration_ << ' ' << engineKey_ << ' ' << labelsRevision_ << ' ' << a.revision << ' ' << a.falloffMm
    << ' ' << upsamplingName(upsampling);
  for (uint16_t id : rigidLabels_) k << ' ' << id;
  const std::string key = k.str();

  bool changed = false;
  if (solve_.valid() && solve_.wait_for(std::chrono::seconds(0)) == std::future_status::ready) {
    Solved s = solve_.get();
    solve_ = {};
    if (s.key == key) {
      adopt(std::move(s), false);
      changed = true;
    }
  }
  if (interacting && liveExact(a.currentPoints())) {  // the exact map itself, at once
    if (mapKey_ == key) return changed;
    waitForSolve();  // a solve of older inputs holds the deformer
    adopt(solve(*deformer_, a.currentPoints(), bodies_.get(), a.falloffMm, upsampling, key), false);
    return true;
  }
  if (interacting) {  // the preview, at once
    if (preview_ && previewKey_ == key) return changed;
    if (!previewDeformer_)
      previewDeformer_ = previewBuild_.valid() ? previewBuild_.get()
                                               : std::make_unique<Deformer>(AnyVolume(scene.ct), previewParams(a.engine));
    adopt(solve(*previewDeformer_, a.currentPoints(), bodies_.get(), a.falloffMm, upsampling, key), true);
    previewKey_ = key;
    return true;
  }
  if (mapKey_ == key) {  // up to date: get the preview ready for the next drag
    prebuildPreview(scene, key);
    return changed;
  }
  if (solve_.valid()) return changed;  // the worker is on it
  // The exact map on the worker; the inputs are copies, the deformer is the worker's until done.
  solve_ = std::async(std::launch::async, [deformer = deformer_.get(), points = a.currentPoints(), bodies = bodies_,
                                           falloff = a.falloffMm, upsampling, key] {
    return solve(*deformer, points, bodies.get(), falloff, upsampling, key);
  });
  preview_ = true;  // the map shown (if any) is out of date until the exact one lands
  return changed;
}

}  // namespace vellum::studio
