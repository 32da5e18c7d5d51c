// `vellum deform` (deform a volume with control points) and `vellum controls` (place them).
#include <iostream>
#include <memory>
#include <sstream>

#include "cli_params.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "deform_cli.hpp"
#include "vellum/app/deform_pipeline.hpp"
#include "vellum/core/error.hpp"
#include "vellum/deformation/deform_params.hpp"
#include "vellum/deformation/placement.hpp"
#include "vellum/deformation/point_files.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::cli {

namespace fs = std::filesystem;
using namespace vellum::deformation;

namespace {
/// --rigid-labels as typed ("4", "4+5"): parsed into the engine when the command line is complete.
struct RigidLabelTokens {
  std::vector<std::string> tokens;
};

const ListTable<RigidLabelTokens>& rigidLabelsTable() {
  static const ListTable<RigidLabelTokens> t{
      commaList<RigidLabelTokens>(
          "rigid_labels", &RigidLabelTokens::tokens, "ID[+ID],..",
          {"Rigid labels", "label ids that stay rigid: each id is one rigid body whatever its connectivity, different "
                           "ids are different bodies (a piece mostly enclosed by another id, e.g. marrow in cortex, "
                           "moves with it); ids joined by + make one body; the phantom: 4+5,6+7,8+11,9+11 (or "
                           "4,5,6,7,8,9,11)", ""}),
  };
  return t;
}

/// The engine's lists, described once (docs/parameters.md, "Deformation run").
const ListTable<app::DeformEngine>& engineListTable() {
  using E = app::DeformEngine;
  static const ListTable<E> t{
      commaList<E>("fixed_labels", &E::fixedIds, "ID,ID..",
                   {"Fixed labels", "label ids that do not move at all (displacement 0; blended outside over "
                                    "--rigid-falloff)", ""}),
      commaList<E>("fixed_box", &E::fixedBoxMm, "X0,Y0,Z0,X1,Y1,Z1",
                   {"Fixed box", "a box (physical LPS) whose voxels do not move at all (needs --labels); repeat it "
                                 "for more boxes", "mm"}),
  };
  return t;
}
}  // namespace

std::string deformListsMarkdown() {
  return listMarkdownRows(rigidLabelsTable()) + listMarkdownRows(engineListTable());
}

void addEngineFlags(CLI::App& cmd, app::DeformEngine& engine) {
  const auto engineFlags = addFlags(cmd, engine.params, deformParamsTable());
  markInput(addFlags(cmd, engine, app::deformEngineTable()).at("labels"));
  auto rigid = std::make_shared<RigidLabelTokens>();
  addLists(cmd, *rigid, rigidLabelsTable());
  addLists(cmd, engine, engineListTable());
  CLI::Option* power = engineFlags.at("power");
  cmd.parse_complete_callback([&engine, power, rigid] {
    engine.powerGiven = power->count() > 0;
    if (engine.fixedBoxMm.size() % 6 != 0)  // a usage error (exit 2, main.cpp)
      throw CLI::ValidationError("--fixed-box", "needs 6 numbers per box: x0,y0,z0,x1,y1,z1 (mm)");
    if (!rigid->tokens.empty()) engine.setRigidLabels(rigid->tokens);
  });
}

