// `vellum render IN --out FIG.png [--preset P|all] [--size WxH] [render settings, background]`
#include <iostream>
#include <memory>

#include "cli_params.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "vellum/app/run_report.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/params_json.hpp"
#include "vellum/deformation/map_file.hpp"
#include "vellum/io/image_io.hpp"
#include "vellum/render/volume_renderer.hpp"

namespace vellum::cli {
namespace {

struct RenderArgs {
  std::string input, output, attributes, labelColours, report;
  std::string preset = render::presetName(render::RenderSettings{}.preset);
  std::string size = "512x512";
  render::RenderSettings settings;  ///< the table's flags write here
  std::vector<double> pan, background;
  bool transparent = false;
  InputOptions in;
  TableRemovalOptions table;
  FigureOptions figure;
};

/// --out for one preset: "fig.png", or "fig-bone.png" ... when several presets are drawn.
std::filesystem::path figurePath(const std::filesystem::path& out, const std::vector<render::Preset>& presets,
                                 render::Preset p) {
  if (presets.size() == 1) return out;
  return out.parent_path() / (out.stem().string() + "-" + render::presetName(p) + out.extension().string());
}

/// The identity map carrying an attribute field written by `vellum deform --attributes-out`
/// for a volume of geometry `volume` (its control grid: same origin and direction).
render::BackwardMap attributeFieldMap(const std::string& path, const Geometry& volume) {
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

}  // namespace

void addRenderCommand(CLI::App& app) {
  auto a = std::make_shared<RenderArgs>();
  auto* cmd = app.add_subcommand("render", "Render a volume through the GL ray caster into a PNG/TIFF figure");
  cmd->add_option("input", a->input, "volume file or DICOM folder")->required();
  cmd->add_option("--out,-o", a->output, "figure path (.png, .tif, .jpg)")->required();
  cmd->add_option("--preset", a->preset, "bone | soft-tissue | skin | mip | all (one figure each, suffixed)")
      ->capture_default_str();
  cmd->add_option("--size", a->size, "image size WxH, up to 4096x4096")->capture_default_str();
  addFlags(*cmd, a->settings, render::renderSettingsTable(), {"width", "height", "preset"});
  cmd->add_option("--pan", a->pan, "shift of the look-at point in mm (x y z)")->expected(3);
  cmd->add_option("--background", a->background, "background colour r g b [a] in 0..1")->expected(3, 4);
  cmd->add_flag("--transparent", a->transparent, "transparent background (PNG/TIFF alpha)");
  cmd->add_option("--label-colours", a->labelColours,
                  "label map whose table colours tint the volume by --label-blend (default blend 0.5; "
                  "without this option --label-map's colours are used)");
  cmd->add_option("--attributes", a->attributes,
                  "attribute field of `vellum deform --attributes-out` for this (deformed) volume: colour shifts "
                  "and density drawn as in the live deformed render");
  cmd->add_option("--report", a->report,
                  "write a JSON report: version, command, inputs and outputs with fingerprints, settings, timings, memory");
  a->in.addTo(*cmd);
  a->table.addTo(*cmd);
  a->figure.addTo(*cmd, FigureOptions::LabelSource::File);
  cmd->footer("Example: vellum render knee.nrrd --preset all --size 1024x1024 --out figs/knee.png");
  cmd->callback([a] {
    const std::vector<render::Preset> presets =
        a->preset == "all" ? render::allPresets() : std::vector{render::parsePreset(a->preset)};
    OutputPlan plan;
    plan.input(a->input)
        .input(a->figure.labelMap, "the --label-map")
        .input(a->labelColours, "the --label-colours map")
        .input(a->attributes, "the --attributes field");
    for (render::Preset p : presets) plan.output(figurePath(a->output, presets, p), "--out");
    plan.json(a->report, "--report");
    plan.check();
    app::RunReport run(commandLine());
    run.input(a->input, "volume");
    run.input(a->figure.labelMap, "label map");
    run.input(a->labelColours, "label colours");
    run.input(a->attributes, "attribute field");
    io::LoadedVolume lv = loadWithProgress(a->input, a->in);
    run.loaded(a->input, lv);
    run.mark("load");
    lv.volume = a->table.apply(std::move(lv.volume), a->input);
    render::RenderSettings s = a->settings;
    std::tie(s.width, s.height) = parseSize(a->size);
    if (!a->pan.empty()) s.camera.panMm = {a->pan[0], a->pan[1], a->pan[2]};
    if (!a->background.empty())
      s.background = {float(a->background[0]), float(a->background[1]), float(a->background[2]),
                      a->background.size() > 3 ? float(a->background[3]) : 1.f};
    if (a->transparent) s.background[3] = 0.f;
    std::optional<LabelVolume> labels;
    if (!a->figure.labelMap.empty()) {
      labels = a->in.loadLabelsOnInputGrid(a->figure.labelMap);
      if (!labels->geometry().approxEqual(geometryOf(lv.volume), 1e-3))
        throw FileError(a->figure.labelMap, "label map grid " + labels->geometry().dims.str() + " differs from the volume's");
    }
    const std::optional<render::BackwardMap> attributeMap =
        a->attributes.empty() ? std::nullopt : std::optional(attributeFieldMap(a->attributes, geometryOf(lv.volume)));
    auto context = render::GlContext::createHeadless();
    render::VolumeRenderer renderer(*context);
    renderer.setVolume(lv.volume);
    if (attributeMap) renderer.setBackwardMap(&*attributeMap);
    // Label colours tint the volume (the studio's "Label colours"): --label-colours, or with
    // --label-blend alone the --label-map's colours.
    if (!a->labelColours.empty() && s.labelBlend == 0) s.labelBlend = 0.5;
    if (s.labelBlend > 0) {
      std::optional<LabelVolume> colours;
      if (!a->labelColours.empty()) {
        colours = a->in.loadLabelsOnInputGrid(a->labelColours);
        if (!colours->geometry().approxEqual(geometryOf(lv.volume), 1e-3))
          throw FileError(a->labelColours, "label map grid " + colours->geometry().dims.str() + " differs from the volume's");
      }
      const LabelVolume* source = colours ? &*colours : labels ? &*labels : nullptr;
      if (!source) throw Error("--label-blend needs --label-colours (the labels whose colours tint the volume)");
      const render::LabelTint tint = render::makeLabelTint(*source);
      renderer.setLabelTint(&tint);
    }
    // The frame's box is the map's node grid when one is set (the annotations must use it too).
    const Geometry& frameBox = attributeMap ? attributeMap->grid : geometryOf(lv.volume);
    ensureParentFolder(a->output);
    RunOutputs outputs;  // Ctrl-C between presets leaves no figure of this run
    nlohmann::json figures = nlohmann::json::array();
    run.mark("prepare");
    for (render::Preset p : presets) {
      s.preset = p;
      RgbaImage image = renderer.render(s);
      // A GL draw cannot be interrupted: Ctrl-C during it cancels here, before anything is written.
      Progress::none().checkCancelled();
      a->figure.apply(image, frameBox, s, labels ? &*labels : nullptr);
      const auto path = figurePath(a->output, presets, p);
      io::saveImage(image, path);
      outputs.wrote(path);
      run.mark(std::string("render ") + render::presetName(p));
      run.output(path);
      figures.push_back({{"path", path.string()}, {"preset", render::presetName(p)}, {"draw_ms", renderer.lastRenderMs()}});
      const bool cinematic = s.quality == render::Quality::Cinematic && p != render::Preset::Mip;
      if (cinematic) figures.back()["samples"] = renderer.lastSamples();
      std::cout << path.string() << "  " << render::presetName(p) << "  " << s.width << "x" << s.height
                << "  " << renderer.lastRenderMs() << " ms"
                << (cinematic ? "  " + std::to_string(renderer.lastSamples()) + " samples" : std::string()) << "\n";
    }
    if (!a->report.empty()) {
      nlohmann::json report = {{"figures", figures}, {"settings", params::toJson(render::renderSettingsTable(), s)}};
      run.stamp(report);
      app::writeJsonFile(report, a->report);
    }
    outputs.commit();
  });
}

}  // namespace vellum::cli
