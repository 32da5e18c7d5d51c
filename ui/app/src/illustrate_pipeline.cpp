// `vellum illustrate` as one call (illustrate_pipeline.hpp).
#include "vellum/app/illustrate_pipeline.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>

#include "vellum/app/outputs.hpp"
#include "vellum/app/run_report.hpp"
#include "vellum/app/table_removal.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/process_time.hpp"
#include "vellum/io/image_io.hpp"
#include "vellum/render/contact_sheet.hpp"
#include "vellum/render/volume_renderer.hpp"

namespace vellum::app {
namespace ill = vellum::illustration;
namespace fs = std::filesystem;
namespace {

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }
nlohmann::json vec3Json(const Vec3& v) { return {v.x, v.y, v.z}; }

/// The styles to draw, in the request's order.
std::vector<ill::Style> requestedStyles(const IllustrateRequest& r) {
  if (r.style.empty() == r.presets.empty()) throw Error("illustrate: give --style S.json or --preset NAME");
  std::vector<ill::Style> styles;
  if (!r.style.empty()) styles.push_back(ill::loadStyle(r.style));
  for (const auto& p : r.presets) styles.push_back(ill::stylePreset(p));
  return styles;
}

/// The views to draw: the request's, or its camera as it is (no name).
std::vector<FigureView> requestedViews(const IllustrateRequest& r) {
  if (!r.views.empty()) return r.views;
  const render::Camera& c = r.settings.render.camera;
  return {FigureView{"", c.azimuthDeg, c.elevationDeg}};
}

/// The lighting layer: the CT ray cast for the figure's camera plain and lit (the render
/// module's light volume: shadows, occlusion, tone map as `lighting` says), and per pixel the
/// lit/plain luminance ratio (at most 1), faded to 1 where the plain render is transparent (no
/// surface for the light to act on), 3x3 mean. The ratio keeps the illustration's colours and
/// carries only the light: shadowed or occluded surfaces darken, the key light models the forms.
std::vector<float> lightFactor(render::VolumeRenderer& vr, const render::RenderSettings& figure,
                               const render::Lighting& lighting, render::Preset preset) {
  render::RenderSettings s = figure;
  s.preset = preset;
  s.transferFunction = {};
  s.shading = true;
  s.quality = render::Quality::Standard;
  s.background = {0.f, 0.f, 0.f, 0.f};
  s.lighting = {};
  const RgbaImage plain = vr.render(s);
  s.lighting = lighting;
  const RgbaImage lit = vr.render(s);
  auto luminance = [](const uint8_t* p) { return 0.2126f * p[0] + 0.7152f * p[1] + 0.0722f * p[2]; };
  const int w = plain.width, h = plain.height;
  std::vector<float> f(size_t(w) * h, 1.f);
  for (size_t i = 0; i < f.size(); ++i) {
    const uint8_t* a = plain.pixels.data() + 4 * i;
    const float lp = luminance(a), ll = luminance(lit.pixels.data() + 4 * i);
    if (lp < 1.f) continue;  // black in the plain render: no ratio to take
    // At most 1: the layer only darkens (the exposure lifts it towards the figure's own colour,
    // never past it, so a style's palette is kept).
    f[i] = 1.f + a[3] / 255.f * (std::min(ll / lp, 1.f) - 1.f);
  }
  // A 3x3 mean: the CT's gradient noise makes the ratio speckle from pixel to pixel.
  std::vector<float> m(f.size());
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      float sum = 0;
      int n = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
          if (x + dx >= 0 && x + dx < w && y + dy >= 0 && y + dy < h) sum += f[size_t(y + dy) * w + x + dx], ++n;
      m[size_t(y) * w + x] = sum / n;
    }
  return m;
}

/// The figure's colour times the factor (straight alpha: the figure alone, its background
/// transparent), then over `background` as the renderer composites it.
void applyLight(RgbaImage& image, const std::vector<float>& factor, const std::array<float, 4>& background) {
  for (size_t i = 0; i < factor.size(); ++i) {
    uint8_t* p = image.pixels.data() + 4 * i;
    const float a = p[3] / 255.f, ab = background[3], ao = a + ab * (1 - a);
    for (int c = 0; c < 3; ++c) {
      const float fg = std::min(255.f, p[c] * factor[i]), bg = background[size_t(c)] * 255.f;
      p[c] = uint8_t(std::lround(ao > 0 ? (fg * a + bg * ab * (1 - a)) / ao : 0.f));
    }
    p[3] = uint8_t(std::lround(ao * 255.f));
  }
}

}  // namespace

render::ImageInsets annotationRoom(const render::AnnotationOptions& o, const std::vector<uint16_t>& labelIds,
                                   const LabelVolume& segments, const ill::Style& style,
                                   const render::RenderSettings& settings) {
  if (!anyAnnotation(o)) return {};
  std::vector<std::string> texts;
  if (o.labels) {
    const std::vector<uint8_t> drawable = ill::styleDrawnIds(style, segments);
    for (const Label& l : segments.table()) {
      const bool asked = labelIds.empty() || std::find(labelIds.begin(), labelIds.end(), l.id) != labelIds.end();
      if (asked && l.id < drawable.size() && drawable[l.id]) texts.push_back(render::displayName(o, l.id, l.name));
    }
  }
  return render::annotationInsets(o, settings.width, settings.height, texts);
}

