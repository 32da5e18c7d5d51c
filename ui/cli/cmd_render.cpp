// `vellum render IN --out FIG.png [--preset P[,P..]|all] [--view V[,V..]] [--plate] [--size WxH]
// [render settings, background]`. The work is app::runRender (render_pipeline.hpp); this file
// binds the flags (the render settings from their table) and prints.
#include <iostream>
#include <memory>

#include "cli_params.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "vellum/app/render_pipeline.hpp"
#include "vellum/core/error.hpp"

namespace vellum::cli {
namespace {

struct RenderArgs {
  app::RenderRequest request;
  std::string preset = render::presetName(render::RenderSettings{}.preset);
  std::string views;
  std::string size = "512x512";
  std::vector<double> pan, background;
  bool transparent = false;
  InputOptions in;
  TableRemovalOptions table;
  FigureOptions figure;
};

void runRender(const RenderArgs& a) {
  app::RenderRequest r = a.request;
  r.presets.clear();
  if (a.preset == "all") r.presets = render::allPresets();
  else
    for (const auto& name : app::splitList(a.preset, "--preset")) r.presets.push_back(render::parsePreset(name));
  if (!a.views.empty())
    for (const auto& v : app::splitList(a.views, "--view")) r.views.push_back(app::parseView(v, r.settings.camera.elevationDeg));
  render::RenderSettings& s = r.settings;
  std::tie(s.width, s.height) = parseSize(a.size);
  if (!a.pan.empty()) s.camera.panMm = {a.pan[0], a.pan[1], a.pan[2]};
  if (!a.background.empty())
    s.background = backgroundColour(a.background);
  if (a.transparent) s.background[3] = 0.f;
  r.labelMap = a.figure.labelMap;
  r.annotations = a.figure.resolved(a.figure.wantsLabels());
  r.labelIds = a.figure.labelIds;
  r.load = a.in.toLoadOptions(nullptr);
  if (a.table.enabled) r.removeTable = a.table.params;
  r.commandLine = commandLine();
  ProgressBar bar;
  const app::RenderResult result = app::runRender(r, bar.progress());
  bar.finish();
  printLoadWarnings(r.input, result.warnings);
  if (!result.tableRemoval.empty()) std::cerr << result.tableRemoval << "\n";
  for (const auto& f : result.figures)
    std::cout << f.path.string() << "  " << render::presetName(f.preset) << (f.view.empty() ? "" : "  ") << f.view
              << "  " << s.width << "x" << s.height << "  " << f.drawMs << " ms"
              << (f.samples ? "  " + std::to_string(f.samples) + " samples" : std::string()) << "\n";
}

}  // namespace

void addRenderCommand(CLI::App& app) {
  auto a = std::make_shared<RenderArgs>();
  app::RenderRequest& r = a->request;
  auto* cmd = app.add_subcommand("render", "Render a volume through the GL ray caster into a PNG/TIFF figure");
  cmd->add_option("input", r.input, "volume file or DICOM folder")->required();
  cmd->add_option("--out,-o", r.output, "figure path (.png, .tif, .jpg)")->required();
  cmd->add_option("--preset", a->preset,
                  "bone | soft-tissue | skin | mip, a comma list of them, or all (one figure each from one upload, "
                  "suffixed -PRESET)")
      ->capture_default_str();
  cmd->add_option("--view", a->views,
                  "anterior | posterior | left | right | lateral (= left) | superior | inferior | AZ | AZ:EL "
                  "(degrees), or a comma list: one figure each from one upload, suffixed -VIEW (overrides "
                  "--azimuth/--elevation)");
  cmd->add_flag("--plate", r.plate, "one contact sheet at --out instead of a file each: a row per preset, a column per view");
  cmd->add_option("--size", a->size, "image size WxH, up to 4096x4096")->capture_default_str();
  addFlags(*cmd, r.settings, render::renderSettingsTable(), {"width", "height", "preset"});
  cmd->add_option("--pan", a->pan, "shift of the look-at point in mm (x y z)")->expected(3);
  cmd->add_option("--background", a->background, "background colour r g b [a] in 0..1")->expected(3, 4);
  cmd->add_flag("--transparent", a->transparent, "transparent background (PNG/TIFF alpha)");
  cmd->add_option("--label-colours", r.labelColours,
                  "label map whose table colours tint the volume by --label-blend (default blend 0.5; "
                  "without this option --label-map's colours are used)");
  cmd->add_option("--attributes", r.attributes,
                  "attribute field of `vellum deform --attributes-out` for this (deformed) volume: colour shifts "
                  "and density drawn as in the live deformed render");
  cmd->add_option("--report", r.report,
                  "write a JSON report: version, command, inputs and outputs with fingerprints, settings, timings, memory");
  a->in.addTo(*cmd);
  a->table.addTo(*cmd);
  a->figure.addTo(*cmd, FigureOptions::LabelSource::File);
  cmd->footer("Examples:\n"
              "  vellum render knee.nrrd --preset all --size 1024x1024 --out figs/knee.png\n"
              "  vellum render knee.nrrd --preset bone,skin --view anterior,lateral --out figs/knee.png "
              "(knee-bone-anterior.png ...)");
  cmd->callback([a] { runRender(*a); });
}

}  // namespace vellum::cli
