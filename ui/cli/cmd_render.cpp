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
  FigureFlags frame;  ///< --view, --plate, --size, --pan, --background, --transparent
  InputOptions in;
  TableRemovalOptions table;
  FigureOptions figure;
};

/// `render`'s own flag besides the tables it shares, described once (docs/parameters.md).
const params::Table<RenderArgs>& renderFlagsTable() {
  static const params::Table<RenderArgs> t{
      params::text<RenderArgs>("preset", &RenderArgs::preset,
                               {"Presets", "bone | soft-tissue | skin | mip, a comma list of them, or all (one figure "
                                           "each from one upload, suffixed -PRESET)", ""}),
  };
  return t;
}

void runRender(const RenderArgs& a) {
  app::RenderRequest r = a.request;
  r.presets.clear();
  if (a.preset == "all") r.presets = render::allPresets();
  else
    for (const auto& name : app::splitList(a.preset, "--preset")) r.presets.push_back(render::parsePreset(name));
  r.views = a.frame.views(r.settings.camera.elevationDeg);
  r.plate = a.frame.plate;
  render::RenderSettings& s = r.settings;
  std::tie(s.width, s.height) = a.frame.sizePixels();
  s.camera.panMm = {a.frame.pan[0], a.frame.pan[1], a.frame.pan[2]};
  if (const auto bg = a.frame.backgroundColour()) s.background = *bg;
  if (a.frame.transparent) s.background[3] = 0.f;
  r.labelMap = a.figure.labelMap;
  a.figure.setAnnotations(r);
  setVolumeInput(r, a.in, &a.table);
  const app::RenderResult result = runPipeline(r, app::runRender);
  for (const auto& f : result.figures)
    std::cout << f.path.string() << "  " << render::presetName(f.preset) << (f.view.empty() ? "" : "  ") << f.view
              << "  " << s.width << "x" << s.height << "  " << f.drawMs << " ms"
              << (f.samples ? "  " + std::to_string(f.samples) + " samples" : std::string()) << "\n";
}

}  // namespace

std::string renderFlagsMarkdown() { return params::markdown(renderFlagsTable()); }

void addRenderCommand(CLI::App& app) {
  auto a = std::make_shared<RenderArgs>();
  app::RenderRequest& r = a->request;
  auto* cmd = app.add_subcommand("render", "Render a volume through the GL ray caster into a PNG/TIFF figure");
  addInput(*cmd, "input", r.input, "volume file or DICOM folder")->required();
  addOutput(*cmd, "--out,-o", r.output, "figure path (.png, .tif, .jpg)")->required();
  addFlags(*cmd, *a, renderFlagsTable());  // --preset
  a->frame.addTo(*cmd);
  addFlags(*cmd, r.settings, render::renderSettingsTable(), {"width", "height", "preset"});
  addInput(*cmd, "--label-colours", r.labelColours,
                  "label map whose table colours tint the volume by --label-blend (default blend 0.5; "
                  "without this option --label-map's colours are used)");
  addInput(*cmd, "--attributes", r.attributes,
                  "attribute field of `vellum deform --attributes-out` for this (deformed) volume: colour shifts "
                  "and density drawn as in the live deformed render");
  addOutput(*cmd, "--report", r.report,
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
