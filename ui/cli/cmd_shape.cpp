// `vellum shape IN --labels L --segment NAME=ID[,ID..] --out DIR`: clean shapes (level-set
// denoising, meshing, mesh repair) and the shape-aware representation (per-segment distances,
// union distance, segmentation volume with shells and grown segments) for the illustration
// renderer. The work is app::runShape (shape_pipeline.hpp); this file binds the flags and prints.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>

#include "cli_params.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "vellum/app/shape_pipeline.hpp"
#include "vellum/core/error.hpp"
#include "vellum/illustration/shape.hpp"

namespace vellum::cli {
namespace ill = vellum::illustration;
namespace fs = std::filesystem;
namespace {

/// The flags: the app request's fields, and the texts parsed into it (shells, grows).
struct ShapeArgs {
  app::ShapeRequest request;
  std::vector<std::string> shells, grows;  ///< "NAME:MM"
  InputOptions in;
  TableRemovalOptions table;
};

/// The segments, shells and grows of `shape`, and its mesh format, described once
/// (docs/parameters.md).
const ListTable<ShapeArgs>& shapeListTable() {
  using A = ShapeArgs;
  static const ListTable<A> t{
      repeated<A>("segment", params::nested(&A::request, &app::ShapeRequest::segments), "NAME=ID[,ID..]",
                  {"Segment", "ids form one segment (repeatable; NAME defaults to the label name for one id)", ""})
          .withShortName("-s")
          .makeRequired(),
      repeated<A>("shell", &A::shells, "NAME:MM",
                  {"Shell", "adds a 'NAME boundary' segment MM thick inside NAME (repeatable)", ""}),
      repeated<A>("grow", &A::grows, "NAME:MM", {"Grow", "grows (MM > 0) or shrinks (MM < 0) a segment (repeatable)", ""}),
  };
  return t;
}
const params::Table<ShapeArgs>& shapeFlagsTable() {
  using A = ShapeArgs;
  static const params::Table<A> t{
      params::text<A>("mesh_format", params::nested(&A::request, &app::ShapeRequest::meshFormat),
                      {"Mesh format", "format of meshes/ (binary PLY and STL)", ""}, {"ply", "obj", "stl"}),
  };
  return t;
}

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

void printShapeSummary(const app::ShapeResult& result, const fs::path& dir) {
  const ill::ShapeResult& r = result.shape;
  const auto& t = r.times;
  std::printf("%zu segments -> %s (pipeline %.2f s: denoise %.0f, mesh %.0f, process %.0f, distances %.0f, segmentation %.0f ms)\n",
              r.shapes.size(), dir.string().c_str(), result.pipelineMs / 1000, t.denoiseMs, t.meshMs, t.processMs,
              t.distancesMs, t.segmentationMs);
  for (const auto& s : r.shapes)
    std::printf("  %-12s %7zu faces  closed=%d manifold=%d outward=%d self-intersections=%lld  volume %.0f mm3 (voxels %.0f)  max boundary distance %.2f mm\n",
                s.segment.name.c_str(), s.mesh.faces.size(), s.checks.closed, s.checks.manifold, s.checks.outward,
                static_cast<long long>(s.checks.selfIntersections), s.checks.volumeMm3, s.checks.voxelVolumeMm3,
                s.checks.maxBoundaryDistanceMm);
}

void runShape(const ShapeArgs& a) {
  app::ShapeRequest r = a.request;
  for (const auto& s : a.shells) {
    auto [name, mm] = parseNameMm(s, "--shell");
    r.shells.push_back({name, mm});
  }
  for (const auto& s : a.grows) {
    auto [name, mm] = parseNameMm(s, "--grow");
    r.grows.push_back({name, mm});
  }
  setVolumeInput(r, a.in, &a.table);
  const app::ShapeResult result = runPipeline(r, app::runShape);
  printShapeSummary(result, r.out);
}

}  // namespace

std::string shapeFlagsMarkdown() {
  // One default-initialised object for both tables: with a value-initialised one (the
  // default arguments' S{}), GCC 12 at -O3 warns that its strings may be destroyed
  // uninitialised (a false positive). Every member has its default initialiser, so both are
  // the same defaults (a const object must: it compiles only then).
  const ShapeArgs defaults;
  return params::markdown(shapeFlagsTable(), defaults) + listMarkdownRows(shapeListTable(), defaults);
}

void demoShape(const DemoContext& ctx, const fs::path& dir) {
  ShapeArgs a;
  a.request.input = ctx.phantomCt;
  a.request.labels = ctx.phantomLabels;
  a.request.out = dir;
  // Enclosing structures first: later segments win where they overlap.
  a.request.segments = {"skin=1,2,3,4,5,6,7,8,9,10,11", "muscle=3", "femur bone=4,5", "tibia bone=6,7",
                "fibula bone=8", "patella bone=9", "cartilage=10"};
  runShape(a);
}

void addShapeCommand(CLI::App& app) {
  auto a = std::make_shared<ShapeArgs>();
  app::ShapeRequest& r = a->request;
  auto* cmd = app.add_subcommand("shape", "Clean segment shapes (denoise, mesh, repair) and the shape-aware representation (distance + segmentation volumes)");
  addInput(*cmd, "input", r.input, "input CT volume (file or DICOM folder)")->required();
  addInput(*cmd, "--labels,-l", r.labels, "label map with the segments (NRRD keeps the label table)")->required();
  addLists(*cmd, *a, shapeListTable());  // --segment, --shell, --grow
  addOutput(*cmd, "--out,-o", r.out, "output folder: distance-<id>.nrrd + distances.json (each segment's own distance), distance.nrrd, segments.nrrd, shape.json, meshes/")->required();
  addFlags(*cmd, r.options, ill::shapeOptionsTable());
  addFlags(*cmd, *a, shapeFlagsTable());  // --mesh-format
  addOutput(*cmd, "--report", r.report, "also write shape.json here");
  a->in.addTo(*cmd);
  a->table.addTo(*cmd);
  addForceFlag(*cmd, r.force);
  cmd->footer("Example: vellum shape knee.nrrd --labels knee-labels.nrrd --segment bone=4,5,6,7,8,9,11 --segment skin=1 --shell bone:1.5 --out shape/");
  cmd->callback([a] { runShape(*a); });
}

}  // namespace vellum::cli
