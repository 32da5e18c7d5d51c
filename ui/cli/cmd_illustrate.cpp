// `vellum illustrate IN --shape DIR (--style S.json | --preset NAME) --out FIG.png [...]`
#include <algorithm>
#include <iostream>
#include <memory>

#include "cli_params.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "vellum/app/run_report.hpp"
#include "vellum/core/error.hpp"
#include "vellum/illustration/figure.hpp"
#include "vellum/illustration/illustration_renderer.hpp"
#include "vellum/io/image_io.hpp"
#include "vellum/render/contact_sheet.hpp"

namespace vellum::cli {
namespace {

struct IllustrateArgs {
  std::string input, shape, style, preset, output, saveStyle, report;
  std::string size = "512x512", interp = "eight", frame = "drawn";
  render::RenderSettings camera = [] {  // the render table's camera and step flags write here
    render::RenderSettings s;
    s.stepVoxels = 1.0;  // distance fields are smooth: a voxel step suffices
    return s;
  }();
  std::vector<double> background;
  bool transparent = false;
  InputOptions in;
  TableRemovalOptions table;
  FigureOptions figure;
};

/// The room the annotations will take (labels: the drawable candidates' texts, both sides).
render::ImageInsets annotationRoom(const FigureOptions& figure, const LabelVolume& segments,
                                   const illustration::Style& style, const render::RenderSettings& settings) {
  if (!figure.any()) return {};
  const render::AnnotationOptions o = figure.resolved(true);
  std::vector<std::string> texts;
  if (o.labels) {
    const std::vector<uint8_t> drawable = illustration::styleDrawnIds(style, segments);
    for (const Label& l : segments.table()) {
      const bool asked = figure.labelIds.empty() ||
                         std::find(figure.labelIds.begin(), figure.labelIds.end(), l.id) != figure.labelIds.end();
      if (asked && l.id < drawable.size() && drawable[l.id]) texts.push_back(render::displayName(o, l.id, l.name));
    }
  }
  return render::annotationInsets(o, settings.width, settings.height, texts);
}

}  // namespace

void demoIllustration(const DemoContext& ctx) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::filesystem::path dir = ctx.outDir / "shape";
  demoShape(ctx, dir);
  illustration::ShapeScene scene = illustration::loadShapeFolder(dir);
  scene.ct = io::loadVolume(ctx.phantomCt).volume;
  auto context = render::GlContext::createHeadless();
  illustration::IllustrationRenderer renderer(*context);
  renderer.setScene(scene);
  illustration::IllustrationSettings s;
  s.render.width = s.render.height = 512;
  s.render.camera.azimuthDeg = 35;
  s.render.camera.elevationDeg = 10;
  s.render.stepVoxels = 1.0;
  // Every plate framed alike: on all the segments, whatever each style draws.
  s.render.camera = illustration::frameFigure(scene.segments, illustration::stylePreset("dvr"), s.render,
                                              illustration::Framing::Segments);
  // The paper's comparison: plain DVR, colour shading, opacity modulation, side by side.
  std::vector<RgbaImage> tiles;
  for (const char* preset : {"dvr", "dvr-colour", "opacity-modulation"}) {
    const illustration::Style style = illustration::stylePreset(preset);
    s.render.background = {style.background[0], style.background[1], style.background[2], 1.f};
    tiles.push_back(renderer.render(style, s));
  }
  io::saveImage(render::contactSheet(tiles, 3), ctx.outDir / "illustration-plate.png");
  // A labelled textbook figure, orthographic so that its scale bar is exact.
  const illustration::Style textbook = illustration::stylePreset("textbook");
  s.render.width = s.render.height = 768;
  s.render.camera = render::Camera{};
  s.render.camera.azimuthDeg = 35;
  s.render.camera.elevationDeg = 10;
  s.render.camera.fieldOfViewDeg = 0;
  FigureOptions annotations;
  annotations.annotateAll = annotations.labelFlag = true;
  annotations.annotations.labelSide = render::AnnotationOptions::LabelSide::Right;
  annotations.labelIds = {2, 3, 4, 5, 6};  // muscle and the bones (skin would hide its own anchor)
  s.render.camera = illustration::frameFigure(scene.segments, textbook, s.render, illustration::Framing::Drawn,
                                              annotationRoom(annotations, scene.segments, textbook, s.render));
  s.render.background = {textbook.background[0], textbook.background[1], textbook.background[2], 1.f};
  RgbaImage figure = renderer.render(textbook, s);
  illustration::LabelSearch search;
  search.ids = annotations.labelIds;
  annotations.apply(figure, scene.distance.geometry(), s.render,
                    illustration::drawnSegmentAnchors(renderer, textbook, s, scene.segments, figure, search));
  io::saveImage(figure, ctx.outDir / "illustration-textbook.png");
  std::cout << "shape folder shape/ + illustration-plate.png (dvr | dvr-colour | opacity-modulation) + "
               "illustration-textbook.png in "
            << secondsSince(t0) << " s\n";
}

