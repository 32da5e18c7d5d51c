#include "export_figure.hpp"

#include <chrono>
#include <sstream>

#include "raw_dialog.hpp"
#include "view3d.hpp"
#include "vellum/core/params.hpp"
#include "vellum/core/error.hpp"
#include "vellum/illustration/style.hpp"
#include "vellum/io/output_policy.hpp"

namespace vellum::studio {
namespace fs = std::filesystem;

namespace {

/// A shell word: single-quoted, a quote inside written as '\''.
std::string shellQuoted(const std::string& t) {
  std::string r = "'";
  for (char c : t) r += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return r + "'";
}

std::string numbers(std::initializer_list<double> values) {
  std::ostringstream s;
  s.precision(17);  // reads back as the same double: the command draws the same picture
  for (double v : values) s << ' ' << v;
  return s.str();
}

/// The flags both commands share: the series, the annotations.
std::string sharedFlags(const Scene& scene, const FigureOptions& o, bool labels, const std::string& labelFlag) {
  std::string c;
  if (isOpenRawHeader(scene.volumePath)) c += " --allow-outside-data";  // names the RAW by absolute path
  if (!scene.seriesUid.empty()) c += " --series " + shellQuoted(scene.seriesUid);
  if (o.scaleBar) c += " --scale-bar";
  if (o.orientation) c += " --orientation";
  if (labels) c += labelFlag;
  return c;
}

void planRender(const Scene& scene, const fs::path& out, const FigureOptions& o, FigurePlan& plan) {
  app::RenderRequest& r = plan.render;
  r.input = fs::absolute(scene.volumePath);
  r.output = fs::absolute(out);
  r.settings = renderSettingsFor(scene, o.width, o.height);
  r.presets = {r.settings.preset};
  const bool haveLabelFile = !scene.labelsPath.empty();
  const fs::path labelFile = haveLabelFile ? fs::absolute(scene.labelsPath) : fs::path();
  // The tint and "this segment only" read the label file (unsaved labels cannot be named).
  const bool tint = r.settings.labelBlend > 0 || r.settings.onlyLabel > 0;
  if (tint && haveLabelFile) {
    r.labelColours = labelFile;
  } else {
    if (tint) plan.leftOut.push_back("the label colours and segment filter (save the labels first)");
    r.settings.labelBlend = render::RenderSettings{}.labelBlend;
    r.settings.onlyLabel = 0;
  }
  const bool labels = o.labels && haveLabelFile;
  if (o.labels && !haveLabelFile) plan.leftOut.push_back("the structure labels (save the labels first)");
  if (labels) r.labelMap = labelFile;
  r.annotations.scaleBar = o.scaleBar;
  r.annotations.orientation = o.orientation;
  r.annotations.labels = labels;
  r.load.seriesUid = scene.seriesUid;
  r.load.allowOutsideData = isOpenRawHeader(scene.volumePath);
  // As cmd_render binds its flags: every render-table setting (the table's own flags), the
  // pan, the tint's label file; paths absolute so the line runs from any folder.
  std::ostringstream cmd;
  std::vector<std::string> skip{"width", "height"};
  if (r.labelColours.empty()) skip.insert(skip.end(), {"label_blend", "only_label"});
  const Vec3& pan = r.settings.camera.panMm;
  cmd << "vellum render " << shellQuoted(r.input.string()) << " --out " << shellQuoted(r.output.string()) << " --size "
      << r.settings.width << 'x' << r.settings.height << params::cliArguments(render::renderSettingsTable(), r.settings, skip)
      << " --pan" << numbers({pan.x, pan.y, pan.z});
  if (!r.labelColours.empty()) cmd << " --label-colours " << shellQuoted(r.labelColours.string());
  std::string c = cmd.str();
  const auto& bg = scene.render.background;
  if (bg != render::RenderSettings{}.background) {  // not a table field: its own flag
    c += " --background" + numbers({bg[0], bg[1], bg[2], bg[3]});
  }
  c += sharedFlags(scene, o, labels, " --label-map " + shellQuoted(labelFile.string()));
  plan.command = c;
}

void planIllustration(const Scene& scene, const fs::path& out, const FigureOptions& o, FigurePlan& plan) {
  if (scene.shapesPath.empty())
    throw Error("the illustration's shapes were made in the studio and have no folder: make them with `vellum shape` "
                "and open that folder (Illustration panel) to export the figure");
  plan.illustrate = true;
  app::IllustrateRequest& r = plan.illustration;
  r.input = fs::absolute(scene.volumePath);
  r.shape = fs::absolute(scene.shapesPath);
  r.output = fs::absolute(out);
  std::ostringstream c;
  c << "vellum illustrate " << shellQuoted(r.input.string()) << " --shape " << shellQuoted(r.shape.string())
    << " --out " << shellQuoted(r.output.string());
  // A built-in style by name; an edited one written beside the figure.
  for (const std::string& name : illustration::stylePresetNames())
    if (illustration::stylePreset(name) == scene.illustration.style) {
      r.presets = {name};
      break;
    }
  if (r.presets.empty()) {
    plan.styleFile = r.output.parent_path() / (r.output.stem().string() + "-style.json");
    plan.style = scene.illustration.style;
    r.style = plan.styleFile;
    c << " --style " << shellQuoted(plan.styleFile.string());
  } else {
    c << " --preset " << r.presets.front();
  }
  // As cmd_illustrate binds its flags: the camera (and pan) from the render table, the ray
  // step and interpolation at their defaults, framed on the volume as the 3D view is.
  render::RenderSettings camera;
  camera.camera = scene.render.camera;
  camera.stepVoxels = 1.0;
  illustration::IllustrationSettings& s = r.settings;
  s.render.camera = camera.camera;
  s.render.stepVoxels = camera.stepVoxels;
  s.render.width = std::clamp(o.width, 1, 4096);
  s.render.height = std::clamp(o.height, 1, 4096);
  r.framing = illustration::Framing::Volume;
  const render::RenderSettings defaults;
  if (scene.render.clipMin != defaults.clipMin || scene.render.clipMax != defaults.clipMax || scene.render.onlyLabel)
    plan.leftOut.push_back("the clip box and segment filter (the illustration draws every shape whole)");
  r.annotations.scaleBar = o.scaleBar;
  r.annotations.orientation = o.orientation;
  r.annotations.labels = o.labels;
  r.load.seriesUid = scene.seriesUid;
  r.load.allowOutsideData = isOpenRawHeader(scene.volumePath);
  std::vector<std::string> skip;
  for (const auto& field : render::renderSettingsTable())
    if (field.key != "azimuth" && field.key != "elevation" && field.key != "zoom" && field.key != "fov")
      skip.push_back(field.key);
  const Vec3& pan = camera.camera.panMm;
  c << " --size " << s.render.width << 'x' << s.render.height << " --frame volume"
    << params::cliArguments(render::renderSettingsTable(), camera, skip) << " --pan" << numbers({pan.x, pan.y, pan.z})
    << sharedFlags(scene, o, o.labels, " --labels");
  plan.command = c.str();
}

}  // namespace

std::string renderCommand(const Scene& scene, const fs::path& out, int width, int height) {
  if (scene.volumePath.empty()) return {};  // a volume without a file: nothing the CLI could read
  FigureOptions o;
  o.width = width;
  o.height = height;
  FigurePlan plan;
  planRender(scene, out, o, plan);
  return plan.command;
}

FigurePlan planFigure(const Scene& scene, const fs::path& out, const FigureOptions& o) {
  if (!scene.hasVolume()) throw Error("no volume is open");
  if (scene.volumePath.empty()) throw Error("the volume has no file the CLI could read");
  if (out.empty()) throw Error("no figure path given");
  if (o.width < 1 || o.height < 1 || o.width > 4096 || o.height > 4096)
    throw Error("the figure size must be 1..4096 x 1..4096 pixels");
  FigurePlan plan;
  if (scene.illustration.enabled && scene.shapes) planIllustration(scene, out, o, plan);
  else planRender(scene, out, o, plan);
  if (!scene.authoring.track.keyframes.empty())
    plan.leftOut.push_back("the deformation (Export movie renders it)");
  if (!scene.hiddenLabels.empty()) plan.leftOut.push_back("hidden labels (the CLI draws every label)");
  if (scene.labelsModified && !scene.labelsPath.empty()) plan.leftOut.push_back("unsaved label edits");
  return plan;
}

FigureJob::FigureJob()
    : job_("export figure", [](const std::string& message) {
        Outcome o;
        o.error = message;
        return o;
      }) {}

bool FigureJob::start(FigurePlan plan) {
  return job_.start(
      [plan = std::move(plan)](Progress& progress) {
        const auto t0 = std::chrono::steady_clock::now();
        Outcome o;
        if (plan.illustrate) {
          if (!plan.styleFile.empty()) {  // through the output policy, written atomically
            io::OutputPlan files;
            files.input(plan.illustration.input).input(plan.illustration.shape, "the shape folder");
            files.json(plan.styleFile, "the figure's style").check();
            illustration::saveStyle(plan.style, plan.styleFile);
          }
          const app::IllustrateResult r = app::runIllustrate(plan.illustration, progress);
          o.path = r.figures.empty() ? plan.illustration.output : r.figures.front().path;
        } else {
          const app::RenderResult r = app::runRender(plan.render, progress);
          o.path = r.figures.empty() ? plan.render.output : r.figures.front().path;
        }
        o.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        return o;
      },
      "export figure");
}

}  // namespace vellum::studio
