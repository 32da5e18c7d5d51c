// The deformation request: `vellum deform`'s run, stage by stage (see deform_pipeline.hpp).
#include "vellum/app/deform_pipeline.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>

#include "vellum/app/grown_box.hpp"
#include "vellum/app/outputs.hpp"
#include "vellum/app/run_report.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/core/params_json.hpp"
#include "vellum/core/process_time.hpp"
#include "vellum/deformation/deformer.hpp"
#include "vellum/deformation/map_file.hpp"
#include "vellum/deformation/point_files.hpp"
#include "vellum/deformation/synthesis.hpp"

namespace vellum::app {
using namespace vellum::deformation;
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

/// Process CPU time (all threads) per stage: laps of one clock, so they add up to no more
/// than the total. "before_command" is everything before the run (loading, parsing).
class CpuLaps {
 public:
  CpuLaps() : last_(processCpuMs()) { laps_["before_command"] = last_; }
  void lap(const char* stage) {
    const double now = processCpuMs();
    laps_[stage] = now - last_;
    last_ = now;
  }
  nlohmann::json withTotal() {
    laps_["total"] = processCpuMs();
    return laps_;
  }

 private:
  double last_;
  nlohmann::json laps_;
};

/// What the stages share while a request runs.
struct Run {
  Run(const DeformRequest& r, Progress& p) : request(r), progress(p) {}
  const DeformRequest& request;
  Progress& progress;
  DeformParams params;
  PointFile points;
  io::LoadedVolume loaded;
  std::optional<RigidBodies> bodies;
  ControlVolume cv;
  std::vector<float> fullMap;  ///< the upsampled map (voxel level), when a stage needed it
  nlohmann::json timings, report;
  CpuLaps cpu;
};

void loadInputs(Run& run) {
  const DeformRequest& r = run.request;
  run.points = r.pointSet ? *r.pointSet : loadControlPoints(r.points);
  run.params = r.engine.resolved(run.points.power);
  run.cpu.lap("points");
  auto t = Clock::now();
  io::LoadOptions load = r.load;
  load.progress = &run.progress;
  run.loaded = io::loadVolume(r.input, load);
  run.timings["load"] = msSince(t);
  if (r.padMm != 0) {
    const GrownBox box = grownBox(run.loaded.volume, r.padMm, {run.points.points}, run.params.controlScale);
    run.loaded.volume = padded(run.loaded.volume, box.pad);
    const Geometry& g = geometryOf(run.loaded.volume);
    run.report["pad_voxels"] = {{"low", box.pad.lo}, {"high", box.pad.hi}};  // per axis (x, y, z), below / above
    run.report["output_origin_mm"] = {g.origin.x, g.origin.y, g.origin.z};
  }
  run.cpu.lap("load");
  if (!r.engine.labels.empty() || !r.engine.fixedIds.empty() || !r.engine.fixedBoxMm.empty()) {
    t = Clock::now();
    run.bodies = r.engine.rigidBodies(geometryOf(run.loaded.volume), r.load);
    run.timings["rigid_bodies"] = msSince(t);
    // What each body is made of: its ids (own id, then the cores that joined it), voxels, pieces.
    nlohmann::json list = nlohmann::json::array();
    for (const auto& b : run.bodies->bodies())
      list.push_back({{"ids", b.ids}, {"voxels", b.voxels}, {"pieces", b.pieces}, {"fixed", b.fixed}});
    run.report["rigid_bodies"] = std::move(list);
    run.report["rigid_specks_voxels"] = run.bodies->droppedVoxels();
  }
}

void buildControlVolume(Run& run) {
  Deformer d(run.loaded.volume, run.params);
  d.setPoints(run.points.points);
  run.cv = d.update(run.progress);
  run.timings["density_build"] = d.timings().densityBuildMs;
  run.timings["rho_cache"] = d.timings().rhoCacheMs;
  run.timings["control_volume"] = d.timings().mapMs;
  run.cpu.lap("control_volume");
}

/// Rigid bones, measured before and after: at voxel level (primary, over the upsampled map)
/// and at the control-grid nodes (kept for comparison).
void keepBonesRigid(Run& run) {
  const DeformEngine& e = run.request.engine;
  const Geometry& g = geometryOf(run.loaded.volume);
  nlohmann::json& rigidity = run.report["rigidity"];
  // "before" is for comparison only: coarser on a large volume, which halves what the measures
  // cost (they were half of the whole run's CPU at 512^2 x 350); "after", the result's own
  // measure, visits every voxel.
  const int beforeStride = coarseMeasureStride(g, e.rigidityStride);
  rigidity["before"] = toJson(measureRigidityVoxels(run.cv, g, *run.bodies, e.upsampling, beforeStride));
  rigidity["before_nodes"] = toJson(measureRigidity(run.cv, *run.bodies));
  run.cpu.lap("rigidity_before_measures");  // the "rigidity" lap below: blend, repair, the after measures
  auto t = Clock::now();
  std::vector<std::optional<RigidTransform>> known;
  for (const auto& b : run.bodies->bodies()) {  // known transforms (vellum pose), inverted: the map is backward
    std::optional<RigidTransform> backward;
    for (const auto& [id, forward] : run.request.boneTransforms)
      if (!b.fixed && !b.ids.empty() && b.ids.front() == id)
        backward = forward.inverse();
    known.push_back(backward);
  }
  const FoldRepairStats folds = applyRigidity(run.cv, *run.bodies, e.rigidity(), known, run.progress);
  run.timings["rigidity"] = msSince(t);
  run.cpu.lap("rigidity_blend_repair");
  rigidity["fold_repair"] = toJson(folds, e.foldRepair);
  t = Clock::now();
  run.fullMap = upsampleMap(run.cv, g, e.upsampling);
  rigidity["after"] = toJson(measureRigidityMap(run.fullMap, g, *run.bodies, e.rigidityStride));
  rigidity["after_nodes"] = toJson(measureRigidity(run.cv, *run.bodies));
  run.timings["rigidity_measures"] = msSince(t);
  run.cpu.lap("rigidity");
}

/// The whole map from the request's map maker (`vellum pose --map twist`), measured exactly as
/// keepBonesRigid() measures the MLS map ("after", voxel level).
void makeWholeMap(Run& run) {
  if (!run.bodies) throw Error("a whole-map deformation (the twist map) needs the label map's rigid bodies");
  const Geometry& g = geometryOf(run.loaded.volume);
  auto t = Clock::now();
  run.fullMap = run.request.mapMaker(g, *run.bodies, run.report["twist"], run.progress);
  run.timings["twist_map"] = msSince(t);
  run.cpu.lap("twist_map");
  t = Clock::now();
  nlohmann::json& rigidity = run.report["rigidity"];
  rigidity["after"] = toJson(measureRigidityMap(run.fullMap, g, *run.bodies, run.request.engine.rigidityStride));
  rigidity["fold_repair"] = nullptr;  // nothing to repair: the twist map is fold-free by construction
  run.timings["rigidity_measures"] = msSince(t);
  run.cpu.lap("rigidity");
}

/// The PSNR of the result against a full-resolution (s = 1) map from the same rho fields.
void psnrAgainstFullResolution(Run& run, const AnyVolume& out) {
  DeformParams ref = run.params;
  ref.controlScale = 1;
  ref.rhoScale = run.params.controlScale;  // same rho fields; only the map resolution differs
  ControlVolume full = computeControlVolume(run.loaded.volume, run.points.points, ref, run.progress);
  if (run.bodies) applyRigidity(full, *run.bodies, run.request.engine.rigidity());
  run.report["psnr_db_vs_s1"] = psnr(synthesize(run.loaded.volume, full, run.request.engine.upsampling), out);
  run.cpu.lap("psnr");
}

void writeOutputs(Run& run, const AnyVolume& out, RunOutputs& written) {
  const DeformRequest& r = run.request;
  auto t = Clock::now();
  ensureParentFolder(r.output);
  io::SaveOptions so;
  so.force = r.force;
  so.gzip = !r.noGzip;
  io::saveVolume(out, r.output, so);
  written.wrote(r.output);
  run.timings["save"] = msSince(t);
  run.cpu.lap("save");
  if (!r.mapOut.empty()) {
    t = Clock::now();
    ensureParentFolder(r.mapOut);
    if (run.fullMap.empty()) run.fullMap = upsampleMap(run.cv, geometryOf(out), r.engine.upsampling);
    saveBackwardMapNrrd(run.fullMap, geometryOf(out), r.mapOut, !r.noGzip);
    written.wrote(r.mapOut);
    run.timings["map_out"] = msSince(t);
  }
  if (!r.attributesOut.empty()) {
    // No point has attributes (or --attributes is off): the neutral field, so scripts can always pass it.
    std::vector<float> field = run.cv.attributes;
    if (field.empty())
      for (int64_t n = 0; n < run.cv.grid.dims.voxelCount(); ++n) field.insert(field.end(), {0.f, 0.f, 0.f, 1.f});
    ensureParentFolder(r.attributesOut);
    saveAttributeFieldNrrd(field, run.cv.grid, r.attributesOut, !r.noGzip);
    written.wrote(r.attributesOut);
  }
}

void finishReport(Run& run, Clock::time_point t0) {
  const DeformRequest& r = run.request;
  const Dims& d = geometryOf(run.loaded.volume).dims;
  run.timings["total"] = msSince(t0);
  run.report["input"] = r.input.string();
  run.report["output"] = r.output.string();
  run.report["points"] = run.points.points.size();
  run.report["dims"] = {d.x, d.y, d.z};
  run.report["params"] = params::toJson(deformParamsTable(), run.params);  // keys as in `vellum params`
  run.report["upsampling"] = upsamplingName(r.engine.upsampling);
  run.report["timings_ms"] = run.timings;
  run.report["cpu_ms"] = run.cpu.withTotal();  // total includes start-up
  if (!r.report.empty()) {
    RunReport shared(r.commandLine, t0);
    shared.input(r.input, "volume");
    shared.loaded(r.input, run.loaded);
    shared.input(r.points, "control points");
    shared.input(r.engine.labels, "label map");
    shared.outputVolume(r.output);
    shared.outputVolume(r.mapOut);
    shared.outputVolume(r.attributesOut);
    shared.stamp(run.report);  // the returned report is the file's
    writeJsonFile(run.report, r.report);
  }
}

}  // namespace

