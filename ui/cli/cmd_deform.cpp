// `vellum deform` (deform a volume with control points) and `vellum controls` (place them).
#include <chrono>
#include <cstring>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

#include "cli_params.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "deform_cli.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/process_time.hpp"
#include "vellum/core/params_json.hpp"
#include "vellum/deformation/deform_params.hpp"
#include "vellum/deformation/map_file.hpp"
#include "vellum/deformation/placement.hpp"
#include "vellum/deformation/point_files.hpp"
#include "vellum/deformation/synthesis.hpp"
#include "vellum/io/atomic_file.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::cli {

namespace fs = std::filesystem;
using namespace vellum::deformation;

void EngineOptions::addTo(CLI::App& cmd) {
  options = addFlags(cmd, flags, deformParamsTable());
  cmd.add_option("--upsampling", upsampling, "map upsampling: trilinear | gaussian")->capture_default_str();
}

DeformParams EngineOptions::params(std::optional<double> filePower) const {
  DeformParams p = flags;
  // A given --power wins over the point file's; otherwise the file's, else the default.
  if (!options.at("power")->count() && filePower) p.mls.power = *filePower;
  validate(p);
  (void)parseUpsampling(upsampling);
  return p;
}

void RigidOptions::addTo(CLI::App& cmd) {
  cmd.add_option("--labels", labels, "label map on the same grid (NRRD ...), for rigid bones");
  cmd.add_option("--rigid-labels", rigidIds, "label ids that stay rigid, e.g. 4,5,6,7,8,9,11 (every bone id of the phantom)")->delimiter(',');
  cmd.add_option("--rigid-falloff", falloffMm, "blend band outside each bone (mm)")->capture_default_str();
  cmd.add_option("--rigidity-stride", measureStride,
                 "voxel-level rigidity measures visit every N-th voxel per axis (1 = all)")
      ->capture_default_str()->check(CLI::Range(1, 64));
}

RigidBodies RigidOptions::load(const Geometry& geometry, const InputOptions& in) const {
  if (rigidIds.empty()) throw Error("--labels needs --rigid-labels (the ids that stay rigid)");
  const LabelVolume lv = in.loadLabelsOnInputGrid(labels);
  if (!(lv.geometry().dims == geometry.dims) || !lv.geometry().approxEqual(geometry, 1e-3))
    throw FileError(labels, "label map grid " + lv.geometry().dims.str() + " differs from the volume's " +
                                geometry.dims.str());
  return RigidBodies::fromLabels(lv, rigidIds);
}

nlohmann::json toJson(const RigidityReport& r) {
  return {{"level", r.voxelLevel ? "voxels" : "control-grid nodes"},
          {"stride", r.stride},
          {"components", r.components},
          {"samples", r.nodes},
          {"bone_samples", r.boneNodes},
          {"soft_tissue_samples", r.softNodes},
          {"bone_rms_residual_mm", r.boneRmsResidualMm},
          {"bone_max_residual_mm", r.boneMaxResidualMm},
          {"soft_tissue_mean_displacement_mm", r.softTissueMeanDisplacementMm},
          {"fold_fraction", r.foldFraction}};
}

namespace {

double msSince(std::chrono::steady_clock::time_point t0) { return secondsSince(t0) * 1000.0; }

struct DeformArgs {
  std::string input, points, output, mapOut, attributesOut, report;
  bool psnr = false;
  EngineOptions engine;
  RigidOptions rigid;
  InputOptions in;
};

struct ControlsArgs {
  std::string input, output, fromLabels;
  int count = 16;
  double inset = 0.1;
  InputOptions in;
};

}  // namespace

