// The deformation request shared by `vellum deform` (and, for its engine, `vellum animate`):
// runDeform is the library's Deformer + rigidity + synthesis, the CLI's flags fill the same
// request, bad requests fail in one line naming the field or file, the report keeps its keys.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <fstream>

#include "commands.hpp"
#include "file_errors.hpp"
#include "test_data.hpp"
#include "vellum/app/deform_pipeline.hpp"
#include "vellum/deformation/deformer.hpp"
#include "vellum/deformation/map_file.hpp"
#include "vellum/deformation/placement.hpp"
#include "vellum/deformation/point_files.hpp"
#include "vellum/deformation/synthesis.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/phantom/phantom.hpp"

using namespace vellum;
using namespace vellum::deformation;
namespace fs = std::filesystem;

namespace {
using test::errorOf;

const std::vector<uint16_t> kBones = {4, 5, 6, 7, 8, 9, 11};

/// A small knee on disk, its labels, and a bend of the tibia as a point file.
struct Case {
  fs::path dir, ct, labels, points;
  phantom::Phantom ph;
  PointFile bend;
};

Case makeCase(const std::string& name) {
  Case c;
  c.dir = test::tempDir(name);
  phantom::PhantomOptions o;
  o.dims = {32, 32, 40};
  c.ph = phantom::makePhantom(o);
  c.ct = c.dir / "ct.nrrd";
  c.labels = c.dir / "labels.nrrd";
  c.points = c.dir / "bend.json";
  io::saveVolume(c.ph.ct, c.ct);
  io::saveLabels(c.ph.labels, c.labels);
  c.bend.points = kneeBendTrack(c.ph.ct.geometry(), 25.0, 2.0, phantom::flexionAxisPointMm()).keyframes[1].points;
  saveControlPoints(c.bend, c.points);
  return c;
}

app::DeformRequest requestFor(const Case& c) {
  app::DeformRequest r;
  r.input = c.ct;
  r.points = c.points;
  r.output = c.dir / "out.nrrd";
  return r;
}

void runCli(std::vector<std::string> args) {
  CLI::App app{"vellum"};
  cli::addDeformCommand(app);
  app.require_subcommand(1);
  std::vector<const char*> argv{"vellum", "deform"};
  for (auto& a : args) argv.push_back(a.c_str());
  app.parse(static_cast<int>(argv.size()), argv.data());
}


}  // namespace

// runDeform wraps Deformer::update, applyRigidity and synthesize: the same voxels.
TEST(DeformPipeline, OutputIsTheLibrarysDeformerRigidityAndSynthesis) {
  const Case c = makeCase("app-deform-library");
  app::DeformRequest r = requestFor(c);
  r.engine.labels = c.labels.string();
  r.engine.rigidIds = kBones;
  r.engine.rigidFalloffMm = 6;
  r.engine.params.controlScale = 3;
  const app::DeformResult result = app::runDeform(r);

  const AnyVolume ct = c.ph.ct;
  DeformParams p;
  p.controlScale = 3;
  Deformer d(ct, p);
  d.setPoints(c.bend.points);
  ControlVolume cv = d.update();
  applyRigidity(cv, RigidBodies::fromLabels(c.ph.labels, kBones), {6.0});
  const AnyVolume expect = synthesize(ct, cv);
  ASSERT_TRUE(std::holds_alternative<VolumeI16>(result.output));
  EXPECT_EQ(std::get<VolumeI16>(result.output).voxels(), std::get<VolumeI16>(expect).voxels());
  EXPECT_NE(std::get<VolumeI16>(expect).voxels(), c.ph.ct.voxels()) << "the bend must move something";
  // What was written is what was returned.
  const auto written = io::loadVolume(r.output);
  EXPECT_EQ(std::get<VolumeI16>(written.volume).voxels(), std::get<VolumeI16>(expect).voxels());
  EXPECT_EQ(result.points, c.bend.points.size());
}

// `vellum deform FLAGS` fills the request the flags name: same file, voxel for voxel.
TEST(DeformPipeline, CliFlagsFillTheSameRequest) {
  const Case c = makeCase("app-deform-cli");
  app::DeformRequest r = requestFor(c);
  r.engine.params.controlScale = 4;
  r.engine.upsampling = Upsampling::Gaussian;
  r.engine.labels = c.labels.string();
  r.engine.rigidIds = kBones;
  r.engine.rigidFalloffMm = 4;
  r.mapOut = c.dir / "map-app.nrrd";
  app::runDeform(r);
  runCli({c.ct.string(), "--points", c.points.string(), "--out", (c.dir / "cli.nrrd").string(), "--control-scale", "4",
          "--upsampling", "gaussian", "--labels", c.labels.string(), "--rigid-labels", "4,5,6,7,8,9,11",
          "--rigid-falloff", "4", "--map-out", (c.dir / "map-cli.nrrd").string()});
  const auto a = io::loadVolume(r.output), b = io::loadVolume(c.dir / "cli.nrrd");
  EXPECT_EQ(std::get<VolumeI16>(a.volume).voxels(), std::get<VolumeI16>(b.volume).voxels());
  EXPECT_EQ(loadBackwardMapNrrd(r.mapOut), loadBackwardMapNrrd(c.dir / "map-cli.nrrd"));
}