DeformParams DeformEngine::resolved(std::optional<double> filePower) const {
  DeformParams p = params;
  if (!powerGiven && filePower) p.mls.power = *filePower;
  validate(p);
  return p;
}

FixedRegions DeformEngine::fixedRegions() const {
  FixedRegions fixed;
  fixed.ids = fixedIds;
  // Each 6 numbers are one box (`--fixed-box` repeated, or a pose file's "fixed_boxes").
  if (fixedBoxMm.size() % 6 != 0) throw Error("--fixed-box needs 6 numbers per box: x0,y0,z0,x1,y1,z1 (mm)");
  for (size_t i = 0; i < fixedBoxMm.size(); i += 6) {
    std::array<double, 6> b{};
    std::copy(fixedBoxMm.begin() + std::ptrdiff_t(i), fixedBoxMm.begin() + std::ptrdiff_t(i + 6), b.begin());
    fixed.boxesMm.push_back(b);
  }
  return fixed;
}

std::optional<RigidBodies> DeformEngine::rigidBodies(const Geometry& grid, const io::LoadOptions& load) const {
  const FixedRegions fixed = fixedRegions();
  if (labels.empty()) {
    if (!fixed.empty()) throw Error("--fixed-labels and --fixed-box need --labels (the label map says what is tissue)");
    return std::nullopt;
  }
  if (rigidIds.empty() && rigidGroups.empty() && fixed.empty())
    throw Error("--labels needs --rigid-labels (the ids that stay rigid) or --fixed-labels / --fixed-box");
  io::LoadOptions o;
  o.region = load.region;
  o.allowOutsideData = load.allowOutsideData;
  return rigidBodies(io::loadLabels(labels, o), grid);
}

