// `vellum render IN --out FIG.png [--preset P|all] [--size WxH] [camera, window, background]`
#include <iostream>
#include <memory>

#include "cli_util.hpp"
#include "commands.hpp"
#include "vellum/core/error.hpp"
#include "vellum/io/image_io.hpp"
#include "vellum/render/volume_renderer.hpp"

namespace vellum::cli {
namespace {

struct RenderArgs {
  std::string input, output;
  std::string preset = "soft-tissue";
  std::string size = "512x512";
  double azimuth = 30, elevation = 15, zoom = 1, fov = 30;
  std::vector<double> pan, window, background;
  bool transparent = false, noShading = false;
  double step = 0.5;
  InputOptions in;
};

/// "fig.png" + "bone" -> "fig-bone.png".
std::filesystem::path withSuffix(const std::filesystem::path& p, const std::string& suffix) {
  return p.parent_path() / (p.stem().string() + "-" + suffix + p.extension().string());
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
  cmd->add_option("--azimuth", a->azimuth, "camera azimuth in degrees about the superior axis")->capture_default_str();
  cmd->add_option("--elevation", a->elevation, "camera elevation in degrees")->capture_default_str();
  cmd->add_option("--zoom", a->zoom, "zoom factor (1 = whole volume)")->capture_default_str();
  cmd->add_option("--fov", a->fov, "vertical field of view in degrees (0 = orthographic)")->capture_default_str();
  cmd->add_option("--pan", a->pan, "shift of the look-at point in mm (x y z)")->expected(3);
  cmd->add_option("--window", a->window, "window centre and width in HU")->expected(2);
  cmd->add_option("--background", a->background, "background colour r g b [a] in 0..1")->expected(3, 4);
  cmd->add_flag("--transparent", a->transparent, "transparent background (PNG/TIFF alpha)");
  cmd->add_flag("--no-shading", a->noShading, "disable gradient shading");
  cmd->add_option("--step", a->step, "ray step in voxels")->capture_default_str();
  a->in.addTo(*cmd);
  cmd->footer("Example: vellum render knee.nrrd --preset all --size 1024x1024 --out figs/knee.png");
  cmd->callback([a] {
    const io::LoadedVolume lv = loadWithProgress(a->input, a->in);
    render::RenderSettings s;
    std::tie(s.width, s.height) = parseSize(a->size);
    s.camera.azimuthDeg = a->azimuth;
    s.camera.elevationDeg = a->elevation;
    s.camera.zoom = a->zoom;
    s.camera.fieldOfViewDeg = a->fov;
    if (!a->pan.empty()) s.camera.panMm = {a->pan[0], a->pan[1], a->pan[2]};
    if (!a->window.empty()) {
      s.windowCenter = a->window[0];
      s.windowWidth = a->window[1];
    }
    if (!a->background.empty())
      s.background = {float(a->background[0]), float(a->background[1]), float(a->background[2]),
                      a->background.size() > 3 ? float(a->background[3]) : 1.f};
    if (a->transparent) s.background[3] = 0.f;
    s.shading = !a->noShading;
    s.stepVoxels = a->step;
    const std::vector<render::Preset> presets =
        a->preset == "all" ? render::allPresets() : std::vector{render::parsePreset(a->preset)};

    auto context = render::GlContext::createHeadless();
    render::VolumeRenderer renderer(*context);
    renderer.setVolume(lv.volume);
    ensureParentFolder(a->output);
    for (render::Preset p : presets) {
      s.preset = p;
      const RgbaImage image = renderer.render(s);
      const auto path = presets.size() > 1 ? withSuffix(a->output, render::presetName(p)) : std::filesystem::path(a->output);
      io::saveImage(image, path);
      std::cout << path.string() << "  " << render::presetName(p) << "  " << s.width << "x" << s.height
                << "  " << renderer.lastRenderMs() << " ms\n";
    }
  });
}

}  // namespace vellum::cli
