// The movie request: `vellum animate`'s run and the studio export's spec and command line
// (see animate_pipeline.hpp).
#include "vellum/app/animate_pipeline.hpp"

#include <algorithm>
#include <chrono>
#include <sstream>

#include "vellum/app/figures.hpp"
#include "vellum/app/outputs.hpp"
#include "vellum/app/run_report.hpp"
#include "vellum/app/table_removal.hpp"
#include "vellum/core/error.hpp"
#include "vellum/deformation/point_files.hpp"
#include "vellum/render/gl_context.hpp"
#include "vellum/render/label_tint.hpp"

namespace vellum::app {
using namespace vellum::deformation;
namespace {

// Per-frame measures as the report writes them.
nlohmann::json perFrameJson(const std::vector<animation::FrameRigidity>& frames) {
  nlohmann::json j = nlohmann::json::array();
  for (const auto& f : frames)  // null: a frame between keyframes measured at its nodes only
    j.push_back({{"voxels_as_rendered", f.voxelsAsRendered.voxelLevel ? toJson(f.voxelsAsRendered) : nlohmann::json()},
                 {"nodes", toJson(f.nodes)}});
  return j;
}

// The worst frame as rendered, every measure (per body, fixed regions, tissue folds).
RigidityReport worstOfFrames(const animation::MovieResult& r) {
  std::vector<RigidityReport> frames;
  for (const auto& f : r.perFrame)
    if (f.voxelsAsRendered.voxelLevel) frames.push_back(f.voxelsAsRendered);
  return frames.empty() ? r.worst : worstOf(frames);
}

nlohmann::json reportJson(const animation::MovieResult& r, const AnimateRequest& request, bool rigid, double totalMs) {
  const int frames = std::max(r.frames, 1);
  // Which frames rigidity_worst covers: every frame, or (a large volume) the keyframe poses and
  // the last frame, the others measured at their nodes only.
  const bool all = std::all_of(r.perFrame.begin(), r.perFrame.end(), [](const auto& f) { return f.voxelsAsRendered.voxelLevel; });
  const std::string voxelFrames = all ? "all" : "keyframes and the last frame (the others: nodes only)";
  return {{"frames", r.frames},
          {"fps", request.fps},
          {"timings_ms", {{"deform_per_frame", r.deformMs / frames}, {"render_per_frame", r.renderMs / frames}, {"total", totalMs}}},
          {"frames_cpu_ms", r.cpuMs},
          {"rigidity_worst", rigid ? toJson(worstOfFrames(r)) : nlohmann::json()},
          {"rigidity_voxel_frames", rigid ? nlohmann::json(voxelFrames) : nlohmann::json()},
          {"rigidity_per_frame", perFrameJson(r.perFrame)}};
}

}  // namespace

std::string singleQuoted(const std::filesystem::path& p) {
  std::string q(1, '\'');  // built up in steps: GCC 12 warns (-Wrestrict) on "'" + s + "'"
  q += p.string();
  q += '\'';
  return q;
}

const params::Table<AnimateRequest>& animateRequestTable() {
  using R = AnimateRequest;
  static const params::Table<R> t{
      params::real<R>("fps", &R::fps, {"FPS", "frames per second", "", 0.01, 240}),
      params::real<R>("camera_orbit", &R::orbitDeg,
                      {"Camera orbit", "turn the camera by this many degrees over the animation", "deg", -3600, 3600}),
      params::flag<R>("loop", &R::loop,
                      {"Loop", "seamless loop: back to the first keyframe, no repeated frame", ""}),
      params::text<R>("title", &R::title,
                      {"Title", "a title card shown before the first frame (empty: none)", ""}),
      params::text<R>("subtitle", &R::subtitle,
                      {"Subtitle", "a second, smaller line on the title card", ""}),
      params::real<R>("title_seconds", &R::titleSeconds,
                      {"Title seconds", "how long the title card shows", "s", 0.1, 30}),
      params::text<R>("caption", &R::caption,
                      {"Caption", "text at the bottom of every frame; a keyframe's \"caption\" replaces it while it plays", ""}),
      // deform's --pad-mm, described once (deformRequestTable()): here over every keyframe.
      params::real<R>("pad_mm", &R::padMm, params::findField(deformRequestTable(), "pad_mm")->info),
  };
  return t;
}

animation::MovieSpec movieSpec(const AnimateRequest& request) {
  animation::MovieSpec spec;
  const std::string out = request.output.string();
  const bool isFolder = !out.empty() && (out.back() == '/' || request.output.extension().empty());
  (isFolder ? spec.framesDir : spec.moviePath) = request.output;
  if (!request.frames.empty()) spec.framesDir = request.frames;
  if (spec.framesDir.filename().empty()) spec.framesDir = spec.framesDir.parent_path();  // "frames/"
  spec.fps = request.fps;
  spec.orbitDeg = request.orbitDeg;
  spec.upsampling = request.engine.upsampling;
  spec.settings = request.settings;
  spec.annotations = request.annotations;
  spec.labelIds = request.labelIds;
  spec.title = request.title;
  spec.subtitle = request.subtitle;
  spec.titleSeconds = request.titleSeconds;
  spec.caption = request.caption;
  spec.knownBodyTransforms = request.knownBodyTransforms;
  return spec;
}

std::string movieArguments(const AnimateRequest& r, const std::vector<std::string>& skip) {
  std::ostringstream c;
  c.precision(10);
  std::vector<std::string> own = skip;
  own.insert(own.end(), {"title", "subtitle", "caption"});
  c << " --size " << r.settings.width << "x" << r.settings.height << params::cliArguments(animateRequestTable(), r, own)
    << params::cliArguments(render::renderSettingsTable(), r.settings, {"width", "height"});
  for (const auto& [flag, text] : {std::pair{"--title", &r.title}, {"--subtitle", &r.subtitle}, {"--caption", &r.caption}})
    if (!text->empty()) c << ' ' << flag << ' ' << singleQuoted(*text);
  if (const Vec3& pan = r.settings.camera.panMm; pan.x != 0 || pan.y != 0 || pan.z != 0)
    c << " --pan " << pan.x << ' ' << pan.y << ' ' << pan.z;
  return c.str();
}

std::string animateArguments(const AnimateRequest& r) {
  std::ostringstream c;
  c.precision(10);
  c << singleQuoted(r.input) << " --keyframes " << singleQuoted(r.keyframes) << " --out " << singleQuoted(r.output);
  if (!r.frames.empty()) c << " --frames " << singleQuoted(r.frames);
  c << movieArguments(r);
  c << params::cliArguments(deformParamsTable(), r.engine.params)
    << params::cliArguments(deformEngineTable(), r.engine, {"labels"});
  if (!r.engine.labels.empty()) {
    c << " --labels " << singleQuoted(r.engine.labels);
    if (const std::string rigid = r.engine.rigidLabelsArgument(); !rigid.empty()) c << " --rigid-labels " << rigid;
    if (!r.engine.fixedIds.empty()) c << " --fixed-labels ";
    for (size_t i = 0; i < r.engine.fixedIds.size(); ++i) c << (i ? "," : "") << r.engine.fixedIds[i];
    for (size_t i = 0; i < r.engine.fixedBoxMm.size(); ++i)  // one --fixed-box per 6 numbers
      c << (i % 6 == 0 ? " --fixed-box " : ",") << r.engine.fixedBoxMm[i];
  }
  return c.str();
}

MovieBox movieBox(AnyVolume volume, const KeyframeTrack& track, double padMm, int controlScale,
                  const render::Camera& asked) {
  std::vector<ControlPoints> poses;
  for (const Keyframe& k : track.keyframes) poses.push_back(k.points);
  MovieBox m;
  m.box = grownBox(volume, padMm, poses, controlScale, padMm != 0);
  m.volume = m.box.pad.none() ? std::move(volume) : padded(volume, m.box.pad);
  m.camera = padMm != 0 ? framedOnContent(m.box.grid, m.box.content, asked) : asked;
  return m;
}

nlohmann::json toJson(const MovieBox& m) {
  const Geometry& g = m.box.grid;
  nlohmann::json j = {{"grid", {{"dims", {g.dims.x, g.dims.y, g.dims.z}},
                                {"origin_mm", {g.origin.x, g.origin.y, g.origin.z}},
                                {"spacing_mm", {g.spacing.x, g.spacing.y, g.spacing.z}}}},
                      {"pad_voxels", {{"low", m.box.pad.lo}, {"high", m.box.pad.hi}}},
                      {"camera", {{"zoom", m.camera.zoom}, {"pan_mm", {m.camera.panMm.x, m.camera.panMm.y, m.camera.panMm.z}}}}};
  if (!m.box.content.empty())
    j["content_box_mm"] = {{m.box.content.lo.x, m.box.content.lo.y, m.box.content.lo.z},
                           {m.box.content.hi.x, m.box.content.hi.y, m.box.content.hi.z}};
  return j;
}

AnimateResult runAnimate(const AnimateRequest& request, Progress& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  RunOutputs written;  // opened before the movie replaces an older one: a failed run puts it back
  params::validate(animateRequestTable(), request);
  params::validate(deformEngineTable(), request.engine);
  const animation::MovieSpec spec = movieSpec(request);
  io::OutputPlan()
      .input(request.input)
      .input(request.keyframes, "the --keyframes file")
      .input(request.engine.labels, "the --labels map")
      .output(spec.moviePath, "--out")
      .folder(spec.framesDir, io::FolderKind::Frames, request.frames.empty() ? "--out" : "--frames")
      .json(request.report, "--report")
      .force(request.force)
      .check();
  if (request.annotations.labels && request.engine.labels.empty())
    throw Error("--name-structures needs the label map of --labels");
  KeyframeTrack track = request.track ? *request.track : loadKeyframes(request.keyframes);
  if (request.loop) track.loop = true;
  const DeformParams params = request.engine.resolved(std::nullopt);
  io::LoadOptions load = request.load;
  load.progress = &progress;
  io::LoadedVolume lv = io::loadVolume(request.input, load);
  std::optional<segmentation::BodyMaskReport> tableRemoval;
  if (request.removeTable)
    lv.volume = withoutCtTable(lv.volume, request.input, *request.removeTable, progress, &tableRemoval.emplace());
  RunReport shared(request.commandLine, t0);  // the keys every report shares
  if (!request.report.empty()) {
    shared.input(request.input, "volume");
    shared.loaded(request.input, lv);  // the input's grid, before the movie's box grows
    shared.input(request.keyframes, "keyframes");
    shared.input(request.engine.labels, "label map");
  }
  const Geometry inputGrid = geometryOf(lv.volume);
  // The movie's box: grown (--pad-mm) to hold every keyframe's content, one grid for all frames.
  MovieBox box = movieBox(std::move(lv.volume), track, request.padMm, params.controlScale, request.settings.camera);
  const Geometry& grid = box.box.grid;
  const std::optional<RigidBodies> bodies = request.engine.rigidBodies(grid, request.load);
  animation::MovieSpec withLabels = spec;
  withLabels.settings.camera = box.camera;
  if (request.frameMapsOn) withLabels.frameMaps = request.frameMapsOn(grid);
  std::optional<LabelVolume> names;
  const auto loadNames = [&] {
    io::LoadOptions o;
    o.region = request.load.region;
    o.allowOutsideData = request.load.allowOutsideData;
    LabelVolume labels = io::loadLabels(request.engine.labels, o);
    requireSameGrid(labels, inputGrid, request.engine.labels);
    return labelsOnGrid(labels, grid);  // padded with 0 as the volume is with air
  };
  if (request.annotations.labels) {
    names = loadNames();
    withLabels.labels = &*names;
  }
  // Label colours (--label-blend): the --labels map's table colours, through every frame's map.
  std::optional<render::LabelTint> tint;
  if (request.settings.labelBlend > 0) {
    if (request.engine.labels.empty()) throw Error("--label-blend needs the label map of --labels");
    tint = render::makeLabelTint(names ? *names : loadNames());
    withLabels.tint = &*tint;
  }
  if (!spec.moviePath.empty()) ensureParentFolder(spec.moviePath);
  if (!spec.framesDir.empty()) ensureParentFolder(spec.framesDir);
  AnimateResult result;
  const auto render = [&](const animation::MovieSpec& s) {
    auto context = render::GlContext::createHeadless();
    // A large volume (coarseMeasureStride's rule) measures its in-between frames at their nodes.
    const bool large = coarseMeasureStride(grid, 1) > 1;
    const animation::MovieRigidity rigidity{bodies ? &*bodies : nullptr, request.engine.rigidFalloffMm,
                                            request.engine.rigidityStride, 0, !large};
    result.movie = animation::renderTrack(*context, box.volume, track, params, rigidity, s, progress);
  };
  if (spec.framesDir.empty()) {
    render(withLabels);
  } else {
    // The frames appear as one folder when the last is written (a cancelled export leaves none).
    io::writeFolderAtomically(spec.framesDir, io::FolderKind::Frames, [&](const std::filesystem::path& tmp) {
      animation::MovieSpec s = withLabels;
      s.framesDir = tmp;
      render(s);
    }, request.force);
  }
  result.warnings = std::move(lv.warnings);
  const double totalMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  result.report = reportJson(result.movie, request, bodies.has_value(), totalMs);
  result.report["box"] = toJson(box);
  if (tableRemoval) {
    result.report["table_removal"] = tableRemovalJson(*tableRemoval);
    result.tableRemoval = tableRemovalSummary(*tableRemoval);
  }
  // A report that cannot be written takes the movie with it.
  if (!spec.moviePath.empty()) written.wrote(spec.moviePath);
  if (!spec.framesDir.empty()) written.wrote(spec.framesDir);
  if (!request.report.empty()) {
    shared.outputVolume(spec.moviePath);
    shared.outputVolume(spec.framesDir);
    shared.stamp(result.report);  // the returned report is the file's
    writeJsonFile(result.report, request.report);
  }
  written.commit();
  return result;
}

}  // namespace vellum::app
