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
  std::string preset, lightPreset;
  illustration::Interpolation interp = illustration::Interpolation::Eight;
  illustration::Framing frame = illustration::Framing::Drawn;
  int refineLevels = 2;          ///< IllustrationSettings::refineLevels (the library's default is 0)
  double refineTolerance = 4.0;  ///< in 8-bit levels
  FigureFlags figureFlags;  ///< --view, --plate, --size, --pan, --background, --transparent
  render::RenderSettings camera = [] {  // the render table's camera and step flags write here
    render::RenderSettings s;
    s.stepVoxels = 1.0;  // distance fields are smooth: a voxel step suffices
    return s;
  }();
  InputOptions in;
  TableRemovalOptions table;
  FigureOptions figure;
};

void runIllustrate(const IllustrateArgs& a) {
  app::IllustrateRequest r = a.request;
  if (!a.preset.empty()) r.presets = app::splitList(a.preset, "--preset");
  const FigureFlags& f = a.figureFlags;
  r.views = f.views(a.camera.camera.elevationDeg);
  r.plate = f.plate;
  r.transparent = f.transparent;
  illustration::IllustrationSettings& s = r.settings;
  s.render.camera = a.camera.camera;
  s.render.camera.panMm = {f.pan[0], f.pan[1], f.pan[2]};
  s.render.stepVoxels = a.camera.stepVoxels;
  s.render.lighting = a.camera.lighting;  // the optional lighting layer (off unless asked)
  if (!a.lightPreset.empty()) r.lightPreset = render::parsePreset(a.lightPreset);
  std::tie(s.render.width, s.render.height) = f.sizePixels();
  s.interpolation = a.interp;
  s.refineLevels = a.refineLevels;
  s.refineTolerance = float(a.refineTolerance / 255.0);
  if (const auto bg = f.backgroundColour()) r.background = *bg;
  r.framing = a.frame;
  a.figure.setAnnotations(r);
  setVolumeInput(r, a.in, &a.table);
  const app::IllustrateResult result = runPipeline(r, app::runIllustrate);
  for (const auto& f : result.figures)
    std::cout << f.path.string() << "  " << f.style << (f.view.empty() ? "" : "  ") << f.view << "  "
              << s.render.width << "x" << s.render.height << "  " << illustration::interpolationName(s.interpolation)
              << "  " << f.renderMs << " ms\n";
}

/// `illustrate`'s own flags besides the tables it shares, described once (docs/parameters.md).
const params::Table<IllustrateArgs>& illustrateFlagsTable() {
  using A = IllustrateArgs;
  static const std::string presets = [] {
    std::string names;
    for (const auto& n : illustration::stylePresetNames()) names += (names.empty() ? "" : " | ") + n;
    return names;
  }();
  static const params::Table<A> t{
      params::text<A>("preset", &A::preset,
                      {"Style presets", "a built-in style (" + presets + "), or a comma list of them (one figure "
                                        "each from one upload, suffixed -PRESET)", ""}),
      params::text<A>("light_preset", &A::lightPreset,
                      {"Light preset", "with --shadows/--occlusion/--tone-map: the render preset whose opacity casts "
                                       "the shadows and whose surface is lit (bone | soft-tissue | skin; empty: bone; "
                                       "docs/lighting.md)", ""}),
      params::choice<A>("frame", &A::frame, illustration::framings().names,
                        {"Framing", "what --zoom 1 fits: drawn (the segments the style draws) | segments (every "
                                    "segment: the same framing for every style) | volume (the volume's bounding "
                                    "sphere)", ""}),
      params::choice<A>("interp", &A::interp, illustration::interpolations().names,
                        {"Interpolation", "eight (gradients by central differences of the interpolated distances) | "
                                          "nearest (forward differences: faster)", ""}),
      params::integer<A>("refine_levels", &A::refineLevels,
                         {"Refinement levels", "trace every 2^N-th pixel first, then halve the spacing where "
                                               "neighbours differ, near ink lines and at edges, and interpolate the "
                                               "smooth rest; 0 = a ray through every pixel (exact)", "", 0, 4}),
      params::real<A>("refine_tolerance", &A::refineTolerance,
                      {"Refinement tolerance", "with --refine-levels: neighbours whose colours differ by more than "
                                               "8x this, or curve by more than this, are traced, not interpolated",
                       "8-bit levels", 0, 64}),
  };
  return t;
}

}  // namespace

std::string illustrateFlagsMarkdown() { return params::markdown(illustrateFlagsTable()); }

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
  auto* cmd = app.add_subcommand("illustrate", "Render a shape folder (from `vellum shape`) as an illustration in a style");
  app::IllustrateRequest& r = a->request;
  addInput(*cmd, "input", r.input, "the CT the shape folder was made from")->required();
  addInput(*cmd, "--shape", r.shape, "shape folder of `vellum shape` (distances.json, distance-<id>.nrrd, segments.nrrd)")->required();
  auto* styleOpt = addInput(*cmd, "--style", r.style, "style file (JSON, see docs/styles.md)");
  addFlags(*cmd, *a, illustrateFlagsTable(), {"light_preset", "frame", "interp", "refine_levels", "refine_tolerance"}).at("preset")->excludes(styleOpt);
  addOutput(*cmd, "--out,-o", r.output, "figure path (.png, .tif, .jpg)")->required();
  a->figureFlags.addTo(*cmd);
  // The camera, the ray step and the lighting layer's terms: the rest of the render table
  // (transfer function, quality) is the volume renderer's; the style does that here.
  std::set<std::string> notHere;
  for (const auto& field : render::renderSettingsTable())
    if (!std::set<std::string>{"azimuth", "elevation", "zoom", "fov", "step", "shadows", "occlusion", "occlusion_radius",
                               "light_azimuth", "light_elevation", "exposure", "tone_map"}
             .count(field.key))
      notHere.insert(field.key);
  addFlags(*cmd, a->camera, render::renderSettingsTable(), notHere);
  addFlags(*cmd, *a, illustrateFlagsTable(), {"preset"});  // --light-preset, --frame, --interp, --refine-*
  addOutput(*cmd, "--save-style", r.saveStyle, "also write the style used as JSON (a starting point for your own)");
  addOutput(*cmd, "--report", r.report, "write timings and settings as JSON");
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
