// `vellum illustrate IN --shape DIR (--style S.json | --preset NAME) --out FIG.png [...]`
#include <iostream>
#include <memory>

#include "cli_util.hpp"
#include "commands.hpp"
#include "vellum/core/error.hpp"
#include "vellum/illustration/illustration_renderer.hpp"
#include "vellum/io/image_io.hpp"

namespace vellum::cli {
namespace {

struct IllustrateArgs {
  std::string input, shape, style, preset, output, saveStyle, report;
  std::string size = "512x512", interp = "eight";
  double azimuth = 30, elevation = 15, zoom = 1, fov = 30, step = 1.0;
  std::vector<double> background;
  bool transparent = false;
  InputOptions in;
};

}  // namespace

void addIllustrateCommand(CLI::App& app) {
  auto a = std::make_shared<IllustrateArgs>();
  std::string presets;
  for (const auto& n : illustration::stylePresetNames()) presets += (presets.empty() ? "" : " | ") + n;
  auto* cmd = app.add_subcommand("illustrate", "Render a shape folder (from `vellum shape`) as an illustration in a style");
  cmd->add_option("input", a->input, "the CT the shape folder was made from")->required();
  cmd->add_option("--shape", a->shape, "shape folder with distance.nrrd and segments.nrrd")->required();
  auto* styleOpt = cmd->add_option("--style", a->style, "style file (JSON, see docs/styles.md)");
  cmd->add_option("--preset", a->preset, "built-in style: " + presets)->excludes(styleOpt);
  cmd->add_option("--out,-o", a->output, "figure path (.png, .tif, .jpg)")->required();
  cmd->add_option("--size", a->size, "image size WxH, up to 4096x4096")->capture_default_str();
  cmd->add_option("--azimuth", a->azimuth, "camera azimuth in degrees about the superior axis")->capture_default_str();
  cmd->add_option("--elevation", a->elevation, "camera elevation in degrees")->capture_default_str();
  cmd->add_option("--zoom", a->zoom, "zoom factor (1 = whole volume)")->capture_default_str();
  cmd->add_option("--fov", a->fov, "vertical field of view in degrees (0 = orthographic)")->capture_default_str();
  cmd->add_option("--interp", a->interp, "eight (styled colour at the 8 voxel centres, interpolated) | nearest (fast)")
      ->capture_default_str();
  cmd->add_option("--step", a->step, "ray step in voxels")->capture_default_str();
  cmd->add_option("--background", a->background, "background colour r g b [a] in 0..1 (default: the style's)")->expected(3, 4);
  cmd->add_flag("--transparent", a->transparent, "transparent background (PNG/TIFF alpha)");
  cmd->add_option("--save-style", a->saveStyle, "also write the style used as JSON (a starting point for your own)");
  cmd->add_option("--report", a->report, "write timings and settings as JSON");
  a->in.addTo(*cmd);
  cmd->footer("Example: vellum illustrate knee.nrrd --shape knee-shape --preset textbook --size 1024x1024 --out knee.png");
  cmd->callback([a] {
    const auto t0 = std::chrono::steady_clock::now();
    if (a->style.empty() && a->preset.empty()) throw Error("illustrate: give --style S.json or --preset NAME");
    const illustration::Style style =
        a->style.empty() ? illustration::stylePreset(a->preset) : illustration::loadStyle(a->style);
    illustration::IllustrationSettings s;
    std::tie(s.render.width, s.render.height) = parseSize(a->size);
    s.render.camera.azimuthDeg = a->azimuth;
    s.render.camera.elevationDeg = a->elevation;
    s.render.camera.zoom = a->zoom;
    s.render.camera.fieldOfViewDeg = a->fov;
    s.render.stepVoxels = a->step;
    s.interpolation = illustration::parseInterpolation(a->interp);
    s.render.background = {style.background[0], style.background[1], style.background[2], 1.f};
    if (!a->background.empty())
      s.render.background = {float(a->background[0]), float(a->background[1]), float(a->background[2]),
                             a->background.size() > 3 ? float(a->background[3]) : 1.f};
    if (a->transparent) s.render.background[3] = 0.f;
    refuseOverwritingInput(a->input, a->output);
    refuseOverwritingInput(a->shape, a->output);

    illustration::ShapeScene scene = illustration::loadShapeFolder(a->shape);
    const io::LoadedVolume lv = loadWithProgress(a->input, a->in);
    if (!geometryOf(lv.volume).approxEqual(scene.distance.geometry()))
      throw FileError(a->shape, "grid " + scene.distance.dims().str() + " does not match the CT " + a->input + " (" +
                                    geometryOf(lv.volume).dims.str() + "): make the shape folder from this CT");
    scene.ct = lv.volume;
    const double loadS = secondsSince(t0);

    auto context = render::GlContext::createHeadless();
    illustration::IllustrationRenderer renderer(*context);
    renderer.setScene(scene);
    const RgbaImage image = renderer.render(style, s);
    ensureParentFolder(a->output);
    io::saveImage(image, a->output);
    if (!a->saveStyle.empty()) illustration::saveStyle(style, a->saveStyle);
    std::cout << a->output << "  " << style.name << "  " << s.render.width << "x" << s.render.height << "  "
              << illustration::interpolationName(s.interpolation) << "  " << renderer.lastRenderMs() << " ms\n";
    if (!a->report.empty()) {
      nlohmann::json r;
      r["input"] = a->input;
      r["shape"] = a->shape;
      r["style"] = style.name;
      r["output"] = a->output;
      r["size"] = {s.render.width, s.render.height};
      r["interpolation"] = illustration::interpolationName(s.interpolation);
      r["camera"] = {{"azimuth", a->azimuth}, {"elevation", a->elevation}, {"zoom", a->zoom}, {"fov", a->fov}};
      r["dims"] = {scene.distance.dims().x, scene.distance.dims().y, scene.distance.dims().z};
      r["load_seconds"] = loadS;
      r["upload_ms"] = renderer.lastUploadMs();
      r["render_ms"] = renderer.lastRenderMs();
      r["renderer"] = context->renderer();
      r["total_seconds"] = secondsSince(t0);
      writeJsonFile(r, a->report);
    }
  });
}

}  // namespace vellum::cli
