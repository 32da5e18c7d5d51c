// `vellum render` as one call (render_pipeline.hpp).
#include "vellum/app/render_pipeline.hpp"
#include "vellum/app/run_io.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "vellum/app/outputs.hpp"
#include "vellum/app/run_report.hpp"
#include "vellum/app/table_removal.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/params_json.hpp"
#include "vellum/deformation/map_file.hpp"
#include "vellum/io/image_io.hpp"
#include "vellum/render/contact_sheet.hpp"
#include "vellum/render/label_tint.hpp"
#include "vellum/render/volume_renderer.hpp"

namespace vellum::app {
namespace fs = std::filesystem;
namespace {

/// The identity map carrying an attribute field written by `vellum deform --attributes-out`
/// for a volume of geometry `volume` (its control grid: same origin and direction).
render::BackwardMap attributeFieldMap(const fs::path& path, const Geometry& volume) {
  Geometry grid;
  std::vector<float> field = deformation::loadAttributeFieldNrrd(path, &grid);
  const Vec3 d = grid.origin - volume.origin;
  bool sameFrame = norm(d) < 1e-3 * std::max(1.0, norm(volume.spacing));
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) sameFrame = sameFrame && std::abs(grid.direction(r, c) - volume.direction(r, c)) < 1e-6;
  for (int axis = 0; axis < 3; ++axis)  // the nodes must reach the last voxel
    sameFrame = sameFrame && (grid.dims[axis] - 1) * grid.spacing[axis] >= (volume.dims[axis] - 1) * volume.spacing[axis] - 1e-3;
  if (!sameFrame)
    throw FileError(path, "attribute field grid " + grid.dims.str() + " does not cover the volume " + volume.dims.str() +
                              " (origin, direction and extent must match its control grid)");
  return render::identityBackwardMap(grid, std::move(field), volume);
}

std::vector<FigureView> requestedViews(const RenderRequest& r) {
  if (!r.views.empty()) return r.views;
  return {FigureView{"", r.settings.camera.azimuthDeg, r.settings.camera.elevationDeg}};
}

}  // namespace

std::vector<fs::path> renderOutputs(const RenderRequest& r) {
  if (r.plate) return {r.output};
  const size_t views = std::max<size_t>(1, r.views.size());
  std::vector<fs::path> paths;
  for (render::Preset p : r.presets)
    for (size_t v = 0; v < views; ++v) {
      std::vector<std::string> parts;
      if (r.presets.size() > 1) parts.push_back(render::presetName(p));
      if (views > 1) parts.push_back(r.views[v].name);
      paths.push_back(figurePath(r.output, parts));
    }
  return paths;
}

namespace {

/// Seconds a cinematic figure keeps back from its share of --time-limit for what follows its
/// sampling: read-back, tone map, denoise and the PNG (measured 1024²: about 1 s on the loaded
/// 2-core machine; docs/benchmarks-render.md).
double finishReserveS(const render::RenderSettings& s) { return 0.25 + 0.75e-6 * double(s.width) * double(s.height); }

}  // namespace

