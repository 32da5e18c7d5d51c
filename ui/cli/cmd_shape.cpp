// `vellum shape IN --labels L --segment NAME=ID[,ID..] --out DIR`: clean shapes (level-set
// denoising, meshing, mesh repair) and the shape-aware representation (per-segment distances,
// union distance, segmentation volume with shells and grown segments) for the illustration
// renderer.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>

#include "cli_params.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "vellum/app/run_report.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/core/params_json.hpp"
#include "vellum/illustration/shape.hpp"

namespace vellum::cli {
namespace ill = vellum::illustration;
namespace fs = std::filesystem;
namespace {

struct ShapeArgs {
  std::string input, labels, out, report, meshFormat = "ply";
  std::vector<std::string> segments, shells, grows;
  bool force = false;
  ill::ShapeOptions options;  ///< the shape table's flags write here
  InputOptions in;
  TableRemovalOptions table;
};

/// "NAME:MM" -> (name, mm).
std::pair<std::string, double> parseNameMm(const std::string& text, const char* flag) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos || colon == 0)
    throw Error(std::string(flag) + " '" + text + "': expected NAME:MM");
  const std::string num = text.substr(colon + 1);
  double v = 0;
  try {
    size_t used = 0;
    v = std::stod(num, &used);
    if (used != num.size() || !std::isfinite(v)) throw std::invalid_argument(num);
  } catch (const std::exception&) {
    throw Error(std::string(flag) + " '" + text + "': '" + num + "' is not a number of mm");
  }
  return {text.substr(0, colon), v};
}

nlohmann::json checksJson(const ill::SegmentShape& s) {
  const auto& c = s.checks;
  return {{"name", s.segment.name}, {"ids", s.segment.ids},
          {"vertices", s.mesh.vertices.size()}, {"faces", s.mesh.faces.size()},
          {"closed", c.closed}, {"manifold", c.manifold}, {"outward", c.outward},
          {"self_intersections", c.selfIntersections},
          {"self_intersections_repaired", c.selfIntersectionsRepaired},
          {"holes_filled", c.holesFilled}, {"degenerate_faces_removed", c.degenerateRemoved},
          {"volume_mm3", c.volumeMm3}, {"voxel_volume_mm3", c.voxelVolumeMm3},
          {"volume_ratio", c.voxelVolumeMm3 > 0 ? c.volumeMm3 / c.voxelVolumeMm3 : 0.0},
          {"max_boundary_distance_mm", c.maxBoundaryDistanceMm}};
}

/// The CT and its labels on the same grid; the labels lose the table with --remove-table.
struct ShapeInputs {
  io::LoadedVolume ct;
  LabelVolume labels;
  TableRemovalOptions table;  ///< with its report when --remove-table ran
};

ShapeInputs loadShapeInputs(const ShapeArgs& a) {
  OutputPlan()
      .input(a.input)
      .input(a.labels, "the --labels map")
      .folder(a.out, io::FolderKind::Shape, "--out")
      .json(a.report, "--report")
      .force(a.force)
      .check();
  ShapeInputs in{loadWithProgress(a.input, a.in), {}, {}};
  const Geometry& ctGeom = geometryOf(in.ct.volume);
  // The labels get the input's --crop / --downsample (the raw-input flags describe IN only).
  in.labels = a.in.loadLabelsOnInputGrid(a.labels);
  if (!(in.labels.geometry().dims == ctGeom.dims))
    throw Error("--labels " + a.labels + ": dims " + in.labels.geometry().dims.str() +
                " differ from the CT's " + ctGeom.dims.str());
  if (!in.labels.geometry().approxEqual(ctGeom, 1e-3))
    throw Error("--labels " + a.labels + ": spacing/origin/direction differ from the CT's");
  if (a.table.enabled) {
    // Labels from a threshold include the CT table: keep only what lies in the body.
    in.table = a.table;
    const segmentation::Mask body = in.table.bodyMask(in.ct.volume, a.input);
    uint16_t* ids = in.labels.ids().data();
    for (size_t v = 0; v < in.labels.ids().size(); ++v)
      if (!body.data()[v]) ids[v] = 0;
  }
  return in;
}

