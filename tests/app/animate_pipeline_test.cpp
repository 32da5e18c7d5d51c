// The movie request shared by `vellum animate` and the studio's export: runAnimate renders
// what animation::renderTrack renders, the frame count is the track's, and the arguments the
// studio writes (animateArguments) make `vellum animate` render the same frames.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <fstream>

#include "commands.hpp"
#include "file_errors.hpp"
#include "knee_on_disk.hpp"
#include "vellum/app/animate_pipeline.hpp"
#include "vellum/deformation/placement.hpp"
#include "vellum/deformation/point_files.hpp"
#include "vellum/io/image_io.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/phantom/phantom.hpp"
#include "vellum/render/gl_context.hpp"

using namespace vellum;
using namespace vellum::deformation;
namespace fs = std::filesystem;

namespace {

const std::vector<uint16_t>& kBones = test::kKneeBones;

/// The knee on disk and a bend of the tibia as a keyframe track.
struct Case : test::KneeOnDisk {
  explicit Case(const std::string& name) : KneeOnDisk(test::writeKnee(name)) {}
  fs::path keys;
  KeyframeTrack track;
};

Case makeCase(const std::string& name) {
  Case c(name);
  c.keys = c.dir / "keys.json";
  c.track = kneeBendTrack(c.ph.ct.geometry(), 25.0, 0.5, phantom::flexionAxisPointMm());
  saveKeyframes(c.track, c.keys);
  return c;
}

app::AnimateRequest requestFor(const Case& c, const fs::path& out) {
  app::AnimateRequest r;
  r.input = c.ct;
  r.keyframes = c.keys;
  r.output = out;
  r.fps = 6;
  r.orbitDeg = 30;
  r.settings.width = 40;
  r.settings.height = 32;
  r.engine.labels = c.labels.string();
  r.engine.rigidIds = kBones;
  r.engine.rigidFalloffMm = 6;
  return r;
}

std::vector<fs::path> framesIn(const fs::path& dir) {
  std::vector<fs::path> frames;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".png") frames.push_back(e.path());
  std::sort(frames.begin(), frames.end());
  return frames;
}

/// Splits "'a b' --x 1" into {"a b", "--x", "1"} (single quotes, as animateArguments writes paths).
std::vector<std::string> splitArguments(const std::string& text) {
  std::vector<std::string> args;
  std::string cur;
  bool quoted = false, any = false;
  for (char ch : text) {
    if (ch == '\'') { quoted = !quoted; any = true; continue; }
    if (ch == ' ' && !quoted) {
      if (any) args.push_back(cur);
      cur.clear();
      any = false;
      continue;
    }
    cur += ch;
    any = true;
  }
  if (any) args.push_back(cur);
  return args;
}

void runCli(const std::vector<std::string>& args) {
  CLI::App app{"vellum"};
  cli::addAnimateCommand(app);
  app.require_subcommand(1);
  std::vector<const char*> argv{"vellum", "animate"};
  for (auto& a : args) argv.push_back(a.c_str());
  app.parse(static_cast<int>(argv.size()), argv.data());
}

}  // namespace

// runAnimate is renderTrack on the loaded volume, keyframes and rigid bones: the same frames,
// as many as the track has at the request's rate, and a report per frame.
TEST(AnimatePipeline, FramesAreRenderTracksAndTheReportCountsThem) {
  const Case c = makeCase("app-animate-track");
  app::AnimateRequest r = requestFor(c, c.dir / "app/");
  r.report = c.dir / "report.json";
  const app::AnimateResult result = app::runAnimate(r);
  const int expected = c.track.frameCount(r.fps);
  ASSERT_GT(expected, 2);
  EXPECT_EQ(result.movie.frames, expected);
  const auto appFrames = framesIn(c.dir / "app");
  ASSERT_EQ(static_cast<int>(appFrames.size()), expected);

  animation::MovieSpec spec = app::movieSpec(r);
  spec.framesDir = c.dir / "library";
  const RigidBodies bodies = RigidBodies::fromLabels(c.ph.labels, kBones);
  {
    auto context = render::GlContext::createHeadless();
    animation::renderTrack(*context, AnyVolume(c.ph.ct), c.track, DeformParams{}, {&bodies, 6.0, 1}, spec);
  }
  const auto libraryFrames = framesIn(c.dir / "library");
  ASSERT_EQ(libraryFrames.size(), appFrames.size());
  for (size_t f = 0; f < appFrames.size(); ++f)
    EXPECT_EQ(io::loadImage(appFrames[f]).pixels, io::loadImage(libraryFrames[f]).pixels) << appFrames[f];

  const nlohmann::json j = nlohmann::json::parse(std::ifstream(r.report));
  EXPECT_EQ(j, result.report);
  EXPECT_EQ(j["frames"].get<int>(), expected);
  EXPECT_EQ(j["fps"].get<double>(), 6.0);
  for (const char* key : {"deform_per_frame", "render_per_frame", "total"}) EXPECT_TRUE(j["timings_ms"].contains(key)) << key;
  EXPECT_EQ(j["rigidity_per_frame"].size(), static_cast<size_t>(expected));
  EXPECT_LT(j["rigidity_worst"]["bone_rms_residual_mm"].get<double>(), 0.5);
  // The worst frame per body too (one per id at this size), and no fixed regions: null.
  ASSERT_GE(j["rigidity_worst"]["bodies"].size(), 3u);
  for (const auto& b : j["rigidity_worst"]["bodies"]) EXPECT_LT(b["rms_residual_mm"].get<double>(), 0.5) << b.dump();
  EXPECT_TRUE(j["rigidity_worst"]["fixed"].is_null());
}

