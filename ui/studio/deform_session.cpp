#include "deform_session.hpp"
#include "thread_priority.hpp"

#include <algorithm>
#include <chrono>
#include <iostream>
#include <sstream>

#include "vellum/animation/movie.hpp"
#include "vellum/deformation/deform_params.hpp"
#include "vellum/deformation/twist_frames.hpp"

namespace vellum::studio {
using namespace vellum::deformation;

DeformSession::~DeformSession() {
  cancel();
  waitForSolve();
  waitForPreview();
  if (bodiesBuild_.valid()) bodiesBuild_.wait();
}

void DeformSession::waitForSolve() {
  if (solve_.valid()) solve_.wait(), solve_ = {};
}

void DeformSession::waitForPreview() {
  if (previewWork_.valid()) previewWork_.wait(), previewWork_ = {};
}

void DeformSession::cancel() {
  if (solveProgress_) solveProgress_->cancel();
}

std::vector<std::string> DeformSession::running() const {
  std::vector<std::string> r;
  if (bodiesBuild_.valid() || labelsCopy_.valid()) r.push_back("rigid bodies from the labels");
  if (solve_.valid()) r.push_back("exact deformation map");
  if (previewWork_.valid()) r.push_back(previewForDrag_ ? "preview deformation map" : "preparing the drag preview");
  return r;
}

namespace {
DeformParams previewParams(const DeformParams& exact) {
  DeformParams p = exact;
  p.controlScale = std::min(2 * p.controlScale, 16);  // the table's limit
  return p;
}

template <class T>
bool ready(const std::future<T>& f) {
  return f.valid() && f.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
}
}  // namespace

DeformSession::Solved DeformSession::solve(Deformer& deformer, const SolveInputs& in, Progress& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  Solved s;
  if (in.twistPose && in.bodies && in.nodeLabels) {
    // The joint tool's twist map, as `vellum pose --map twist` makes it (its movie's frames):
    // the bones on this grid's nodes, the full-resolution bones snapped exactly.
    const int scale = deformer.params().controlScale;
    std::vector<std::vector<uint16_t>> groups;
    for (uint16_t id : in.rigidLabels) groups.push_back({id});
    // The tool's twist power and margin are `vellum pose`'s defaults.
    const TwistFrames frames(*in.twistPose, nodeBodiesOf(*in.nodeLabels, groups, scale, in.fixed),
                             deformer.outputGeometry(), scale, twistParamsOf(PoseOptions{}));
    ControlVolume cv = frames.at(in.twistAngles, *in.bodies, progress);
    s.map = deformation::renderedMap(cv, deformer.outputGeometry(), in.upsampling);
    s.sampler = std::make_shared<const MapSampler>(std::move(cv), deformer.outputGeometry(), in.upsampling);
    s.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    s.key = in.key;
    for (const auto& p : in.points) s.sources.push_back(p.source);
    return s;
  }
  deformer.setPoints(in.points);
  ControlVolume cv = deformer.update(progress);
  if (in.bodies) {  // the bodies' fields on this grid: built once per grid, timed apart
    const auto tf = std::chrono::steady_clock::now();
    in.bodies->gridFields(cv.grid);
    s.fieldsMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - tf).count();
  }
  const auto t1 = std::chrono::steady_clock::now();
  if (in.bodies && !in.prescribed.empty()) applyRigidity(cv, *in.bodies, {in.falloffMm}, in.prescribed);
  else if (in.bodies) applyRigidity(cv, *in.bodies, {in.falloffMm});
  s.rigidityMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t1).count();
  s.map = deformation::renderedMap(cv, deformer.outputGeometry(), in.upsampling);
  s.sampler = std::make_shared<const MapSampler>(std::move(cv), deformer.outputGeometry(), in.upsampling);  // last use
  s.timings = deformer.timings();
  s.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  s.key = in.key;
  for (const auto& p : in.points) s.sources.push_back(p.source);
  return s;
}

std::future<DeformSession::Solved> DeformSession::solveOnWorker(std::unique_ptr<Deformer>* slot, const VolumeI16* ct,
                                                                DeformParams params, SolveInputs in,
                                                                std::shared_ptr<Progress> progress, SolveKind kind) {
  // The CT is read, not copied, here: the studio adopts a new volume only once busy() is
  // false, so it cannot change under the worker.
  return std::async(std::launch::async, [slot, ct, params, in = std::move(in), progress = std::move(progress), kind] {
    // Only a drag's preview keeps the window's priority: the exact solve (seconds of rho
    // fields on a real scan) starved the window's frames of the core they share with it
    // (200-900 ms frames drawing nothing at 512^2 x 350); at nice +10 it still gets every
    // cycle the window leaves, and the window waits for it between frames (awaitSolve).
    if (kind != SolveKind::DragPreview) lowerThreadPriority();
    auto work = [&] {
      if (!*slot) *slot = std::make_unique<Deformer>(AnyVolume(*ct), params);
      return solve(**slot, in, *progress);
    };
    // A drag's preview is what the user waits for (the first drag response): all the cores.
    // The others in a smaller arena, so that the UI thread keeps a core.
    if (kind == SolveKind::DragPreview) return work();
    return inWorkerArena(work);
  });
}