// The keys docs/benchmarks-deformation.md and the scripts read.
TEST(DeformPipeline, ReportHasTheDocumentedKeys) {
  const Case c = makeCase("app-deform-report");
  app::DeformRequest r = requestFor(c);
  r.engine.labels = c.labels.string();
  r.engine.rigidIds = kBones;
  r.mapOut = c.dir / "map.nrrd";
  r.attributesOut = c.dir / "attributes.nrrd";
  r.report = c.dir / "report.json";
  r.psnr = true;
  const app::DeformResult result = app::runDeform(r);
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(r.report));
  EXPECT_EQ(j, result.report);
  for (const char* key : {"input", "output", "points", "dims", "params", "upsampling", "timings_ms", "cpu_ms",
                          "rigidity", "psnr_db_vs_s1"})
    EXPECT_TRUE(j.contains(key)) << key;
  for (const char* stage : {"load", "rigid_bodies", "density_build", "rho_cache", "control_volume", "rigidity",
                            "rigidity_measures", "synthesis", "save", "map_out", "total"})
    EXPECT_TRUE(j["timings_ms"].contains(stage)) << stage;
  double laps = 0;
  for (const char* stage : {"before_command", "points", "load", "control_volume", "rigidity", "synthesis", "psnr", "save"}) {
    ASSERT_TRUE(j["cpu_ms"].contains(stage)) << stage;
    laps += j["cpu_ms"][stage].get<double>();
  }
  EXPECT_LE(laps, j["cpu_ms"]["total"].get<double>() + 1e-6);
  for (const char* level : {"before", "before_nodes", "after", "after_nodes"})
    EXPECT_TRUE(j["rigidity"][level].contains("bone_rms_residual_mm")) << level;
  EXPECT_EQ(j["dims"], nlohmann::json({32, 32, 40}));
  EXPECT_EQ(j["points"].get<size_t>(), c.bend.points.size());
  EXPECT_EQ(j["upsampling"], "trilinear");
  EXPECT_EQ(j["params"]["control_scale"].get<double>(), 2.0);
  // The neutral attribute field (no point has attributes): dL* = da* = db* = 0, density 1.
  Geometry grid;
  const std::vector<float> field = loadAttributeFieldNrrd(r.attributesOut, &grid);
  ASSERT_FALSE(field.empty());
  for (size_t v = 0; v < field.size(); v += 4) ASSERT_EQ((std::array{field[v], field[v + 1], field[v + 2], field[v + 3]}),
                                                      (std::array{0.f, 0.f, 0.f, 1.f}));
}

// A point file's power stands unless the power was given, even at its default.
TEST(DeformPipeline, GivenPowerWinsOverThePointFiles) {
  Case c = makeCase("app-deform-power");
  c.bend.power = 3;
  saveControlPoints(c.bend, c.points);
  app::DeformRequest r = requestFor(c);
  EXPECT_EQ(app::runDeform(r).params.mls.power, 3.0);
  r.engine.powerGiven = true;  // params.mls.power keeps its default, 2
  EXPECT_EQ(app::runDeform(r).params.mls.power, 2.0);
}

TEST(DeformPipeline, BadRequestsNameTheFieldOrFile) {
  const Case c = makeCase("app-deform-bad");
  app::DeformRequest r = requestFor(c);
  r.points = c.dir / "missing.json";
  EXPECT_NE(errorOf([&] { app::runDeform(r); }).find("missing.json"), std::string::npos);
  r = requestFor(c);
  r.output = c.ct;
  EXPECT_NE(errorOf([&] { app::runDeform(r); }).find("refusing to overwrite an input"), std::string::npos);
  r = requestFor(c);
  r.engine.rigidityStride = 0;
  EXPECT_NE(errorOf([&] { app::runDeform(r); }).find("rigidity_stride"), std::string::npos);
  r = requestFor(c);
  r.engine.labels = c.labels.string();
  EXPECT_EQ(errorOf([&] { app::runDeform(r); }), "--labels needs --rigid-labels (the ids that stay rigid)");
  // A label map on another grid names the label file.
  phantom::PhantomOptions o;
  o.dims = {16, 16, 16};
  io::saveLabels(phantom::makePhantom(o).labels, c.dir / "small-labels.nrrd");
  r.engine.labels = (c.dir / "small-labels.nrrd").string();
  r.engine.rigidIds = kBones;
  const std::string m = errorOf([&] { app::runDeform(r); });
  EXPECT_NE(m.find("small-labels.nrrd"), std::string::npos) << m;
  EXPECT_NE(m.find("differs from the volume's"), std::string::npos) << m;
  // Bad control points name their file (vellum::test::fileErrorOf checks one line + the name).
  test::fileErrorOf([&](const fs::path& f) {
    app::DeformRequest bad = requestFor(c);
    bad.points = f;
    app::runDeform(bad);
  }, c.dir / "broken.json", "{\"points\": [");
  EXPECT_FALSE(fs::exists(r.output)) << "no output after a failed request";
}