RigidBodies DeformEngine::rigidBodies(const LabelVolume& labelMap, const Geometry& grid) const {
  LabelVolume onGrid;
  try {  // the volume padded by --pad-mm: the label grid sits at whole voxels inside it
    onGrid = labelsOnGrid(labelMap, grid);
  } catch (const Error& e) {
    if (labels.empty()) throw;
    throw FileError(labels, e.what());
  }
  return RigidBodies::fromLabelGroups(onGrid, bodyGroups(), 20, fixedRegions());
}

RigidityParams DeformEngine::rigidity() const {
  RigidityParams p;
  p.falloffMm = rigidFalloffMm;
  p.repairFolds = foldRepair;
  return p;
}

std::vector<std::vector<uint16_t>> DeformEngine::bodyGroups() const {
  std::vector<std::vector<uint16_t>> all = rigidGroups;
  for (uint16_t id : rigidIds) all.push_back({id});
  return all;
}

void DeformEngine::setRigidLabels(const std::vector<std::string>& tokens) {
  rigidIds.clear();
  rigidGroups.clear();
  for (const std::string& token : tokens) {
    std::vector<uint16_t> group;
    size_t start = 0;
    for (;;) {
      const size_t plus = token.find('+', start);
      const std::string part = token.substr(start, plus == std::string::npos ? std::string::npos : plus - start);
      size_t used = 0;
      long id = -1;
      try {
        id = std::stol(part, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (part.empty() || used != part.size() || id < 1 || id > 65535)
        throw Error("--rigid-labels: \"" + token + "\" is not a label id 1..65535 or ids joined by '+' (e.g. 4+5)");
      group.push_back(static_cast<uint16_t>(id));
      if (plus == std::string::npos) break;
      start = plus + 1;
    }
    if (group.size() == 1) rigidIds.push_back(group.front());
    else rigidGroups.push_back(group);
  }
}

std::string DeformEngine::rigidLabelsArgument() const {
  std::string out;
  for (const auto& g : rigidGroups) {
    out += out.empty() ? "" : ",";
    for (size_t i = 0; i < g.size(); ++i) {
      // Appended piece by piece: `"+" + std::to_string(..)` (operator+(const char*,
      // string&&), an insert at 0) draws a false -Wrestrict from GCC 12 at -O3.
      if (i) out += '+';
      out += std::to_string(g[i]);
    }
  }
  for (uint16_t id : rigidIds) {
    if (!out.empty()) out += ',';
    out += std::to_string(id);
  }
  return out;
}

int coarseMeasureStride(const Geometry& grid, int stride) {
  return grid.dims.voxelCount() > (int64_t{1} << 25) ? std::max(2, stride) : stride;
}

const params::Table<DeformEngine>& deformEngineTable() {
  using E = DeformEngine;
  static const params::Table<E> t{
      params::choice<E>("upsampling", &E::upsampling, upsamplings().names,
                        {"Map upsampling", "how the control-grid map reaches every voxel (Gaussian: smoother, slower)", ""}),
      params::text<E>("labels", &E::labels,
                      {"Rigid-bone labels", "label map on the volume's grid (NRRD ...); the --rigid-labels ids stay rigid", ""}),
      params::real<E>("rigid_falloff", &E::rigidFalloffMm,
                      {"Rigid falloff", "blend band outside each bone", "mm", 0, 1000}),
      params::integer<E>("rigidity_stride", &E::rigidityStride,
                         {"Rigidity stride", "voxel-level rigidity measures visit every N-th voxel per axis (1 = all)",
                          "", 1, 64}),
  };
  return t;
}

const params::Table<DeformRequest>& deformRequestTable() {
  using R = DeformRequest;
  static const params::Table<R> t{
      params::flag<R>("psnr", &R::psnr,
                      {"PSNR", "also synthesise at s = 1 and report the PSNR of the result against it", ""}),
      params::real<R>("pad_mm", &R::padMm,
                      {"Output padding", "grow the output box by this on every side so what moves out is not cut "
                       "(origin moves out, world positions kept); -1 = automatic, per side: only the sides the "
                       "content's forward displacement passes, by that much + a cell (a movie: over all its keyframes, "
                       "one box for every frame, framed on the content)", "mm", -1, 500}),
      params::flag<R>("fold_repair", params::nested(&R::engine, &DeformEngine::foldRepair),
                      {"Fold repair", "relax the map around cells that fold in tissue (det J < 0.2); bones and fixed regions stay exact", ""}),
      params::flag<R>("no_gzip", &R::noGzip,
                      {"No gzip", "write the NRRD outputs (volume, map, attributes) raw instead of gzip", ""}),
  };
  return t;
}

DeformResult runDeform(const DeformRequest& request, Progress& progress) {
  const auto t0 = Clock::now();
  io::OutputPlan()
      .input(request.input)
      .input(request.points, "the --points file")
      .input(request.engine.labels, "the --labels map")
      .output(request.output, "--out")
      .output(request.mapOut, "--map-out")
      .output(request.attributesOut, "--attributes-out")
      .json(request.report, "--report")
      .force(request.force)
      .check();
  params::validate(deformRequestTable(), request);
  params::validate(deformEngineTable(), request.engine);
  if (request.mapMaker && !request.attributesOut.empty())
    throw Error("--attributes-out needs the MLS map (the twist map carries no attributes)");
  Run run(request, progress);
  loadInputs(run);
  const bool whole = static_cast<bool>(request.mapMaker);
  if (whole) {
    makeWholeMap(run);
  } else {
    buildControlVolume(run);
    if (run.bodies) keepBonesRigid(run);
  }
  auto t = Clock::now();
  DeformResult result;
  result.output = whole ? synthesizeFromMap(run.loaded.volume, run.fullMap, progress)
                        : synthesize(run.loaded.volume, run.cv, request.engine.upsampling, progress);
  run.timings["synthesis"] = msSince(t);
  run.cpu.lap("synthesis");
  if (!whole && request.psnr && run.params.controlScale > 1) psnrAgainstFullResolution(run, result.output);
  RunOutputs written;
  writeOutputs(run, result.output, written);
  finishReport(run, t0);
  written.commit();
  result.params = run.params;
  result.points = run.points.points.size();
  result.warnings = std::move(run.loaded.warnings);
  result.report = std::move(run.report);
  if (request.keepMap) result.map = run.fullMap.empty() ? upsampleMap(run.cv, geometryOf(result.output), request.engine.upsampling)
                                                        : std::move(run.fullMap);
  return result;
}

namespace {
// A measure, or null with the reason in `notMeasured` when no sample exists.
nlohmann::json measured(bool has, double value, nlohmann::json& notMeasured, const std::string& key,
                        const std::string& why) {
  if (has) return value;
  notMeasured[key] = why;
  return nullptr;
}
}  // namespace

nlohmann::json toJson(const FoldRepairStats& s, bool ran) {
  if (!ran) return nullptr;
  auto det = [](double d) { return std::isfinite(d) ? nlohmann::json(d) : nlohmann::json(); };
  return {{"cells_before", s.cellsBefore}, {"cells_after", s.cellsAfter}, {"locked_cells_after", s.lockedCells},
          {"nodes_relaxed", s.nodesRelaxed}, {"nodes_released", s.nodesReleased}, {"rounds", s.rounds},
          {"clusters_relaxed", s.clustersRelaxed},
          {"min_cell_jacobian_before", det(s.minJacobianBefore)}, {"min_cell_jacobian_after", det(s.minJacobianAfter)}};
}

nlohmann::json toJson(const RigidityReport& r) {
  nlohmann::json notMeasured = nlohmann::json::object();
  const bool bone = r.boneNodes > 0, soft = r.softNodes > 0, tissue = r.tissueSamples > 0;
  nlohmann::json j = {
      {"level", r.voxelLevel ? "voxels" : "control-grid nodes"},
      {"stride", r.stride},
      {"components", r.components},
      {"samples", r.nodes},
      {"bone_samples", r.boneNodes},
      {"soft_tissue_samples", r.softNodes},
      {"tissue_samples", r.tissueSamples},
      {"bone_rms_residual_mm", measured(bone, r.boneRmsResidualMm, notMeasured, "bone_rms_residual_mm",
                                        "no sample lands in a fitted rigid body")},
      {"bone_max_residual_mm", bone ? nlohmann::json(r.boneMaxResidualMm) : nlohmann::json()},
      {"soft_tissue_mean_displacement_mm",
       measured(soft, r.softTissueMeanDisplacementMm, notMeasured, "soft_tissue_mean_displacement_mm",
                "no soft-tissue sample (no label outside the rigid and fixed ids)")},
      {"soft_tissue_max_displacement_mm", soft ? nlohmann::json(r.softTissueMaxDisplacementMm) : nlohmann::json()},
      {"fold_fraction", measured(tissue, r.foldFraction, notMeasured, "fold_fraction",
                                 "no interior tissue sample (folds are counted in tissue only, not air)")},
      {"min_jacobian", tissue ? nlohmann::json(r.minJacobian) : nlohmann::json()},
      {"min_jacobian_at_mm", tissue ? nlohmann::json{r.minJacobianAtMm.x, r.minJacobianAtMm.y, r.minJacobianAtMm.z}
                                    : nlohmann::json()},
  };
  nlohmann::json bodies = nlohmann::json::array();
  for (const auto& b : r.bodies) {
    if (b.fixed) continue;
    nlohmann::json o = {{"ids", b.ids}, {"samples", b.samples}};
    const bool has = b.fitted && b.samples > 0;
    o["rms_residual_mm"] = has ? nlohmann::json(b.rmsResidualMm) : nlohmann::json();
    o["max_residual_mm"] = has ? nlohmann::json(b.maxResidualMm) : nlohmann::json();
    o["rotation_deg"] = b.fitted ? nlohmann::json(b.rotationDeg) : nlohmann::json();
    o["translation_mm"] = b.fitted ? nlohmann::json({b.translationMm.x, b.translationMm.y, b.translationMm.z})
                                   : nlohmann::json();
    if (!has) o["not_measured"] = b.samples ? "too few samples for a rigid fit" : "no sample lands in this body";
    bodies.push_back(std::move(o));
  }
  j["bodies"] = std::move(bodies);
  const bool hasFixed = std::any_of(r.bodies.begin(), r.bodies.end(), [](const auto& b) { return b.fixed; });
  if (hasFixed) {
    const bool has = r.fixedSamples > 0;
    j["fixed"] = {{"samples", r.fixedSamples},
                  {"max_displacement_mm", has ? nlohmann::json(r.fixedMaxDisplacementMm) : nlohmann::json()},
                  {"mean_displacement_mm", has ? nlohmann::json(r.fixedMeanDisplacementMm) : nlohmann::json()},
                  {"content_moved_elsewhere_samples", r.fixedContentElsewhere},
                  {"content_moved_elsewhere_max_mm", r.fixedContentElsewhereMaxMm}};
    if (!has) notMeasured["fixed"] = "no sample lies in the fixed regions";
  } else {
    j["fixed"] = nullptr;
    notMeasured["fixed"] = "no fixed regions (--fixed-labels, --fixed-box)";
  }
  j["not_measured"] = std::move(notMeasured);
  return j;
}

}  // namespace vellum::app