void DeformSession::buildBodies(std::shared_ptr<const LabelVolume> labels, uint64_t revision) {
  buildingRevision_ = revision;
  bodiesBuild_ = std::async(std::launch::async, [labels = std::move(labels), ids = buildingLabels_, f = buildingFixed_] {
    lowerThreadPriority();
    return std::make_shared<const RigidBodies>(RigidBodies::fromLabels(*labels, ids, 20, f));
  });
}

DeformSession::SolveInputs DeformSession::inputs(const Scene& scene, const std::string& key, bool exact) const {
  const Authoring& a = scene.authoring;
  SolveInputs in{a.currentPoints(), bodies_, a.falloffMm, scene.view.deformedUpsampling, key, {}, {}, {}, {}, {}, {}};
  if (a.pose && bodies_) {  // the joint tool's exact bones at the angles of the time shown
    const double t = a.timeS.value_or(keyframeStartS(a.track, a.keyframe));
    in.prescribed = knownBodyTransforms(*a.pose, *bodies_, a.pose->anglesAt(t));
    if (exact && a.pose->map == "twist" && scene.labels.geometry().dims == scene.ct.geometry().dims) {
      const int scale = a.engine.controlScale;
      const std::string labelsKey = std::to_string(volumeGeneration_) + ' ' + std::to_string(labelsRevision_) + ' ' +
                                    std::to_string(scale);
      if (!nodeLabels_ || nodeLabelsKey_ != labelsKey) {
        nodeLabels_ = std::make_shared<const LabelVolume>(labelsAtNodes(scene.labels, scale));
        nodeLabelsKey_ = labelsKey;
      }
      in.twistPose = a.pose;
      in.twistAngles = a.pose->anglesAt(t);
      in.nodeLabels = nodeLabels_;
      in.rigidLabels = rigidLabels_;
      in.fixed = a.fixed;
    }
  }
  return in;
}

namespace {
/// The fixed regions as text: what the rigid bodies depend on beside the labels and rigid ids.
std::string fixedKey(const FixedRegions& f) {
  std::ostringstream k;
  k.precision(17);
  for (uint16_t id : f.ids) k << id << ',';
  for (const auto& b : f.boxesMm)
    for (double v : b) k << ' ' << v;
  return k.str();
}
}  // namespace

bool DeformSession::liveExact(const ControlPoints& points) const {
  if (!(exactUpdateMs_ <= liveExactBudgetMs_) || points.size() != exactSources_.size()) return false;
  for (size_t i = 0; i < points.size(); ++i)
    if (points[i].source != exactSources_[i]) return false;  // a rho field to rebuild: preview
  return true;
}

