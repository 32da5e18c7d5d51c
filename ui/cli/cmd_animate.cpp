// `vellum animate` (keyframed deformation movie through the GL renderer) and the deformation
// part of `vellum demo`.
#include <algorithm>
#include <chrono>
#include <iostream>
#include <memory>

#include "cli_params.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "deform_cli.hpp"
#include "vellum/animation/movie.hpp"
#include "vellum/app/animate_pipeline.hpp"
#include "vellum/core/error.hpp"
#include "vellum/deformation/placement.hpp"
#include "vellum/deformation/point_files.hpp"
#include "vellum/deformation/synthesis.hpp"
#include "vellum/io/image_io.hpp"
#include "vellum/io/video_io.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/phantom/phantom.hpp"
#include "vellum/render/volume_renderer.hpp"

namespace vellum::cli {

namespace fs = std::filesystem;
using namespace vellum::deformation;
using animation::MovieResult;
using animation::MovieSpec;

namespace {

struct AnimateArgs {
  app::AnimateRequest request;  ///< the flags write here
  std::string size = "512x512";
  InputOptions in;
  TableRemovalOptions table;
  FigureOptions figure;
};

/// `animate`'s own flags besides the request's tables, described once (docs/parameters.md).
const params::Table<AnimateArgs>& animateFlagsTable() {
  using A = AnimateArgs;
  static const params::Table<A> t{
      params::text<A>("size", &A::size, {"Size", "image size WxH", "px"}),
      params::vector<A>("pan", params::nested(&A::request, &app::AnimateRequest::settings,
                                              &render::RenderSettings::camera, &render::Camera::panMm),
                        {"Pan", "shift of the look-at point (x y z, or x,y,z; as `vellum render --pan`)", "mm"}),
  };
  return t;
}

void printSummary(const app::AnimateRequest& request, const app::AnimateResult& result) {
  const MovieResult& r = result.movie;
  const int frames = std::max(r.frames, 1);
  std::cout << request.output.string() << "  " << r.frames << " frames  deform " << r.deformMs / frames
            << " ms/frame  render " << r.renderMs / frames << " ms/frame\n";
  if (!request.engine.labels.empty())
    std::cout << "worst frame: bone RMS residual " << r.worst.boneRmsResidualMm << " mm, fold fraction "
              << r.worst.foldFraction << "\n";
}

}  // namespace

std::string animateFlagsMarkdown() { return params::markdown(animateFlagsTable()); }

void addAnimateCommand(CLI::App& app) {
  auto a = std::make_shared<AnimateArgs>();
  app::AnimateRequest& r = a->request;
  auto* cmd = app.add_subcommand("animate", "Render a keyframed deformation as an MP4 and/or PNG frames (GL)");
  addInput(*cmd, "input", r.input, "volume file or DICOM folder")->required();
  addInput(*cmd, "--keyframes", r.keyframes, "keyframe JSON (mm; see docs/deformation.md)")->required();
  addOutput(*cmd, "--out,-o", r.output, "movie.mp4, or a folder (ending in /) for PNG frames")->required();
  addOutput(*cmd, "--frames", r.frames, "also write PNG frames into this folder");
  addFlags(*cmd, *a, animateFlagsTable());  // --size, --pan
  addFlags(*cmd, r.settings, render::renderSettingsTable(), {"width", "height"});
  addFlags(*cmd, r, app::animateRequestTable());  // --fps, --camera-orbit, --loop
  addOutput(*cmd, "--report", r.report, "JSON report: timings and per-frame rigidity measures");
  addForceFlag(*cmd, r.force);
  addEngineFlags(*cmd, r.engine);
  a->in.addTo(*cmd);
  a->table.addTo(*cmd);
  a->figure.addTo(*cmd, FigureOptions::LabelSource::OtherOption);
  cmd->footer("Example: vellum animate knee.nrrd --keyframes bend.json --labels knee-labels.nrrd "
              "--rigid-labels 4+5,6+7,8+11,9+11 --camera-orbit 360 --loop --out bend.mp4");
  cmd->callback([a] {
    app::AnimateRequest request = a->request;
    std::tie(request.settings.width, request.settings.height) = parseSize(a->size);
    setVolumeInput(request, a->in, &a->table);
    a->figure.setAnnotations(request);
    printSummary(request, runPipeline(request, app::runAnimate));
  });
}

void demoDeformation(const DemoContext& ctx) {
  const auto t0 = std::chrono::steady_clock::now();
  const io::LoadedVolume lv = io::loadVolume(ctx.phantomCt);
  const Geometry& g = geometryOf(lv.volume);
  // One body per bone: cortex + marrow (4+5, 6+7), and the cancellous id 11 split between the
  // fibula's and the patella's cores (`--rigid-labels 4+5,6+7,8+11,9+11`).
  const RigidBodies bodies =
      RigidBodies::fromLabelGroups(io::loadLabels(ctx.phantomLabels), {{4, 5}, {6, 7}, {8, 11}, {9, 11}});
  const Vec3 pivot = phantom::flexionAxisPointMm();  // the tibia swings about the knee's axis
  const KeyframeTrack track = kneeBendTrack(g, 20.0, 2.0, pivot);
  saveKeyframes(track, ctx.outDir / "deform-keyframes.json");
  DeformParams params;
  params.controlScale = 2;
  const double falloff = 10.0;

  // Before / after figures at the strongest bend (keyframe 1).
  render::RenderSettings s;
  s.width = s.height = 384;
  s.camera.azimuthDeg = 90;  // from the side: the bend is about the medio-lateral axis
  s.camera.elevationDeg = 5;
  ControlVolume cv = computeControlVolume(lv.volume, track.keyframes[1].points, params);
  const RigidityReport plain = measureRigidityVoxels(cv, g, bodies);
  const RigidityReport plainNodes = measureRigidity(cv, bodies);
  applyRigidity(cv, bodies, {falloff});
  // Voxel level: the map CPU synthesis resamples with (with the voxel snap; the GL renderer
  // applies the same snap per ray sample, so the frames show this map); and the control-grid nodes.
  const RigidityReport rigid = measureRigidityVoxels(cv, g, bodies);
  const RigidityReport rigidNodes = measureRigidity(cv, bodies);
  const RigidityReport rigidGl = rigid;
  {
    auto context = render::GlContext::createHeadless();
    render::VolumeRenderer renderer(*context);
    renderer.setVolume(lv.volume);
    io::saveImage(renderer.render(s), ctx.outDir / "deform-before.png");
    const render::BackwardMap map = deformation::renderedMap(cv, g);
    renderer.setBackwardMap(&map);
    io::saveImage(renderer.render(s), ctx.outDir / "deform-after.png");
    s.preset = render::Preset::Bone;
    io::saveImage(renderer.render(s), ctx.outDir / "deform-after-bone.png");
    s.preset = render::Preset::SoftTissueBone;
  }

  // The movie: the bend over the keyframes while the camera orbits 60 degrees.
  MovieSpec spec;
  spec.fps = 15;
  spec.settings = s;
  spec.settings.width = spec.settings.height = 256;
  spec.orbitDeg = 60;
  if (io::videoEncoderAvailable()) spec.moviePath = ctx.outDir / "deform-bend.mp4";
  else spec.framesDir = ctx.outDir / "deform-frames";
  MovieResult r;
  {
    ProgressBar bar;
    auto context = render::GlContext::createHeadless();
    r = animation::renderTrack(*context, lv.volume, track, params, {&bodies, falloff, 1}, spec, bar.progress());
  }
  writeJsonFile({{"keyframes", "deform-keyframes.json"},
                 {"rigid_labels", "4+5,6+7,8+11,9+11"},
                 {"rigid_falloff_mm", falloff},
                 {"flexion_pivot_mm", {pivot.x, pivot.y, pivot.z}},
                 {"strongest_bend", {{"plain_mls", toJson(plain)},
                                     {"plain_mls_nodes", toJson(plainNodes)},
                                     {"with_rigid_bones", toJson(rigid)},
                                     {"with_rigid_bones_as_rendered", toJson(rigidGl)},
                                     {"with_rigid_bones_nodes", toJson(rigidNodes)}}},
                 {"movie", spec.moviePath.empty() ? "deform-frames/" : "deform-bend.mp4"},
                 {"frames", r.frames},
                 {"worst_frame", toJson(r.worst)},
                 {"timings_ms", {{"deform_per_frame", r.deformMs / std::max(r.frames, 1)},
                                 {"render_per_frame", r.renderMs / std::max(r.frames, 1)}}},
                 {"seconds", secondsSince(t0)}},
                ctx.outDir / "deform-rigidity.json");
  std::cout << "deformation: bone RMS residual (voxels) " << rigid.boneRmsResidualMm << " mm (as rendered "
            << rigidGl.boneRmsResidualMm << ", nodes " << rigidNodes.boneRmsResidualMm << ", plain MLS "
            << plain.boneRmsResidualMm << "), soft tissue moved " << rigid.softTissueMeanDisplacementMm
            << " mm, fold-over " << r.worst.foldFraction << "; " << r.frames << " frames -> "
            << (spec.moviePath.empty() ? spec.framesDir : spec.moviePath).string() << " ("
            << secondsSince(t0) << " s)\n";
}

}  // namespace vellum::cli
