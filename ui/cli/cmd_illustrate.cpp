// `vellum illustrate IN --shape DIR (--style S.json | --preset NAME[,NAME..]) [--view V[,V..]]
// [--plate] --out FIG.png [...]`. The work is app::runIllustrate (illustrate_pipeline.hpp); this
// file binds the flags and prints, and draws the demo's plates.
#include <iostream>
#include <memory>
#include <set>

#include "cli_params.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "vellum/app/illustrate_pipeline.hpp"
#include "vellum/core/error.hpp"
#include "vellum/illustration/figure.hpp"
#include "vellum/illustration/illustration_renderer.hpp"
#include "vellum/io/image_io.hpp"
#include "vellum/render/contact_sheet.hpp"

namespace vellum::cli {
namespace {

/// The flags: the app request's fields, and the texts parsed into it.
struct IllustrateArgs {
  app::IllustrateRequest request;
  std::string preset, views, size = "512x512", interp = "eight", frame = "drawn", lightPreset;
  render::RenderSettings camera = [] {  // the render table's camera and step flags write here
    render::RenderSettings s;
    s.stepVoxels = 1.0;  // distance fields are smooth: a voxel step suffices
    return s;
  }();
  std::vector<double> background, pan;
  InputOptions in;
  TableRemovalOptions table;
  FigureOptions figure;
};

void runIllustrate(const IllustrateArgs& a) {
  app::IllustrateRequest r = a.request;
  if (!a.preset.empty()) r.presets = app::splitList(a.preset, "--preset");
  if (!a.views.empty())
    for (const auto& v : app::splitList(a.views, "--view")) r.views.push_back(app::parseView(v, a.camera.camera.elevationDeg));
  illustration::IllustrationSettings& s = r.settings;
  s.render.camera = a.camera.camera;
  if (!a.pan.empty()) s.render.camera.panMm = {a.pan[0], a.pan[1], a.pan[2]};
  s.render.stepVoxels = a.camera.stepVoxels;
  s.render.lighting = a.camera.lighting;  // the optional lighting layer (off unless asked)
  if (!a.lightPreset.empty()) r.lightPreset = render::parsePreset(a.lightPreset);
  std::tie(s.render.width, s.render.height) = parseSize(a.size);
  s.interpolation = illustration::parseInterpolation(a.interp);
  if (!a.background.empty())
    r.background = backgroundColour(a.background);
  r.framing = illustration::parseFraming(a.frame);
  r.annotations = a.figure.resolved(a.figure.wantsLabels());
  r.labelIds = a.figure.labelIds;
  r.load = a.in.toLoadOptions(nullptr);
  if (a.table.enabled) r.removeTable = a.table.params;
  r.commandLine = commandLine();
  ProgressBar bar;
  const app::IllustrateResult result = app::runIllustrate(r, bar.progress());
  bar.finish();
  printLoadWarnings(r.input, result.warnings);
  if (!result.tableRemoval.empty()) std::cerr << result.tableRemoval << "\n";
  for (const auto& f : result.figures)
    std::cout << f.path.string() << "  " << f.style << (f.view.empty() ? "" : "  ") << f.view << "  "
              << s.render.width << "x" << s.render.height << "  " << illustration::interpolationName(s.interpolation)
              << "  " << f.renderMs << " ms\n";
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
                                              app::annotationRoom(annotations.resolved(true), annotations.labelIds,
                                                                  scene.segments, textbook, s.render));
  s.render.background = {textbook.background[0], textbook.background[1], textbook.background[2], 1.f};
  RgbaImage figure = renderer.render(textbook, s);
  illustration::LabelSearch search;
  search.ids = annotations.labelIds;
  annotations.apply(figure, scene.grid(), s.render,
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
  app::IllustrateRequest& r = a->request;
  cmd->add_option("input", r.input, "the CT the shape folder was made from")->required();
  cmd->add_option("--shape", r.shape, "shape folder of `vellum shape` (distances.json, distance-<id>.nrrd, segments.nrrd)")->required();
  auto* styleOpt = cmd->add_option("--style", r.style, "style file (JSON, see docs/styles.md)");
  cmd->add_option("--preset", a->preset,
                  "built-in style: " + presets + "; or a comma list of them (one figure each from one upload, suffixed -PRESET)")
      ->excludes(styleOpt);
  cmd->add_option("--view", a->views,
                  "anterior | posterior | left | right | lateral (= left) | superior | inferior | AZ | AZ:EL "
                  "(degrees), or a comma list: one figure each from one upload, suffixed -VIEW (overrides "
                  "--azimuth/--elevation)");
  cmd->add_flag("--plate", r.plate, "one contact sheet at --out instead of a file each: a row per style, a column per view");
  cmd->add_option("--out,-o", r.output, "figure path (.png, .tif, .jpg)")->required();
  cmd->add_option("--size", a->size, "image size WxH, up to 4096x4096")->capture_default_str();
  // The camera, the ray step and the lighting layer's terms: the rest of the render table
  // (transfer function, quality) is the volume renderer's; the style does that here.
  std::set<std::string> notHere;
  for (const auto& field : render::renderSettingsTable())
    if (!std::set<std::string>{"azimuth", "elevation", "zoom", "fov", "step", "shadows", "occlusion", "occlusion_radius",
                               "light_azimuth", "light_elevation", "exposure", "tone_map"}
             .count(field.key))
      notHere.insert(field.key);
  addFlags(*cmd, a->camera, render::renderSettingsTable(), notHere);
  cmd->add_option("--light-preset", a->lightPreset,
                  "with --shadows/--occlusion/--tone-map: the render preset whose opacity casts the shadows and "
                  "whose surface is lit (bone | soft-tissue | skin; default bone; docs/lighting.md)");
  cmd->add_option("--pan", a->pan, "shift of the look-at point in mm (x y z), after the framing")->expected(3);
  cmd->add_option("--frame", a->frame,
                  "what --zoom 1 fits: drawn (the segments the style draws) | segments (every segment: the same "
                  "framing for every style) | volume (the volume's bounding sphere)")
      ->capture_default_str();
  cmd->add_option("--interp", a->interp, "eight (gradients by central differences of the interpolated distances) | nearest (forward differences: faster)")
      ->capture_default_str();
  cmd->add_option("--background", a->background, "background colour r g b [a] in 0..1 (default: the style's)")->expected(3, 4);
  cmd->add_flag("--transparent", r.transparent, "transparent background (PNG/TIFF alpha)");
  cmd->add_option("--save-style", r.saveStyle, "also write the style used as JSON (a starting point for your own)");
  cmd->add_option("--report", r.report, "write timings and settings as JSON");
  a->in.addTo(*cmd);
  a->table.addTo(*cmd);
  a->figure.addTo(*cmd, FigureOptions::LabelSource::Input);
  cmd->footer("Examples:\n"
              "  vellum illustrate knee.nrrd --shape knee-shape --preset textbook --size 1024x1024 --out knee.png\n"
              "  vellum illustrate knee.nrrd --shape knee-shape --preset textbook,pen,x-ray --view anterior,lateral "
              "--out figs/knee.png (knee-textbook-anterior.png ...; --plate: one sheet)");
  cmd->callback([a] { runIllustrate(*a); });
}

}  // namespace vellum::cli
