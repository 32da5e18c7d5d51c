// `vellum demo --out DIR`: the main job on the built-in phantom. Generates the phantom,
// saves it (NRRD + labels + a DICOM series), renders every preset from several views, then
// runs the segmentation and deformation parts, and writes a summary.json of what it did.
#include <iostream>
#include <memory>

#include "cli_params.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "vellum/io/image_io.hpp"
#include "vellum/phantom/phantom.hpp"
#include "vellum/render/contact_sheet.hpp"
#include "vellum/render/volume_renderer.hpp"

namespace vellum::cli {
namespace {

struct DemoArgs {
  std::string out = "vellum-demo";
  int size = 128;
  int imageSize = 512;
  uint64_t seed = 1;
  bool skipDicom = false;
  bool force = false;
};

struct View {
  const char* name;
  double azimuth, elevation;
};

/// The demo's single-valued flags, described once (docs/parameters.md).
const params::Table<DemoArgs>& demoFlagsTable() {
  using A = DemoArgs;
  static const params::Table<A> t{
      params::integer<A>("size", &A::size, {"Size", "phantom voxels per axis", "voxels", 32, 512}),
      params::integer<A>("image_size", &A::imageSize, {"Image size", "figure size (square)", "px", 64, 4096}),
      params::integer<A>("seed", &A::seed, {"Seed", "phantom noise seed", "", 0}),
      params::flag<A>("no_dicom", &A::skipDicom, {"No DICOM", "do not write the phantom as a DICOM series", ""}),
  };
  return t;
}

}  // namespace

std::string demoFlagsMarkdown() { return params::markdown(demoFlagsTable()); }

void addDemoCommand(CLI::App& app) {
  auto a = std::make_shared<DemoArgs>();
  auto* cmd = app.add_subcommand("demo", "Run the main job on the built-in phantom: figures, segmentation, deformation");
  addOutput(*cmd, "--out,-o", a->out, "output folder (created)")->capture_default_str();
  addFlags(*cmd, *a, demoFlagsTable());
  addForceFlag(*cmd, a->force);
  cmd->footer("Example: vellum demo --out vellum-demo --size 192");
  cmd->callback([a] {
    const auto t0 = std::chrono::steady_clock::now();
    const std::filesystem::path out = a->out;
    // A new folder, or one an earlier demo wrote (its outputs are listed as they are made, so
    // it is written in place rather than swapped in whole).
    io::prepareFolderInPlace(out, io::FolderKind::Demo, a->force);
    nlohmann::json summary;

    // 1. The phantom, in the formats other tools open.
    phantom::PhantomOptions po;
    po.dims = {a->size, a->size, a->size};
    po.seed = a->seed;
    phantom::Phantom p;
    {
      ProgressBar bar;
      p = phantom::makePhantom(po, bar.progress());
    }
    DemoContext ctx{out, out / "phantom.nrrd", out / "phantom-labels.nrrd", a->size};
    io::saveVolume(p.ct, ctx.phantomCt);
    io::saveLabels(p.labels, ctx.phantomLabels);
    if (!a->skipDicom) io::saveVolume(p.ct, out / "phantom-dicom", {.format = "dicom", .seriesDescription = "Vellum knee phantom"});
    summary["phantom"] = {{"dims", {po.dims.x, po.dims.y, po.dims.z}},
                          {"spacing_mm", toJson(p.ct.geometry().spacing)},
                          {"files", {"phantom.nrrd", "phantom-labels.nrrd", a->skipDicom ? "" : "phantom-dicom/"}}};
    std::cout << "phantom " << po.dims.str() << " -> " << ctx.phantomCt.string() << "\n";

    // 2. Figures: every preset from three views, plus a contact sheet.
    const View views[] = {{"front", 0, 10}, {"oblique", 40, 20}, {"side", 90, 5}};
    auto context = render::GlContext::createHeadless();
    render::VolumeRenderer renderer(*context);
    renderer.setVolume(p.ct);
    render::RenderSettings s;
    s.width = s.height = a->imageSize;
    s.camera.zoom = 1.4;  // the leg, not the empty corners of its bounding sphere, fills the frame
    std::vector<RgbaImage> tiles;
    nlohmann::json figures = nlohmann::json::array();
    for (render::Preset preset : render::allPresets()) {
      for (const View& v : views) {
        s.preset = preset;
        s.camera.azimuthDeg = v.azimuth;
        s.camera.elevationDeg = v.elevation;
        RgbaImage img = renderer.render(s);
        const std::string name = std::string("render-") + render::presetName(preset) + "-" + v.name + ".png";
        io::saveImage(img, out / name);
        figures.push_back({{"file", name}, {"preset", render::presetName(preset)}, {"ms", renderer.lastRenderMs()}});
        tiles.push_back(std::move(img));
      }
    }
    io::saveImage(render::contactSheet(tiles, 3), out / "contact-sheet.png");
    summary["figures"] = figures;
    summary["renderer"] = context->renderer();
    std::cout << tiles.size() << " figures + contact-sheet.png (" << context->renderer() << ")\n";

    // 3. The parts later capabilities add.
    demoSegmentation(ctx);
    demoDeformation(ctx);
    demoIllustration(ctx);
    demoCurveAnalogy(ctx);

    summary["seconds"] = secondsSince(t0);
    writeJsonFile(summary, out / "summary.json");
    std::cout << "demo finished in " << secondsSince(t0) << " s; outputs in " << out.string() << "\n";
  });
}

}  // namespace vellum::cli
