// The segmentation request: method dispatch and post-processing (see segment_pipeline.hpp).
#include "vellum/app/segment_pipeline.hpp"

#include "vellum/core/error.hpp"
#include "vellum/core/params.hpp"
#include "vellum/segmentation/components.hpp"
#include "vellum/segmentation/morphology.hpp"
#include "vellum/segmentation/region_growing.hpp"
#include "vellum/segmentation/split.hpp"
#include "vellum/segmentation/threshold.hpp"

namespace vellum::app {
namespace seg = vellum::segmentation;
namespace {

seg::HuInterval interval(const SegmentSettings& a, seg::Preset fallback) {
  seg::HuInterval iv = seg::presetInterval(a.preset.empty() ? fallback : seg::parsePreset(a.preset));
  if (a.lower) iv.lower = *a.lower;
  if (a.upper) iv.upper = *a.upper;
  if (!(iv.upper >= iv.lower)) throw Error("upper must be >= lower (--upper, --lower)");
  return iv;
}

/// Runs the chosen method; multi-Otsu fills `classes` instead of returning a mask.
seg::Mask runMethod(const SegmentSettings& a, const VolumeI16& ct, nlohmann::json& info,
                    std::optional<VolumeU16>& classes, Progress& progress, const seg::SnakeObserver& observe) {
  const std::vector<Vec3>& seeds = a.seedsMm;
  const std::string& m = a.method;
  auto needSeeds = [&] {
    if (seeds.empty()) throw Error("method " + m + " needs at least one seed (--seed x,y,z in mm)");
  };
  if (m == "threshold") {
    const auto iv = interval(a, seg::Preset::Bone);
    info["interval_hu"] = {iv.lower, iv.upper};
    return seg::threshold(ct, iv);
  }
  if (m == "otsu" || m == "multi-otsu") {
    const auto h = seg::histogram(ct, {256, a.lower.value_or(-1024), a.upper.value_or(3071)});
    if (m == "otsu") {
      const double t = seg::otsuThreshold(h);
      info["threshold_hu"] = t;
      return seg::threshold(ct, {t, 32767});
    }
    const auto t = seg::multiOtsuThresholds(h, a.classes);
    info["thresholds_hu"] = t;
    classes = seg::classify(ct, t);
    return {};
  }
  if (m == "hysteresis") {
    seg::HysteresisParams p;  // the library's defaults, unless a flag or preset says otherwise
    if (!a.preset.empty() || a.lower || a.upper) p.weak = interval(a, seg::Preset::Bone);
    p.strong = {a.strong.value_or(p.strong.lower), p.weak.upper};
    params::validate(seg::hysteresisParamsTable(), p);
    info["weak_hu"] = {p.weak.lower, p.weak.upper};
    info["strong_hu"] = {p.strong.lower, p.strong.upper};
    return seg::hysteresis(ct, p);
  }
  if (m == "grow") {
    needSeeds();
    const auto iv = interval(a, seg::Preset::SoftTissue);
    info["interval_hu"] = {iv.lower, iv.upper};
    return seg::connectedThreshold(ct, seeds, iv, seg::Connectivity::Face6, progress);
  }
  if (m == "confidence") {
    needSeeds();
    seg::ConfidenceParams p;
    p.multiplier = a.multiplier;
    if (a.iterations) p.iterations = *a.iterations;
    auto r = seg::confidenceConnected(ct, seeds, p, progress);
    info["interval_hu"] = {r.finalInterval.lower, r.finalInterval.upper};
    info["iterations"] = r.iterations;
    return std::move(r.mask);
  }
  if (m == "snake") {
    needSeeds();
    const seg::SpeedType type = seg::parseSpeedType(a.speed);
    seg::SpeedImage speed;
    if (type == seg::SpeedType::Threshold) {
      const auto iv = interval(a, seg::Preset::SoftTissue);
      info["interval_hu"] = {iv.lower, iv.upper};
      speed = seg::thresholdSpeed(ct, {iv.lower, iv.upper, 60}, progress);
    } else {
      speed = seg::edgeSpeed(ct, {a.sigma, a.kappa, a.exponent}, progress);
      info["edge"] = {{"sigma_mm", a.sigma}, {"kappa_hu_per_mm", a.kappa}, {"exponent", a.exponent}};
    }
    seg::SnakeParams p;
    p.propagation = a.propagation;
    p.curvature = a.curvature;
    p.advection = a.advection;
    if (a.iterations) p.maxIterations = *a.iterations;
    std::vector<seg::Bubble> bubbles;
    for (const Vec3& s : seeds) bubbles.push_back({s, a.bubbleRadiusMm});
    auto r = a.snakeStart ? seg::evolveSnakeFrom(speed, *a.snakeStart, p, progress, observe, 5)
                          : seg::evolveSnake(speed, bubbles, p, progress, observe, 5);
    info["snake"] = {{"speed", a.speed}, {"iterations", r.iterations}, {"coarse_iterations", r.coarseIterations},
                     {"converged", r.converged}, {"settled", r.settled}, {"seconds", r.seconds},
                     {"ms_per_iteration", 1000 * r.secondsPerIteration},
                     {"propagation", p.propagation}, {"curvature", p.curvature}, {"advection", seg::resolvedAdvection(p, type)},
                     {"bubble_radius_mm", a.bubbleRadiusMm}};
    return std::move(r.mask);
  }
  throw Error("unknown method '" + m + "' (threshold, otsu, multi-otsu, hysteresis, grow, confidence, snake)");
}

seg::Mask postProcess(const SegmentSettings& r, seg::Mask m, nlohmann::json& info) {
  const SegmentPostProcessing& a = r.post;
  const std::vector<Vec3>& seeds = r.seedsMm;
  nlohmann::json steps = nlohmann::json::array();
  if (a.closeMm > 0) { m = seg::close(m, a.closeMm); steps.push_back({{"close_mm", a.closeMm}}); }
  if (a.openMm > 0) { m = seg::open(m, a.openMm); steps.push_back({{"open_mm", a.openMm}}); }
  if (a.fillHoles) { m = seg::fillHoles(m); steps.push_back("fill_holes_3d"); }
  if (a.fillHolesSlices) { m = seg::fillHolesAllSlices(m); steps.push_back("fill_holes_slices_xyz"); }
  if (a.minIslandMm3 > 0) { m = seg::removeSmallIslands(m, a.minIslandMm3); steps.push_back({{"min_island_mm3", a.minIslandMm3}}); }
  if (a.keepLargest) {
    // With seeds, keep the pieces holding them; otherwise the largest.
    m = seeds.empty() || r.method == "threshold" ? seg::keepLargestComponent(m) : seg::keepComponentsWithSeeds(m, seeds);
    steps.push_back("keep_largest");
  }
  info["post_processing"] = steps;
  return m;
}

}  // namespace

const params::Table<SegmentSettings>& segmentSettingsTable() {
  using R = SegmentSettings;
  using params::real, params::integer, params::flag, params::text, params::nested;
  static const params::Table<R> t = [] {
    params::Table<R> rows{
      text<R>("method", &R::method, {"Method", "segmentation method", ""},
              {"threshold", "otsu", "multi-otsu", "hysteresis", "grow", "confidence", "snake"}),
      text<R>("preset", &R::preset,
              {"HU preset", "interval preset (bone [700,3071] cortex, whole-bone [550,3071], soft-tissue [-500,300], "
                            "skin-air [-500,3071], fat [-190,-30], lung [-950,-500]); empty: the method's default", ""}),
      real<R>("lower", &R::lower,
              {"Lower", "lower bound (overrides the preset; otsu: histogram range; hysteresis: weak threshold)", "HU", -32768, 32767}),
      real<R>("upper", &R::upper, {"Upper", "upper bound (overrides the preset)", "HU", -32768, 32767}),
      real<R>("strong", &R::strong,
              {"Strong", "hysteresis: lower bound of the strong interval (unset: the hysteresis table's)", "HU", -32768, 32767}),
      integer<R>("classes", &R::classes, {"Classes", "multi-otsu: number of classes", "", 2, 8}),
      real<R>("radius", &R::bubbleRadiusMm, {"Bubble radius", "snake: seed bubble radius", "mm", 0.1, 500}),
      integer<R>("iterations", &R::iterations,
                 {"Iterations", "snake: iteration limit (unset 2000); confidence: passes (unset 4)", "", 1, 100000}),
      text<R>("speed", &R::speed,
              {"Snake speed", "threshold (region competition inside the HU interval) | edge (stops at gradients)", ""},
              {"threshold", "edge"}),
      real<R>("curvature", &R::curvature, {"Curvature", "snake: curvature weight (smooths)", "mm", 0, 100}),
      real<R>("propagation", &R::propagation, {"Propagation", "snake: propagation weight", "", -10, 10}),
      real<R>("advection", &R::advection,
              {"Advection", "snake: advection weight (unset: 0 threshold speed, 2 edge speed)", "", 0, 100}),
      real<R>("sigma", &R::sigma, {"Edge sigma", "edge speed: Gaussian sigma", "mm", 0, 50}),
      real<R>("kappa", &R::kappa, {"Edge kappa", "edge speed: gradient where g = 0.5", "HU/mm", 1, 100000}),
      real<R>("exponent", &R::exponent, {"Edge exponent", "edge speed: g = 1/(1+(|grad|/kappa)^exponent)", "", 0.5, 16}),
      real<R>("multiplier", &R::multiplier,
              {"Confidence multiplier", "confidence: interval = mean +- multiplier * std", "", 0.1, 20}),
      real<R>("close", nested(&R::post, &SegmentPostProcessing::closeMm), {"Close", "post: morphological closing radius (0 = off)", "mm", 0, 100}),
      real<R>("open", nested(&R::post, &SegmentPostProcessing::openMm), {"Open", "post: morphological opening radius (0 = off)", "mm", 0, 100}),
      flag<R>("fill_holes", nested(&R::post, &SegmentPostProcessing::fillHoles), {"Fill holes", "post: fill enclosed cavities (3D)", ""}),
      flag<R>("fill_holes_slices", nested(&R::post, &SegmentPostProcessing::fillHolesSlices),
              {"Fill holes in slices", "post: fill holes enclosed in any axial, coronal or sagittal slice (then 3D)", ""}),
      real<R>("min_island", nested(&R::post, &SegmentPostProcessing::minIslandMm3),
              {"Min island", "post: remove pieces smaller than this volume (0 = off)", "mm^3", 0, 1e12}),
      flag<R>("keep_largest", nested(&R::post, &SegmentPostProcessing::keepLargest),
              {"Keep largest", "post: keep the largest piece (with seeds: the pieces holding them)", ""}),
      flag<R>("split", nested(&R::post, &SegmentPostProcessing::split),
              {"Split objects", "post, last: split into separate objects (bones touching at joints, two feet), "
                                "one label id each, largest first (watershed on the depth below the surface)", ""}),
    };
    for (auto& f : params::embed<R>("split_", nested(&R::post, &SegmentPostProcessing::splitParams),
                                    seg::splitParamsTable()))
      rows.push_back(std::move(f));
    return rows;
  }();
  return t;
}

SegmentationResult runSegmentation(const VolumeI16& ct, const SegmentSettings& request, Progress& progress,
                               const seg::SnakeObserver& observe) {
  params::validate(segmentSettingsTable(), request);
  SegmentationResult out;
  out.mask = runMethod(request, ct, out.info, out.classes, progress, observe);
  if (!out.classes) out.mask = postProcess(request, std::move(out.mask), out.info);
  if (!out.classes && request.post.split) {
    seg::SplitResult split = seg::splitObjects(out.mask, request.post.splitParams, progress, &ct);
    nlohmann::json objects = nlohmann::json::array();
    for (int o = 1; o <= split.count(); ++o) objects.push_back({{"object", o}, {"volume_mm3", split.volumesMm3[o]}});
    out.info["split"] = {{"neck_mm", request.post.splitParams.neckMm},
                         {"min_volume_mm3", request.post.splitParams.minVolumeMm3},
                         {"seeds", request.post.splitParams.seedsMm.size()},
                         {"markers", split.markers},
                         {"joint_contrast_hu", request.post.splitParams.jointContrastHu},
                         {"joint_width_mm", request.post.splitParams.jointWidthMm},
                         {"joint_share", request.post.splitParams.jointShare},
                         {"joint_voxels", split.jointVoxels},
                         {"joint_merges", split.jointMerges},
                         {"open_joints", request.post.splitParams.openJoints},
                         {"opened_mm3", split.openedMm3},
                         {"fill", request.post.splitParams.fillObjects},
                         {"filled_mm3", split.filledMm3},
                         {"thin_mm", request.post.splitParams.thinMm},
                         {"thin_removed_mm3", split.thinRemovedMm3},
                         {"objects", objects},
                         {"dropped_mm3", split.droppedMm3}};
    out.objects = std::move(split.objects);
  }
  return out;
}

}  // namespace vellum::app