/// shape.json: inputs, options, per-segment checks, the label table, shells, grows, timings.
nlohmann::json shapeReport(const ShapeArgs& a, const Geometry& ctGeom, const ill::ShapeResult& r,
                           const std::vector<ill::Shell>& shells, const std::vector<ill::Grow>& grows,
                           nlohmann::json timings) {
  const ill::ShapeOptions& opt = a.options;
  nlohmann::json j;
  j["input"] = a.input;
  j["labels"] = a.labels;
  j["dims"] = {ctGeom.dims.x, ctGeom.dims.y, ctGeom.dims.z};
  j["spacing_mm"] = toJson(ctGeom.spacing);
  j["options"] = params::toJson(ill::shapeOptionsTable(), opt);  // keys as in `vellum params`
  j["options"]["exact_band_mm"] = opt.exactBandMm > 0 ? opt.exactBandMm : ill::defaultExactBandMm(ctGeom);
  j["options"]["mesh_format"] = a.meshFormat;
  j["segments"] = nlohmann::json::array();
  for (const auto& s : r.shapes) j["segments"].push_back(checksJson(s));
  j["labels_out"] = nlohmann::json::array();
  for (const auto& l : r.segmentation.table())
    j["labels_out"].push_back({{"id", l.id}, {"name", l.name}, {"rgb", l.rgb}});
  for (const auto& s : shells) j["shells"].push_back({{"segment", s.segment}, {"thickness_mm", s.thicknessMm}});
  for (const auto& g : grows) j["grows"].push_back({{"segment", g.segment}, {"offset_mm", g.offsetMm}});
  j["timings_ms"] = std::move(timings);
  j["threads"] = workerCount();
  return j;
}

void printShapeSummary(const ill::ShapeResult& r, const fs::path& dir, double pipelineMs) {
  const auto& t = r.times;
  std::printf("%zu segments -> %s (pipeline %.2f s: denoise %.0f, mesh %.0f, process %.0f, distances %.0f, segmentation %.0f ms)\n",
              r.shapes.size(), dir.string().c_str(), pipelineMs / 1000, t.denoiseMs, t.meshMs, t.processMs,
              t.distancesMs, t.segmentationMs);
  for (const auto& s : r.shapes)
    std::printf("  %-12s %7zu faces  closed=%d manifold=%d outward=%d self-intersections=%lld  volume %.0f mm3 (voxels %.0f)  max boundary distance %.2f mm\n",
                s.segment.name.c_str(), s.mesh.faces.size(), s.checks.closed, s.checks.manifold, s.checks.outward,
                static_cast<long long>(s.checks.selfIntersections), s.checks.volumeMm3, s.checks.voxelVolumeMm3,
                s.checks.maxBoundaryDistanceMm);
}