namespace {

struct DeformArgs {
  app::DeformRequest request;  ///< the flags write here
  InputOptions in;
};

struct ControlsArgs {
  std::string input, output, fromLabels;
  int count = 16;
  double inset = 0.1;
  InputOptions in;
};

/// `controls`' numbers, described once (docs/parameters.md).
const params::Table<ControlsArgs>& controlsFlagsTable() {
  using A = ControlsArgs;
  static const params::Table<A> t{
      params::integer<A>("count", &A::count, {"Count", "points on the bounding box ([HVD]'s default: 16)", ""}),
      params::real<A>("inset", &A::inset, {"Inset", "inner offset as a fraction of the box", ""}),
  };
  return t;
}

void printSummary(const app::DeformRequest& request, const app::DeformResult& r) {
  const Geometry& g = geometryOf(r.output);
  std::cout << request.output.string() << "  " << g.dims.str() << "  " << r.points << " points  s="
            << r.params.controlScale << "  " << r.report["timings_ms"]["total"].get<double>() / 1000.0 << " s\n";
  if (!r.report.contains("rigidity")) return;
  // Null measures (no sample) are said so, not printed as 0.
  const auto mm = [](const nlohmann::json& v) {
    std::ostringstream o;
    if (v.is_null()) return std::string("not measured");
    o << v.get<double>() << " mm";
    return o.str();
  };
  const nlohmann::json& after = r.report["rigidity"]["after"];
  std::cout << "bone RMS residual " << mm(after["bone_rms_residual_mm"]) << " (before "
            << mm(r.report["rigidity"]["before"]["bone_rms_residual_mm"]) << "), soft tissue moved "
            << mm(after["soft_tissue_mean_displacement_mm"]) << " (voxel level)\n";
  for (const auto& b : after["bodies"]) {
    std::cout << "  body";
    for (const auto& id : b["ids"]) std::cout << ' ' << id.get<int>();
    std::cout << ": RMS " << mm(b["rms_residual_mm"]) << ", max " << mm(b["max_residual_mm"]);
    if (!b["rotation_deg"].is_null()) std::cout << ", turned " << b["rotation_deg"].get<double>() << " deg";
    std::cout << "\n";
  }
  if (!after["fixed"].is_null())
    std::cout << "  fixed regions moved: max " << mm(after["fixed"]["max_displacement_mm"]) << ", mean "
              << mm(after["fixed"]["mean_displacement_mm"]) << "; their content shown moved elsewhere in "
              << after["fixed"]["content_moved_elsewhere_samples"].get<int64_t>() << " voxels (max "
              << mm(after["fixed"]["content_moved_elsewhere_max_mm"]) << ")\n";
  if (!after["fold_fraction"].is_null())
    std::cout << "  folds in tissue: " << 100.0 * after["fold_fraction"].get<double>() << " % ("
              << worstJacobianText(after) << ")\n";
}

}  // namespace

void addDeformCommand(CLI::App& app) {
  auto a = std::make_shared<DeformArgs>();
  app::DeformRequest& r = a->request;
  auto* cmd = app.add_subcommand("deform", "Deform a volume with MLS control points (mm); bones can stay rigid");
  addInput(*cmd, "input", r.input, "volume file or DICOM folder")->required();
  addInput(*cmd, "--points", r.points, "control points JSON (mm; see docs/deformation.md)")->required();
  addOutput(*cmd, "--out,-o", r.output, "deformed volume (same geometry and type; any writable format)")->required();
  addOutput(*cmd, "--map-out", r.mapOut, "backward map as a gzip 3-component float32 NRRD (source mm per output voxel)");
  addOutput(*cmd, "--attributes-out", r.attributesOut,
                  "attribute field (dL*, da*, db*, density per control-grid node) as a 4-component float NRRD; "
                  "`vellum render OUT --attributes FILE` draws the output as the live deformed render does");
  addOutput(*cmd, "--report", r.report, "JSON report: stage timings, PSNR, rigidity measures");
  addForceFlag(*cmd, r.force);
  addFlags(*cmd, r, app::deformRequestTable());
  addEngineFlags(*cmd, r.engine);
  a->in.addTo(*cmd);
  cmd->footer("Example: vellum deform knee.nrrd --points cp.json --labels knee-labels.nrrd "
              "--rigid-labels 4,5,6,7,8,9,11 --out bent.nrrd --report bent.json; "
              "the other leg still: --fixed-box x0,y0,z0,x1,y1,z1 or --fixed-labels IDS");
  cmd->callback([a] {
    app::DeformRequest request = a->request;
    setVolumeInput(request, a->in);
    printSummary(request, runPipeline(request, app::runDeform));
  });
}

std::string controlsFlagsMarkdown() { return params::markdown(controlsFlagsTable()); }

void addControlsCommand(CLI::App& app) {
  auto a = std::make_shared<ControlsArgs>();
  auto* cmd = app.add_subcommand("controls", "Place control points (sources = targets) and write them as JSON (mm)");
  addInput(*cmd, "input", a->input, "volume file or DICOM folder (its box is used)")->required();
  addOutput(*cmd, "--out,-o", a->output, "control-point JSON to write")->required();
  addFlags(*cmd, *a, controlsFlagsTable());  // --count, --inset
  addInput(*cmd, "--from-labels", a->fromLabels,
                  "place points from a label map instead: centroids + surface points of each label, "
                  "plus 8 box anchors");
  a->in.addTo(*cmd);
  cmd->callback([a] {
    OutputPlan().input(a->input).input(a->fromLabels, "the --from-labels map").json(a->output, "--out").check();
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
