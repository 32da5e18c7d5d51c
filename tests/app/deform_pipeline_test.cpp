// The deformation request shared by `vellum deform` (and, for its engine, `vellum animate`):
// runDeform is the library's Deformer + rigidity + synthesis, the CLI's flags fill the same
// request, bad requests fail in one line naming the field or file, the report keeps its keys.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <fstream>

#include "commands.hpp"
#include "file_errors.hpp"
#include "knee_on_disk.hpp"
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

const std::vector<uint16_t>& kBones = test::kKneeBones;

/// The knee on disk and a bend of the tibia as a point file.
struct Case : test::KneeOnDisk {
  explicit Case(const std::string& name) : KneeOnDisk(test::writeKnee(name)) {}
  fs::path points;
  PointFile bend;
};

Case makeCase(const std::string& name) {
  Case c(name);
  c.points = c.dir / "bend.json";
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
  EXPECT_EQ(errorOf([&] { app::runDeform(r); }),
            "--labels needs --rigid-labels (the ids that stay rigid) or --fixed-labels / --fixed-box");
  r.engine.labels.clear();
  r.engine.fixedIds = {3};
  EXPECT_NE(errorOf([&] { app::runDeform(r); }).find("need --labels"), std::string::npos);
  r.engine.fixedIds.clear();
  r.engine.labels = c.labels.string();
  r.engine.rigidIds = {3};
  r.engine.fixedIds = {3};
  EXPECT_EQ(errorOf([&] { app::runDeform(r); }), "label 3 is both rigid and fixed");
  r.engine.rigidIds.clear();
  r.engine.fixedIds.clear();
  r.engine.fixedBoxMm = {1, 2, 3};
  EXPECT_NE(errorOf([&] { app::runDeform(r); }).find("6 numbers"), std::string::npos);
  r.engine.fixedBoxMm = {500, 500, 500, 600, 600, 600};
  EXPECT_NE(errorOf([&] { app::runDeform(r); }).find("hold no voxel"), std::string::npos);
  r.engine.fixedBoxMm.clear();
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

// The report per body, the fixed regions and "not measured": a bone-only label map has no
// soft tissue, so its displacement is null with a reason (not "moved 0 mm"); the fixed label
// and box move 0 and their voxels are the input's; the CLI's --fixed-labels / --fixed-box
// fill the same request.
TEST(DeformPipeline, ReportsPerBodyFixedRegionsAndWhatWasNotMeasured) {
  const Case c = makeCase("app-deform-honest");
  // Bone-only: every non-bone id cleared.
  LabelVolume bones = c.ph.labels;
  for (auto& id : bones.ids().voxels())
    if (!phantom::isBone(id)) id = 0;
  io::saveLabels(bones, c.dir / "bones.nrrd");
  app::DeformRequest r = requestFor(c);
  r.engine.labels = (c.dir / "bones.nrrd").string();
  r.engine.setRigidLabels({"4+5", "6+7", "8+11", "9+11"});
  r.report = c.dir / "bones.json";
  const nlohmann::json j = app::runDeform(r).report;
  const nlohmann::json& after = j["rigidity"]["after"];
  EXPECT_EQ(after["soft_tissue_samples"], 0);
  EXPECT_TRUE(after["soft_tissue_mean_displacement_mm"].is_null());
  EXPECT_TRUE(after["not_measured"].contains("soft_tissue_mean_displacement_mm"));
  EXPECT_TRUE(after["fixed"].is_null());
  EXPECT_TRUE(after["not_measured"].contains("fixed"));
  EXPECT_TRUE(after["fold_fraction"].is_number()) << "bone is tissue: folds are measured";
  // One entry per bone (femur 4+5, tibia 6+7, fibula 8+11, patella 9+11; at 32 voxels the
  // fibula's and patella's cortex has no voxel: 11 goes to the first group), each with its fit.
  ASSERT_EQ(after["bodies"].size(), j["rigid_bodies"].size());
  ASSERT_GE(after["bodies"].size(), 3u);
  EXPECT_EQ(after["bodies"][0]["ids"], nlohmann::json({4, 5}));
  for (const auto& b : after["bodies"]) {
    EXPECT_TRUE(b["rms_residual_mm"].is_number()) << b.dump();
    EXPECT_LT(b["rms_residual_mm"].get<double>(), 0.5) << b.dump();
    EXPECT_TRUE(b["rotation_deg"].is_number()) << b.dump();
  }
  EXPECT_EQ(j["rigid_bodies"][1]["ids"], nlohmann::json({6, 7}));
  // The flat list: one body per id (and the --rigid-labels syntax round-trips).
  app::DeformEngine e;
  e.setRigidLabels({"4+5", "6", "8+11", "9+11"});
  EXPECT_EQ(e.rigidLabelsArgument(), "4+5,8+11,9+11,6");
  EXPECT_THROW(e.setRigidLabels({"4+"}), Error);
  EXPECT_THROW(e.setRigidLabels({"x"}), Error);

  // The whole leg, the femur's muscle fixed by label and the thigh's top by a box (mm).
  const Geometry& g = c.ph.ct.geometry();
  const Vec3 lo = g.indexToPhysical({0, 0, 32}), hi = g.indexToPhysical({31, 31, 39});
  const std::string box = std::to_string(lo.x) + "," + std::to_string(lo.y) + "," + std::to_string(lo.z) + "," +
                          std::to_string(hi.x) + "," + std::to_string(hi.y) + "," + std::to_string(hi.z);
  const fs::path out = c.dir / "fixed.nrrd", report = c.dir / "fixed.json";
  runCli({c.ct.string(), "--points", c.points.string(), "--out", out.string(), "--labels", c.labels.string(),
          "--rigid-labels", "6+7,8+11,9+11", "--fixed-labels", "4,5", "--fixed-box", box, "--report", report.string()});
  const nlohmann::json f = nlohmann::json::parse(std::ifstream(report));
  const nlohmann::json& fa = f["rigidity"]["after"];
  EXPECT_GT(fa["fixed"]["samples"].get<int64_t>(), 1000);
  EXPECT_LT(fa["fixed"]["max_displacement_mm"].get<double>(), 1e-4);
  EXPECT_TRUE(fa["soft_tissue_mean_displacement_mm"].is_number());
  EXPECT_TRUE(f["rigid_bodies"].back()["fixed"].get<bool>());
  EXPECT_EQ(f["rigid_bodies"].back()["ids"], nlohmann::json({4, 5}));
  const auto moved = io::loadVolume(out);
  const auto& v = std::get<VolumeI16>(moved.volume);
  int64_t checked = 0;
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t jj = 0; jj < g.dims.y; ++jj)
      for (int64_t i = 0; i < g.dims.x; ++i) {
        const uint16_t id = c.ph.labels(i, jj, k);
        if (id != 4 && id != 5 && k < 32) continue;
        ++checked;
        ASSERT_EQ(v(i, jj, k), c.ph.ct(i, jj, k)) << "fixed voxel " << i << "," << jj << "," << k << " changed";
      }
  EXPECT_GT(checked, 32 * 32 * 8);
  EXPECT_NE(v.voxels(), c.ph.ct.voxels()) << "the bend must still move the calf";
}