void runShape(const ShapeArgs& a) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  if (a.meshFormat != "ply" && a.meshFormat != "obj" && a.meshFormat != "stl")
    throw Error("--mesh-format '" + a.meshFormat + "': expected ply, obj or stl");
  const ShapeInputs in = loadShapeInputs(a);
  const Geometry& ctGeom = geometryOf(in.ct.volume);
  const double loadMs = 1000 * secondsSince(t0);

  std::vector<ill::Segment> segments;
  for (const auto& s : a.segments) segments.push_back(ill::parseSegmentSpec(s, in.labels));
  std::vector<ill::Shell> shells;
  for (const auto& s : a.shells) {
    auto [name, mm] = parseNameMm(s, "--shell");
    shells.push_back({name, mm});
  }
  std::vector<ill::Grow> grows;
  for (const auto& s : a.grows) {
    auto [name, mm] = parseNameMm(s, "--grow");
    grows.push_back({name, mm});
  }
  params::validate(ill::shapeOptionsTable(), a.options);
  ill::ShapeResult r;
  const auto tp = Clock::now();
  {
    ProgressBar bar;
    r = ill::runShapePipeline(in.labels, segments, shells, grows, a.options, bar.progress());
    bar.finish();
  }
  const double pipelineMs = 1000 * secondsSince(tp);
  r.distance.setGeometry(ctGeom);
  for (auto& f : r.fields) f.distance.setGeometry(ctGeom);

  // The folder is written whole beside its target and then moved into place (a reader never
  // sees a mix of two runs' meshes), with the report first: nothing claims a finished result
  // that is not there.
  const auto tw = Clock::now();
  const fs::path dir = a.out;
  ensureParentFolder(dir);
  nlohmann::json report;
  io::writeFolderAtomically(dir, io::FolderKind::Shape, [&](const fs::path& tmp) {
    fs::create_directories(tmp / "meshes");
    io::SaveOptions raw;
    raw.gzip = false;  // 4 bytes a voxel of smooth floats: gzip would cost seconds for little
    io::saveVolume(r.distance, tmp / "distance.nrrd", raw);
    io::saveLabels(r.segmentation, tmp / "segments.nrrd");
    ill::saveSegmentFields(r.fields, tmp);  // per-segment distances (docs/shape.md)
    for (const auto& s : r.shapes) ill::saveMesh(s.mesh, tmp / "meshes" / (s.segment.name + "." + a.meshFormat), a.meshFormat);
    const double writeMs = 1000 * secondsSince(tw);
    const auto& t = r.times;
    nlohmann::json j = shapeReport(a, ctGeom, r, shells, grows,
                                         {{"load", loadMs}, {"denoise", t.denoiseMs}, {"mesh", t.meshMs},
                                          {"process", t.processMs}, {"distances", t.distancesMs},
                                          {"segmentation", t.segmentationMs}, {"pipeline", pipelineMs},
                                          {"write", writeMs}, {"total", 1000 * secondsSince(t0)}});
    in.table.addToReport(j);
    writeJsonFile(j, tmp / "shape.json");
    report = std::move(j);
  }, a.force);
  if (!a.report.empty()) {
    RunOutputs outputs;  // a report that cannot be written takes the folder with it
    outputs.wrote(dir);
    app::RunReport shared(commandLine(), t0);
    shared.input(a.input, "volume");
    shared.input(a.labels, "label map");
    shared.output(dir);
    shared.stamp(report);
    writeJsonFile(report, a.report);
    outputs.commit();
  }
  printShapeSummary(r, dir, pipelineMs);
}

}  // namespace

void demoShape(const DemoContext& ctx, const fs::path& dir) {
  ShapeArgs a;
  a.input = ctx.phantomCt.string();
  a.labels = ctx.phantomLabels.string();
  a.out = dir.string();
  // Enclosing structures first: later segments win where they overlap.
  a.segments = {"skin=1,2,3,4,5,6,7,8,9,10,11", "muscle=3", "femur bone=4,5", "tibia bone=6,7",
                "fibula bone=8", "patella bone=9", "cartilage=10"};
  runShape(a);
}

void addShapeCommand(CLI::App& app) {
  auto a = std::make_shared<ShapeArgs>();
  auto* cmd = app.add_subcommand("shape", "Clean segment shapes (denoise, mesh, repair) and the shape-aware representation (distance + segmentation volumes)");
  cmd->add_option("input", a->input, "input CT volume (file or DICOM folder)")->required();
  cmd->add_option("--labels,-l", a->labels, "label map with the segments (NRRD keeps the label table)")->required();
  cmd->add_option("--segment,-s", a->segments, "NAME=ID[,ID..] (repeatable; ids form one segment; NAME defaults to the label name for one id)")->required();
  cmd->add_option("--out,-o", a->out, "output folder: distance-<id>.nrrd + distances.json (each segment's own distance), distance.nrrd, segments.nrrd, shape.json, meshes/")->required();
  cmd->add_option("--shell", a->shells, "NAME:MM adds a 'NAME boundary' segment MM thick inside NAME (repeatable)");
  cmd->add_option("--grow", a->grows, "NAME:MM grows (MM > 0) or shrinks (MM < 0) a segment (repeatable)");
  addFlags(*cmd, a->options, ill::shapeOptionsTable());
  cmd->add_option("--mesh-format", a->meshFormat, "ply | obj | stl (binary PLY and STL)")->capture_default_str();
  cmd->add_option("--report", a->report, "also write shape.json here");
  a->in.addTo(*cmd);
  a->table.addTo(*cmd);
  addForceFlag(*cmd, a->force);
  cmd->footer("Example: vellum shape knee.nrrd --labels knee-labels.nrrd --segment bone=4,5,6,7,8,9,11 --segment skin=1 --shell bone:1.5 --out shape/");
  cmd->callback([a] { runShape(*a); });
}

}  // namespace vellum::cli