std::vector<fs::path> illustrateOutputs(const IllustrateRequest& r) {
  if (r.plate) return {r.output};
  const size_t styles = r.presets.empty() ? 1 : r.presets.size();
  const size_t views = std::max<size_t>(1, r.views.size());
  std::vector<fs::path> paths;
  for (size_t i = 0; i < styles; ++i)
    for (size_t v = 0; v < views; ++v) {
      std::vector<std::string> parts;
      if (styles > 1) parts.push_back(r.presets[i]);
      if (views > 1) parts.push_back(r.views[v].name);
      paths.push_back(figurePath(r.output, parts));
    }
  return paths;
}

IllustrateResult runIllustrate(const IllustrateRequest& r, Progress& progress) {
  const auto t0 = Clock::now();
  const std::vector<ill::Style> styles = requestedStyles(r);
  const std::vector<FigureView> views = requestedViews(r);
  if (!r.saveStyle.empty() && styles.size() > 1)
    throw Error("--save-style writes one style: give one --preset (or --style)");
  const std::vector<fs::path> outputs = illustrateOutputs(r);
  io::OutputPlan plan;
  plan.input(r.input).input(r.shape, "the --shape folder").input(r.style, "the --style file");
  for (const auto& path : outputs) plan.output(path, "--out");
  plan.json(r.saveStyle, "--save-style").json(r.report, "--report").check();

  IllustrateResult result;
  ill::ShapeScene scene = ill::loadShapeFolder(r.shape, false);
  render::AnnotationOptions annotations = r.annotations;
  // A figure framed on its anatomy keeps room for one label column, on the right.
  if (r.framing != ill::Framing::Volume) annotations.labelSide = render::AnnotationOptions::LabelSide::Right;
  if (annotations.labels) checkDisplayNames(annotations, scene.segments);
  io::LoadOptions load = r.load;
  load.progress = &progress;
  io::LoadedVolume lv = io::loadVolume(r.input, load);
  result.warnings = std::move(lv.warnings);
  std::optional<segmentation::BodyMaskReport> tableRemoval;
  if (r.removeTable) lv.volume = withoutCtTable(lv.volume, r.input, *r.removeTable, progress, &tableRemoval.emplace());
  if (!geometryOf(lv.volume).approxEqual(scene.grid()))
    throw FileError(r.shape, "grid " + scene.grid().dims.str() + " does not match the CT " + r.input.string() +
                                 " (" + geometryOf(lv.volume).dims.str() + "): make the shape folder from this CT");
  scene.ct = std::move(lv.volume);
  const double loadS = secondsSince(t0);
  const double loadCpuMs = processCpuMs();

  // One context, one upload: every style and view below draws from the same textures.
  auto context = render::GlContext::createHeadless();
  ill::IllustrationRenderer renderer(*context);
  renderer.setScene(scene);
  result.uploadMs = renderer.lastUploadMs();
  const double uploadCpuMs = processCpuMs() - loadCpuMs;  // context, packing and upload
  // The lighting layer's ray caster, on the same context (only when asked: off costs nothing).
  const render::Lighting& lighting = r.settings.render.lighting;
  std::optional<render::VolumeRenderer> lightRenderer;
  if (lighting.on()) lightRenderer.emplace(*context).setVolume(*scene.ct);
  const Geometry& grid = scene.grid();
  RunOutputs written;  // a failure (or Ctrl-C) between figures leaves none of this run's
  ensureParentFolder(r.output);
  std::vector<RgbaImage> tiles;
  nlohmann::json figures = nlohmann::json::array();
  for (const ill::Style& style : styles)
    for (const FigureView& view : views) {
      ill::IllustrationSettings s = r.settings;
      s.render.camera.azimuthDeg = view.azimuthDeg;
      s.render.camera.elevationDeg = view.elevationDeg;
      s.render.background = {style.background[0], style.background[1], style.background[2], 1.f};
      if (r.background) s.render.background = *r.background;
      if (r.transparent) s.render.background[3] = 0.f;
      // Zoom 1 fits what the figure shows (framing), not the volume's bounding sphere, and
      // leaves the annotations their room.
      s.render.camera = ill::frameFigure(scene.segments, style, s.render, r.framing,
                                         annotationRoom(annotations, r.labelIds, scene.segments, style, s.render));
      const double cpu0 = processCpuMs();
      RgbaImage image;
      double renderMs = 0;
      if (!lightRenderer) {
        image = renderer.render(style, s);
        renderMs = renderer.lastRenderMs();  // before the label probes render again
      } else {
        ill::IllustrationSettings alone = s;  // the figure without its background, lit, then over it
        alone.render.background[3] = 0.f;
        image = renderer.render(style, alone);
        renderMs = renderer.lastRenderMs();
        applyLight(image, lightFactor(*lightRenderer, s.render, lighting, r.lightPreset), s.render.background);
        renderMs += lightRenderer->lastRenderMs();
      }
      const double renderCpuMs = processCpuMs() - cpu0;  // load-independent (all GL threads)
      const double tracedPerPixel = renderer.lastTracedFraction();  // --refine-levels
      // A GL draw cannot be interrupted: Ctrl-C during it cancels here, before anything is written.
      progress.checkCancelled();
      // Labels only for segments the figure shows, each where it shows (alone, where it can).
      const auto tl = Clock::now();
      std::vector<render::StructureAnchor> anchors;
      if (annotations.labels) {
        ill::LabelSearch search;
        search.ids = r.labelIds;
        anchors = ill::drawnSegmentAnchors(renderer, style, s, scene.segments, image, search);
      }
      render::AnnotationLayout layout;
      if (anyAnnotation(annotations)) layout = render::annotate(image, render::Projection(grid, s.render), annotations, anchors);
      const double annotateS = secondsSince(tl);
      const fs::path path = outputs[r.plate ? 0 : result.figures.size()];
      if (r.plate) {
        tiles.push_back(std::move(image));
      } else {
        io::saveImage(image, path);
        written.wrote(path);
      }
      result.figures.push_back({path, style.name, view.name, renderMs});
      const auto& cam = s.render.camera;
      nlohmann::json f;
      if (!r.plate) f["output"] = path.string();
      f["style"] = style.name;
      if (!r.views.empty()) f["view"] = view.name;
      f["camera"] = {{"azimuth", cam.azimuthDeg}, {"elevation", cam.elevationDeg},
                     {"zoom", r.settings.render.camera.zoom}, {"fov", cam.fieldOfViewDeg},
                     {"frame", ill::framingName(r.framing)}, {"zoom_applied", cam.zoom},
                     {"pan_applied_mm", vec3Json(cam.panMm)}};
      f["labels"] = layout.labelTexts;
      f["render_ms"] = renderMs;
      f["render_cpu_ms"] = renderCpuMs;
      f["traced_rays_per_pixel"] = tracedPerPixel;
      f["annotate_seconds"] = annotateS;  // labels: probe renders and anchors
      figures.push_back(std::move(f));
    }
  if (r.plate) {
    // A row per style, a column per view (one row when there is one view).
    const int columns = static_cast<int>(views.size() > 1 ? views.size() : styles.size());
    io::saveImage(render::contactSheet(tiles, columns), r.output);
    written.wrote(r.output);
  }
  if (!r.saveStyle.empty()) {
    ill::saveStyle(styles.front(), r.saveStyle);
    written.wrote(r.saveStyle);
  }

  nlohmann::json& j = result.report;
  j["input"] = r.input.string();
  j["shape"] = r.shape.string();
  const ill::IllustrationSettings& s0 = r.settings;
  j["size"] = {s0.render.width, s0.render.height};
  j["interpolation"] = ill::interpolationName(s0.interpolation);
  j["refine"] = {{"levels", s0.refineLevels}, {"tolerance_levels", s0.refineTolerance * 255.0}};
  if (lighting.on())
    j["lighting"] = {{"shadows", lighting.shadows}, {"occlusion", lighting.occlusion},
                     {"occlusion_radius_mm", lighting.occlusionRadiusMm}, {"light_azimuth", lighting.azimuthDeg},
                     {"light_elevation", lighting.elevationDeg}, {"exposure", lighting.exposure},
                     {"tone_map", lighting.toneMap}, {"preset", render::presets().name(r.lightPreset)}};
  if (figures.size() == 1 && !r.plate) {
    j.update(figures[0]);  // one figure: its keys at the top, as they always were
  } else {
    if (r.plate) j["output"] = r.output.string();
    j["figures"] = figures;
  }
  if (tableRemoval) {
    j["table_removal"] = tableRemovalJson(*tableRemoval);
    result.tableRemoval = tableRemovalSummary(*tableRemoval);
  }
  j["dims"] = {grid.dims.x, grid.dims.y, grid.dims.z};
  j["load_seconds"] = loadS;
  j["upload_ms"] = result.uploadMs;
  j["load_cpu_ms"] = loadCpuMs;
  j["upload_cpu_ms"] = uploadCpuMs;
  j["renderer"] = context->renderer();
  j["total_seconds"] = secondsSince(t0);
  if (!r.report.empty()) {
    RunReport shared(r.commandLine, t0);
    shared.input(r.input, "volume");
    shared.input(r.shape, "shape folder");
    shared.input(r.style, "style");
    for (const auto& path : outputs) shared.output(path);
    if (!r.saveStyle.empty()) shared.output(r.saveStyle);
    shared.stamp(j);
    writeJsonFile(j, r.report);
  }
  written.commit();
  return result;
}

}  // namespace vellum::app