void addDeformCommand(CLI::App& app) {
  auto a = std::make_shared<DeformArgs>();
  auto* cmd = app.add_subcommand("deform", "Deform a volume with MLS control points (mm); bones can stay rigid");
  cmd->add_option("input", a->input, "volume file or DICOM folder")->required();
  cmd->add_option("--points", a->points, "control points JSON (mm; see docs/deformation.md)")->required();
  cmd->add_option("--out,-o", a->output, "deformed volume (same geometry and type; any writable format)")->required();
  cmd->add_option("--map-out", a->mapOut, "backward map as a gzip 3-component float32 NRRD (source mm per output voxel)");
  cmd->add_option("--attributes-out", a->attributesOut,
                  "attribute field (dL*, da*, db*, density per control-grid node) as a 4-component float NRRD; "
                  "`vellum render OUT --attributes FILE` draws the output as the live deformed render does");
  cmd->add_option("--report", a->report, "JSON report: stage timings, PSNR, rigidity measures");
  cmd->add_flag("--psnr", a->psnr, "also synthesise at s = 1 and report the PSNR of the result against it");
  a->engine.addTo(*cmd);
  a->rigid.addTo(*cmd);
  a->in.addTo(*cmd);
  cmd->footer("Example: vellum deform knee.nrrd --points cp.json --labels knee-labels.nrrd "
              "--rigid-labels 4,5,6,7,8,9,11 --out bent.nrrd --report bent.json");
  cmd->callback([a] {
    const auto t0 = std::chrono::steady_clock::now();
    nlohmann::json cpu;
    cpu["before_command"] = processCpuMs();  // dynamic loading, static initialisers, parsing
    double c = processCpuMs();
    const auto cpuLap = [&](const char* stage) {
      const double now = processCpuMs();
      cpu[stage] = now - c;
      c = now;
    };
    refuseOverwritingInput(a->input, a->output);
    if (!a->attributesOut.empty()) refuseOverwritingInput(a->input, a->attributesOut);
    const PointFile pf = loadControlPoints(a->points);
    const DeformParams params = a->engine.params(pf.power);
    const Upsampling up = parseUpsampling(a->engine.upsampling);
    nlohmann::json timings, report;
    auto t = std::chrono::steady_clock::now();
    cpuLap("points");
    const io::LoadedVolume lv = loadWithProgress(a->input, a->in);
    const Geometry& g = geometryOf(lv.volume);
    timings["load"] = msSince(t);
    cpuLap("load");
    std::optional<RigidBodies> bodies;
    if (a->rigid.enabled()) {
      t = std::chrono::steady_clock::now();
      bodies = a->rigid.load(g, a->in);
      timings["rigid_bodies"] = msSince(t);
    }
    ControlVolume cv;
    {
      ProgressBar bar;
      Deformer d(lv.volume, params);
      d.setPoints(pf.points);
      cv = d.update(bar.progress());
      timings["density_build"] = d.timings().densityBuildMs;
      timings["rho_cache"] = d.timings().rhoCacheMs;
      timings["control_volume"] = d.timings().mapMs;
    }
    cpuLap("control_volume");
    std::vector<float> fullMap;  // the upsampled map synthesis resamples with (voxel level)
    if (bodies) {
      // Voxel level (primary): over the upsampled map; node level kept for comparison.
      report["rigidity"]["before"] = toJson(measureRigidityVoxels(cv, g, *bodies, up, a->rigid.measureStride));
      report["rigidity"]["before_nodes"] = toJson(measureRigidity(cv, *bodies));
      t = std::chrono::steady_clock::now();
      ProgressBar bar;
      applyRigidity(cv, *bodies, {a->rigid.falloffMm}, bar.progress());
      timings["rigidity"] = msSince(t);
      t = std::chrono::steady_clock::now();
      fullMap = upsampleMap(cv, g, up);
      report["rigidity"]["after"] = toJson(measureRigidityMap(fullMap, g, *bodies, a->rigid.measureStride));
      report["rigidity"]["after_nodes"] = toJson(measureRigidity(cv, *bodies));
      timings["rigidity_measures"] = msSince(t);
    }
    if (bodies) cpuLap("rigidity");
    AnyVolume out;
    {
      t = std::chrono::steady_clock::now();
      ProgressBar bar;
      out = synthesize(lv.volume, cv, up, bar.progress());
      timings["synthesis"] = msSince(t);
    }
    cpuLap("synthesis");
    if (a->psnr && params.controlScale > 1) {
      DeformParams ref = params;
      ref.controlScale = 1;
      ref.rhoScale = params.controlScale;  // same rho fields; only the map resolution differs
      ProgressBar bar;
      ControlVolume full = computeControlVolume(lv.volume, pf.points, ref, bar.progress());
      if (bodies) applyRigidity(full, *bodies, {a->rigid.falloffMm});
      report["psnr_db_vs_s1"] = psnr(synthesize(lv.volume, full, up), out);
    }
    if (report.contains("psnr_db_vs_s1")) cpuLap("psnr");
    t = std::chrono::steady_clock::now();
    ensureParentFolder(a->output);
    io::saveVolume(out, a->output);
    timings["save"] = msSince(t);
    cpuLap("save");
    if (!a->mapOut.empty()) {
      t = std::chrono::steady_clock::now();
      ensureParentFolder(a->mapOut);
      if (fullMap.empty()) fullMap = upsampleMap(cv, g, up);
      saveBackwardMapNrrd(fullMap, g, a->mapOut);
      timings["map_out"] = msSince(t);
    }
    if (!a->attributesOut.empty()) {
      // No point has attributes (or --attributes is off): the neutral field, so scripts can always pass it.
      std::vector<float> field = cv.attributes;
      if (field.empty())
        for (int64_t n = 0; n < cv.grid.dims.voxelCount(); ++n) field.insert(field.end(), {0.f, 0.f, 0.f, 1.f});
      ensureParentFolder(a->attributesOut);
      saveAttributeFieldNrrd(field, cv.grid, a->attributesOut);
    }
    timings["total"] = msSince(t0);
    std::cout << a->output << "  " << g.dims.str() << "  " << pf.points.size() << " points  s="
              << params.controlScale << "  " << timings["total"].get<double>() / 1000.0 << " s\n";
    if (report.contains("rigidity"))
      std::cout << "bone RMS residual " << report["rigidity"]["after"]["bone_rms_residual_mm"].get<double>()
                << " mm (before " << report["rigidity"]["before"]["bone_rms_residual_mm"].get<double>()
                << "), soft tissue moved "
                << report["rigidity"]["after"]["soft_tissue_mean_displacement_mm"].get<double>()
                << " mm (voxel level; control-grid nodes: "
                << report["rigidity"]["after_nodes"]["bone_rms_residual_mm"].get<double>() << " mm)\n";
    if (!a->report.empty()) {
      report["input"] = a->input;
      report["output"] = a->output;
      report["points"] = pf.points.size();
      report["dims"] = {g.dims.x, g.dims.y, g.dims.z};
      report["params"] = params::toJson(deformParamsTable(), params);  // keys as in `vellum params`
      report["upsampling"] = upsamplingName(up);
      report["timings_ms"] = timings;
      cpu["total"] = processCpuMs();
      report["cpu_ms"] = cpu;  // process CPU time (all threads) per stage; total includes start-up
      writeJsonFile(report, a->report);
    }
  });
}