// The arguments the studio writes beside its export make `vellum animate` render the request's frames.
TEST(AnimatePipeline, AnimateArgumentsReproduceTheRequestThroughTheCli) {
  const Case c = makeCase("app-animate-cli");
  app::AnimateRequest r = requestFor(c, c.dir / "app/");
  r.engine.params.controlScale = 3;
  r.engine.upsampling = Upsampling::Gaussian;
  r.loop = true;
  r.settings.camera.elevationDeg = 20;
  r.settings.camera.panMm = {6, -4, 2.5};  // a panned view (the studio's middle drag)
  // The thigh stays put: the femur by label, the top slab by a box (mm).
  r.engine.setRigidLabels({"6+7", "8+11", "9+11"});
  r.engine.fixedIds = {4, 5};
  const Geometry& g = c.ph.ct.geometry();
  const Vec3 lo = g.indexToPhysical({0, 0, double(g.dims.z - 6)}), hi = g.indexToPhysical({double(g.dims.x - 1), double(g.dims.y - 1), double(g.dims.z - 1)});
  r.engine.fixedBoxMm = {lo.x, lo.y, lo.z, hi.x, hi.y, hi.z};
  const app::AnimateResult result = app::runAnimate(r);
  EXPECT_LT(result.report["rigidity_worst"]["fixed"]["max_displacement_mm"].get<double>(), 1e-4);
  app::AnimateRequest viaCli = r;
  viaCli.output = c.dir / "cli/";
  const std::string args = app::animateArguments(viaCli);
  EXPECT_NE(args.find("--control-scale 3"), std::string::npos) << args;
  EXPECT_NE(args.find("--loop=true"), std::string::npos) << args;
  EXPECT_NE(args.find("--pan 6 -4 2.5"), std::string::npos) << args;
  EXPECT_NE(args.find("--rigid-labels 6+7,8+11,9+11"), std::string::npos) << args;
  EXPECT_NE(args.find("--fixed-labels 4,5"), std::string::npos) << args;
  EXPECT_NE(args.find("--fixed-box "), std::string::npos) << args;
  runCli(splitArguments(args));
  const auto a = framesIn(c.dir / "app"), b = framesIn(c.dir / "cli");
  ASSERT_EQ(a.size(), b.size());
  KeyframeTrack looped = c.track;
  looped.loop = true;
  EXPECT_EQ(static_cast<int>(a.size()), looped.frameCount(r.fps));
  for (size_t f = 0; f < a.size(); ++f) EXPECT_EQ(io::loadImage(a[f]).pixels, io::loadImage(b[f]).pixels) << a[f];
}

TEST(AnimatePipeline, BadRequestsNameTheFieldOrFile) {
  const Case c = makeCase("app-animate-bad");
  auto errorOf = [](const app::AnimateRequest& r) { return test::errorOf([&] { app::runAnimate(r); }); };
  app::AnimateRequest r = requestFor(c, c.dir / "out/");
  r.keyframes = c.dir / "missing.json";
  EXPECT_NE(errorOf(r).find("missing.json"), std::string::npos);
  r = requestFor(c, c.dir / "out/");
  r.fps = 0;
  EXPECT_NE(errorOf(r).find("fps"), std::string::npos);
  r = requestFor(c, c.ct);
  EXPECT_NE(errorOf(r).find("refusing to overwrite an input"), std::string::npos);
  r = requestFor(c, c.dir / "out/");
  r.engine.labels.clear();
  r.annotations.labels = true;
  EXPECT_EQ(errorOf(r), "--name-structures needs the label map of --labels");
  r = requestFor(c, c.dir / "out/");
  r.removeTable = segmentation::BodyMaskParams{};
  io::saveVolume(AnyVolume(VolumeF32(c.ph.ct.geometry())), c.dir / "float.nrrd");
  r.input = c.dir / "float.nrrd";
  EXPECT_NE(errorOf(r).find("float.nrrd: --remove-table needs a CT"), std::string::npos);
  EXPECT_FALSE(fs::exists(c.dir / "out")) << "nothing written after a failed request";
}