void addIllustrateCommand(CLI::App& app) {
  auto a = std::make_shared<IllustrateArgs>();
  std::string presets;
  for (const auto& n : illustration::stylePresetNames()) presets += (presets.empty() ? "" : " | ") + n;
  auto* cmd = app.add_subcommand("illustrate", "Render a shape folder (from `vellum shape`) as an illustration in a style");
  cmd->add_option("input", a->input, "the CT the shape folder was made from")->required();
  cmd->add_option("--shape", a->shape, "shape folder of `vellum shape` (distances.json, distance-<id>.nrrd, segments.nrrd)")->required();
  auto* styleOpt = cmd->add_option("--style", a->style, "style file (JSON, see docs/styles.md)");
  cmd->add_option("--preset", a->preset, "built-in style: " + presets)->excludes(styleOpt);
  cmd->add_option("--out,-o", a->output, "figure path (.png, .tif, .jpg)")->required();
  cmd->add_option("--size", a->size, "image size WxH, up to 4096x4096")->capture_default_str();
  addFlags(*cmd, a->camera, render::renderSettingsTable(),
           {"width", "height", "preset", "window_center", "window_width", "shading", "jitter", "label_blend", "shadows",
            "occlusion", "occlusion_radius", "light_azimuth", "light_elevation", "exposure", "quality", "samples",
            "time_limit", "seed", "bounces", "denoise", "light_size", "fill_light", "sky_light"});
  cmd->add_option("--frame", a->frame,
                  "what --zoom 1 fits: drawn (the segments the style draws) | segments (every segment: the same "
                  "framing for every style) | volume (the volume's bounding sphere)")
      ->capture_default_str();
  cmd->add_option("--interp", a->interp, "eight (gradients by central differences of the interpolated distances) | nearest (forward differences: faster)")
      ->capture_default_str();
  cmd->add_option("--background", a->background, "background colour r g b [a] in 0..1 (default: the style's)")->expected(3, 4);
  cmd->add_flag("--transparent", a->transparent, "transparent background (PNG/TIFF alpha)");
  cmd->add_option("--save-style", a->saveStyle, "also write the style used as JSON (a starting point for your own)");
  cmd->add_option("--report", a->report, "write timings and settings as JSON");
  a->in.addTo(*cmd);
  a->table.addTo(*cmd);
  a->figure.addTo(*cmd, FigureOptions::LabelSource::Input);
  cmd->footer("Example: vellum illustrate knee.nrrd --shape knee-shape --preset textbook --size 1024x1024 --out knee.png");
  cmd->callback([a] {
    const auto t0 = std::chrono::steady_clock::now();
    if (a->style.empty() && a->preset.empty()) throw Error("illustrate: give --style S.json or --preset NAME");
    const illustration::Style style =
        a->style.empty() ? illustration::stylePreset(a->preset) : illustration::loadStyle(a->style);
    illustration::IllustrationSettings s;
    s.render.camera = a->camera.camera;
    s.render.stepVoxels = a->camera.stepVoxels;
    std::tie(s.render.width, s.render.height) = parseSize(a->size);
    s.interpolation = illustration::parseInterpolation(a->interp);
    s.render.background = {style.background[0], style.background[1], style.background[2], 1.f};
    if (!a->background.empty())
      s.render.background = {float(a->background[0]), float(a->background[1]), float(a->background[2]),
                             a->background.size() > 3 ? float(a->background[3]) : 1.f};
    if (a->transparent) s.render.background[3] = 0.f;
    OutputPlan()
        .input(a->input)
        .input(a->shape, "the --shape folder")
        .input(a->style, "the --style file")
        .input(a->figure.labelMap, "the --label-map")
        .output(a->output, "--out")
        .json(a->saveStyle, "--save-style")
        .json(a->report, "--report")
        .check();

    const illustration::Framing framing = illustration::parseFraming(a->frame);
    // A figure framed on its anatomy keeps room for one label column, on the right.
    if (framing != illustration::Framing::Volume) a->figure.annotations.labelSide = render::AnnotationOptions::LabelSide::Right;
    illustration::ShapeScene scene = illustration::loadShapeFolder(a->shape);
    if (a->figure.wantsLabels()) a->figure.checkLabelNames(scene.segments);
    io::LoadedVolume lv = loadWithProgress(a->input, a->in);
    lv.volume = a->table.apply(std::move(lv.volume), a->input);
    if (!geometryOf(lv.volume).approxEqual(scene.distance.geometry()))
      throw FileError(a->shape, "grid " + scene.distance.dims().str() + " does not match the CT " + a->input + " (" +
                                    geometryOf(lv.volume).dims.str() + "): make the shape folder from this CT");
    scene.ct = lv.volume;
    // Zoom 1 fits what the figure shows (--frame), not the volume's bounding sphere, and
    // leaves the annotations their room.
    s.render.camera = illustration::frameFigure(scene.segments, style, s.render, framing,
                                                annotationRoom(a->figure, scene.segments, style, s.render));
    const double loadS = secondsSince(t0);

    auto context = render::GlContext::createHeadless();
    illustration::IllustrationRenderer renderer(*context);
    renderer.setScene(scene);
    RgbaImage image = renderer.render(style, s);
    const double renderMs = renderer.lastRenderMs();  // before the label probes render again
    // A GL draw cannot be interrupted: Ctrl-C during it cancels here, before anything is written.
    Progress::none().checkCancelled();
    // Labels only for segments the figure shows, each where it shows (alone, where it can).
    std::vector<render::StructureAnchor> anchors;
    const auto tl = std::chrono::steady_clock::now();
    if (a->figure.wantsLabels()) {
      illustration::LabelSearch search;
      search.ids = a->figure.labelIds;
      anchors = illustration::drawnSegmentAnchors(renderer, style, s, scene.segments, image, search);
    }
    const render::AnnotationLayout layout = a->figure.apply(image, scene.distance.geometry(), s.render, anchors);
    const double annotateS = secondsSince(tl);
    RunOutputs outputs;
    ensureParentFolder(a->output);
    io::saveImage(image, a->output);
    outputs.wrote(a->output);
    if (!a->saveStyle.empty()) {
      illustration::saveStyle(style, a->saveStyle);
      outputs.wrote(a->saveStyle);
    }
    std::cout << a->output << "  " << style.name << "  " << s.render.width << "x" << s.render.height << "  "
              << illustration::interpolationName(s.interpolation) << "  " << renderMs << " ms\n";
    if (!a->report.empty()) {
      nlohmann::json r;
      r["input"] = a->input;
      r["shape"] = a->shape;
      r["style"] = style.name;
      r["output"] = a->output;
      r["size"] = {s.render.width, s.render.height};
      r["interpolation"] = illustration::interpolationName(s.interpolation);
      const auto& cam = s.render.camera;
      r["camera"] = {{"azimuth", cam.azimuthDeg}, {"elevation", cam.elevationDeg}, {"zoom", a->camera.camera.zoom},
                     {"fov", cam.fieldOfViewDeg}, {"frame", illustration::framingName(framing)},
                     {"zoom_applied", cam.zoom}, {"pan_applied_mm", toJson(cam.panMm)}};
      r["labels"] = layout.labelTexts;
      a->table.addToReport(r);
      r["dims"] = {scene.distance.dims().x, scene.distance.dims().y, scene.distance.dims().z};
      r["load_seconds"] = loadS;
      r["upload_ms"] = renderer.lastUploadMs();
      r["render_ms"] = renderMs;
      r["annotate_seconds"] = annotateS;  // labels: probe renders and anchors
      r["renderer"] = context->renderer();
      r["total_seconds"] = secondsSince(t0);
      app::RunReport shared(commandLine(), t0);
      shared.input(a->input, "volume");
      shared.input(a->shape, "shape folder");
      shared.input(a->style, "style");
      shared.output(a->output);
      if (!a->saveStyle.empty()) shared.output(a->saveStyle);
      shared.stamp(r);
      writeJsonFile(r, a->report);
    }
    outputs.commit();
  });
}

}  // namespace vellum::cli