void addControlsCommand(CLI::App& app) {
  auto a = std::make_shared<ControlsArgs>();
  auto* cmd = app.add_subcommand("controls", "Place control points (sources = targets) and write them as JSON (mm)");
  cmd->add_option("input", a->input, "volume file or DICOM folder (its box is used)")->required();
  cmd->add_option("--out,-o", a->output, "control-point JSON to write")->required();
  cmd->add_option("--count", a->count, "points on the bounding box ([HVD]'s default: 16)")->capture_default_str();
  cmd->add_option("--inset", a->inset, "inner offset as a fraction of the box")->capture_default_str();
  cmd->add_option("--from-labels", a->fromLabels,
                  "place points from a label map instead: centroids + surface points of each label, "
                  "plus 8 box anchors");
  a->in.addTo(*cmd);
  cmd->callback([a] {
    refuseOverwritingInput(a->input, a->output);
    const io::LoadedVolume lv = loadWithProgress(a->input, a->in, true);
    const Geometry& g = geometryOf(lv.volume);
    PointFile pf;
    if (!a->fromLabels.empty()) {
      const LabelVolume labels = a->in.loadLabelsOnInputGrid(a->fromLabels);
      if (!(labels.geometry().dims == g.dims))
        throw FileError(a->fromLabels, "label map grid " + labels.geometry().dims.str() +
                                           " differs from the volume's " + g.dims.str());
      pf.points = labelControlPoints(labels, a->inset);
    } else {
      pf.points = boxControlPoints(g, a->count, a->inset);
    }
    pf.power = 2;
    ensureParentFolder(a->output);
    saveControlPoints(pf, a->output);
    std::cout << a->output << "  " << pf.points.size() << " control points\n";
  });
}

}  // namespace vellum::cli