RenderResult runRender(const RenderRequest& r, Progress& progress) {
  // --time-limit bounds the whole command, as a user times it: loading and set-up count.
  const auto commandStart = std::chrono::steady_clock::now();
  if (r.presets.empty()) throw Error("render: no preset");
  const std::vector<fs::path> outputs = renderOutputs(r);
  const std::vector<FigureView> views = requestedViews(r);
  io::OutputPlan plan;
  plan.input(r.input)
      .input(r.labelMap, "the --label-map")
      .input(r.labelColours, "the --label-colours map")
      .input(r.attributes, "the --attributes field");
  for (const auto& path : outputs) plan.output(path, "--out");
  plan.json(r.report, "--report");
  plan.check();
  RunReport run(r.commandLine);
  run.input(r.input, "volume");
  run.input(r.labelMap, "label map");
  run.input(r.labelColours, "label colours");
  run.input(r.attributes, "attribute field");
  io::LoadedVolume lv = loadInput(run, r.input, r.load, progress);
  RenderResult result;
  result.warnings = lv.warnings;
  std::optional<segmentation::BodyMaskReport> tableRemoval;
  if (r.removeTable) {
    lv.volume = withoutCtTable(lv.volume, r.input, *r.removeTable, progress, &tableRemoval.emplace());
    result.tableRemoval = tableRemovalSummary(*tableRemoval);
  }
  render::RenderSettings s = r.settings;
  const Geometry& grid = geometryOf(lv.volume);
  std::optional<LabelVolume> labels;
  if (!r.labelMap.empty()) {
    labels = loadLabelsLike(r.labelMap, r.load);
    requireSameGrid(*labels, grid, r.labelMap);
  }
  const std::optional<render::BackwardMap> attributeMap =
      r.attributes.empty() ? std::nullopt : std::optional(attributeFieldMap(r.attributes, grid));
  auto context = render::GlContext::createHeadless();
  render::VolumeRenderer renderer(*context);
  renderer.setVolume(lv.volume);
  if (attributeMap) renderer.setBackwardMap(&*attributeMap);
  // Label colours tint the volume (the studio's "Label colours"): labelColours, or with a
  // label blend alone the label map's colours.
  // With --only-label the labels filter; the blend is then only what --label-blend says.
  if (!r.labelColours.empty() && s.labelBlend == 0 && s.onlyLabel == 0) s.labelBlend = 0.5;
  std::optional<render::LabelTint> tint;
  if (s.labelBlend > 0 || s.onlyLabel > 0) {
    std::optional<LabelVolume> colours;
    if (!r.labelColours.empty()) {
      colours = loadLabelsLike(r.labelColours, r.load);
      requireSameGrid(*colours, grid, r.labelColours);
    }
    const LabelVolume* source = colours ? &*colours : labels ? &*labels : nullptr;
    if (!source) throw Error("--label-blend and --only-label need --label-colours (the label map)");
    tint = render::makeLabelTint(*source);
    renderer.setLabelTint(&*tint);
  }
  // Labels are named only when there is a label map to name them from.
  render::AnnotationOptions annotations = r.annotations;
  annotations.labels = annotations.labels && labels;
  if (labels && r.annotations.labels) checkDisplayNames(annotations, *labels);
  // The frame's box is the map's node grid when one is set (the annotations must use it too).
  const Geometry& frameBox = attributeMap ? attributeMap->grid : grid;
  ensureParentFolder(r.output);
  RunOutputs written;  // Ctrl-C between figures leaves no figure of this run
  nlohmann::json figures = nlohmann::json::array();
  std::vector<RgbaImage> tiles;
  run.mark("prepare");
  const double timeLimitS = r.settings.cinematic.timeLimitS;
  size_t figuresLeft = r.presets.size() * views.size();
  for (render::Preset p : r.presets)
    for (const FigureView& view : views) {
      s.preset = p;
      s.camera.azimuthDeg = view.azimuthDeg;
      s.camera.elevationDeg = view.elevationDeg;
      const bool cinematic = r.settings.quality == render::Quality::Cinematic && p != render::Preset::Mip;
      RgbaImage image;
      double drawMs = 0;
      int samples = 0;
      if (cinematic && timeLimitS > 0) {
        // The figure's share of what is left of the limit, less its finish; at least one sample.
        const auto t0 = std::chrono::steady_clock::now();
        renderer.beginCinematic(s);
        const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - commandStart).count();
        const double share = (timeLimitS - elapsed) / double(figuresLeft) - finishReserveS(s);
        samples = renderer.addCinematicSamples(s.cinematic.samples, std::max(share, 1e-3));
        image = renderer.resolveCinematic();
        drawMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      } else {
        image = renderer.render(s);
        drawMs = renderer.lastRenderMs();
        samples = cinematic ? renderer.lastSamples() : 0;
      }
      --figuresLeft;
      // A GL draw cannot be interrupted: Ctrl-C during it cancels here, before anything is written.
      progress.checkCancelled();
      if (anyAnnotation(annotations)) {
        const render::Projection projection(frameBox, s);
        const auto anchors = annotations.labels
                                 ? render::structureAnchors(*labels, r.labelIds, projection, image, 30, nullptr,
                                                            render::AnchorOcclusion::FrontMost)
                                 : std::vector<render::StructureAnchor>{};
        render::annotate(image, projection, annotations, anchors);
      }
      const fs::path path = outputs[r.plate ? 0 : result.figures.size()];
      std::string stage = std::string("render ") + render::presetName(p);
      if (!view.name.empty()) stage += " " + view.name;
      nlohmann::json f = {{"preset", render::presetName(p)}, {"draw_ms", drawMs}};
      if (!r.views.empty()) f["view"] = view.name;
      if (cinematic) f["samples"] = samples;
      if (r.plate) {
        tiles.push_back(std::move(image));
        run.mark(stage);
      } else {
        io::saveImage(image, path);
        written.wrote(path);
        run.mark(stage);
        run.output(path);
        f["path"] = path.string();
      }
      figures.push_back(std::move(f));
      result.figures.push_back({path, p, view.name, drawMs, samples});
    }
  if (r.plate) {
    const int columns = static_cast<int>(views.size() > 1 ? views.size() : r.presets.size());
    io::saveImage(render::contactSheet(tiles, columns), r.output);
    written.wrote(r.output);
    run.output(r.output);
  }
  result.report = {{"figures", figures}, {"settings", params::toJson(render::renderSettingsTable(), s)}};
  if (r.plate) result.report["output"] = r.output.string();
  if (!r.report.empty()) {
    run.stamp(result.report);
    writeJsonFile(result.report, r.report);
  }
  written.commit();
  return result;
}

}  // namespace vellum::app