void DeformSession::adopt(Solved s, bool preview) {
  map_ = std::make_shared<const render::BackwardMap>(std::move(s.map));
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
    // Nothing to show; running workers finish on their own (their results are dropped).
    const bool had = map_ != nullptr;
    labelsSettling_ = false;  // nothing is rebuilt while there is nothing to show
    map_.reset();
    sampler_.reset();
    mapKey_.clear();
    preview_ = false;
    if (had) ++mapRevision_;
    return had;
  }
  const std::string engineKey = params::cliArguments(deformParamsTable(), a.engine);
  const bool newVolume = scene.volumeGeneration != volumeGeneration_ || engineKey != engineKey_;
  if (newVolume) {
    // The workers hold the old deformers: the exact solve stops early, a preview finishes (a
    // new volume is adopted only when none runs; engine edits wait for at most a preview).
    cancel();
    waitForSolve();
    waitForPreview();
    deformer_.reset();  // made again on the exact solve's worker
    previewDeformer_.reset();
    exactUpdateMs_ = 1e300;  // unknown until the new deformer has solved once
    exactSources_.clear();
    volumeGeneration_ = scene.volumeGeneration;
    engineKey_ = engineKey;
    labelsRevision_ = ~0ull;
    labelsCopy_ = {};  // of the previous volume's labels
  }
  // Rigid bodies: built on a worker from a copy of the labels (painting goes on meanwhile);
  // the map keeps the previous bodies until they land, then is solved again.
  if (ready(bodiesBuild_)) {
    try {
      bodies_ = bodiesBuild_.get();
    } catch (const std::exception& e) {
      std::cerr << "vellum-studio: rigid bodies: " << e.what() << "\n";
      bodies_.reset();
    }
    bodiesBuild_ = {};
    labelsRevision_ = buildingRevision_;
    rigidLabels_ = buildingLabels_;
    fixedKey_ = buildingFixedKey_;
  }
  if (ready(labelsCopy_)) {
    try {
      LabelsCopy copy = labelsCopy_.get();
      buildBodies(std::move(copy.labels), copy.revision);
    } catch (const std::future_error&) {  // dropped before it ran: asked again below
    }
    labelsCopy_ = {};
  }
  const std::string fixed = fixedKey(a.fixed);
  // Label edits while bones are rigid (brush strokes) wait until the labels have been still
  // for kSettleLabelsS: each rebuild costs seconds on a real scan, and the copy it starts
  // holds the labels (a stroke begun meanwhile is refused).
  if (scene.labelsRevision != seenLabelsRevision_) {
    seenLabelsRevision_ = scene.labelsRevision;
    labelsChangedAt_ = std::chrono::steady_clock::now();
  }
  labelsSettling_ = bodies_ && labelsRevision_ != ~0ull && scene.labelsRevision != labelsRevision_ &&
                    a.rigidLabels == rigidLabels_ && fixed == fixedKey_ &&
                    std::chrono::steady_clock::now() - labelsChangedAt_ < std::chrono::duration<double>(kSettleLabelsS);
  if ((scene.labelsRevision != labelsRevision_ || a.rigidLabels != rigidLabels_ || fixed != fixedKey_) &&
      !bodiesBuild_.valid() && !labelsCopy_.valid() && !labelsSettling_) {
    if (a.rigidLabels.empty() || scene.labels.ids().empty() || !(scene.labels.geometry().dims == scene.ct.geometry().dims)) {
      bodies_.reset();
      labelsRevision_ = scene.labelsRevision;
      rigidLabels_ = a.rigidLabels;
      fixedKey_ = fixed;
    } else {
      buildingLabels_ = a.rigidLabels;
      buildingFixedKey_ = fixed;
      buildingFixed_ = a.fixed;
      if (!sceneReader_) {
        buildBodies(std::make_shared<const LabelVolume>(scene.labels), scene.labelsRevision);
      } else {
        // The copy (the size of the CT) is made on the task queue's worker, not in this frame;
        // the revision is read there too, so it names the labels copied.
        auto promise = std::make_shared<std::promise<LabelsCopy>>();
        std::future<LabelsCopy> copy = promise->get_future();
        if (sceneReader_("copying the labels for the rigid bodies", [promise](const Scene& s) {
              promise->set_value({std::make_shared<const LabelVolume>(s.labels), s.labelsRevision});
            }))
          labelsCopy_ = std::move(copy);
      }
    }
  }
  // Everything the map depends on (the labels only through rigid bodies).
  std::ostringstream k;
  k.precision(17);
  const Upsampling upsampling = scene.view.deformedUpsampling;
  k << volumeGeneration_ << ' ' << engineKey_ << ' ' << (rigidLabels_.empty() ? 0 : labelsRevision_) << ' '
    << a.revision << ' ' << a.falloffMm << ' ' << upsamplingName(upsampling);
  for (uint16_t id : rigidLabels_) k << ' ' << id;
  k << " fixed " << fixedKey_;
  const std::string key = k.str();

  bool changed = false;
  if (ready(solve_)) {
    try {
      Solved s = solve_.get();
      if (s.key == key) {
        adopt(std::move(s), false);
        changed = true;
      }
    } catch (const std::exception&) {  // cancelled (a new volume), or failed: solved again below
    }
    solve_ = {};
  }
  if (ready(previewWork_)) {
    try {
      Solved s = previewWork_.get();
      // During a drag the newest preview is shown; after it, only one of the final inputs
      // that the exact map has not replaced yet. A preparation's map is not shown.
      if (previewForDrag_ && mapKey_ != key && (interacting || s.key == key)) {
        previewKey_ = s.key;
        adopt(std::move(s), true);
        changed = true;
      }
    } catch (const std::exception& e) {
      std::cerr << "vellum-studio: preview map: " << e.what() << "\n";
    }
    previewWork_ = {};
  }
  if (interacting && liveExact(a.currentPoints())) {  // the exact map itself, at once
    if (mapKey_ == key) return changed;
    if (solve_.valid()) cancel(), waitForSolve();  // a solve of older inputs holds the deformer
    adopt(solve(*deformer_, inputs(scene, key, true), Progress::none()), false);
    return true;
  }
  if (interacting) {  // the preview, on its worker, the newest inputs whenever it is free
    if ((preview_ && previewKey_ == key) || previewWork_.valid()) return changed;
    previewForDrag_ = true;
    previewWork_ = solveOnWorker(&previewDeformer_, &scene.ct, previewParams(a.engine), inputs(scene, key, false),
                                 std::make_shared<Progress>(), SolveKind::DragPreview);
    return changed;
  }
  if (mapKey_ == key) {  // up to date: get the preview's deformer ready for the next drag
    if (!previewWork_.valid() && !previewDeformer_) {
      previewForDrag_ = false;
      previewWork_ = solveOnWorker(&previewDeformer_, &scene.ct, previewParams(a.engine), inputs(scene, key, false),
                                   std::make_shared<Progress>(), SolveKind::Background);
    }
    return changed;
  }
  if (solve_.valid() || bodiesBuild_.valid() || labelsCopy_.valid() || labelsSettling_)
    return changed;  // the worker is on it; or bodies first
  // The exact map on the worker; the inputs are copies, the deformer is the worker's until done.
  solveProgress_ = std::make_shared<Progress>();
  solve_ = solveOnWorker(&deformer_, &scene.ct, a.engine, inputs(scene, key, true), solveProgress_);
  preview_ = true;  // the map shown (if any) is out of date until the exact one lands
  return changed;
}

}  // namespace vellum::studio
