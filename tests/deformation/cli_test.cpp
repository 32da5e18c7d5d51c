// `vellum deform` / `vellum controls` end to end, through the same CLI11 wiring as main.cpp.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <zlib.h>

#include <cstring>
#include <iterator>

#include <fstream>

#include "commands.hpp"
#include "phantom_files.hpp"
#include "test_data.hpp"
#include "vellum/deformation/deformer.hpp"
#include "vellum/deformation/map_file.hpp"
#include "vellum/deformation/placement.hpp"
#include "vellum/deformation/rigidity.hpp"
#include "vellum/deformation/synthesis.hpp"
#include "vellum/deformation/point_files.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/phantom/phantom.hpp"

using namespace vellum;

namespace {

void run(std::vector<std::string> args) {
  CLI::App app{"vellum"};
  cli::addDeformCommand(app);
  cli::addControlsCommand(app);
  app.require_subcommand(1);
  std::vector<const char*> argv{"vellum"};
  for (auto& a : args) argv.push_back(a.c_str());
  app.parse(static_cast<int>(argv.size()), argv.data());
}

}  // namespace

TEST(DeformCli, ControlsThenDeformWithRigidBonesAndReport) {
  const auto dir = vellum::test::tempDir("deform-cli");
  const phantom::Phantom ph = vellum::test::writePhantomFiles(dir, {48, 48, 56}, "knee.nrrd");

  run({"controls", (dir / "knee.nrrd").string(), "--out", (dir / "cp.json").string()});
  auto pf = deformation::loadControlPoints(dir / "cp.json");
  ASSERT_EQ(pf.points.size(), 16u);
  // Bend: the same as the demo's strongest keyframe, written as a file.
  pf.points = deformation::kneeBendTrack(ph.ct.geometry(), 30.0, 2.0, phantom::flexionAxisPointMm()).keyframes[1].points;
  deformation::saveControlPoints(pf, dir / "bend.json");

  run({"deform", (dir / "knee.nrrd").string(), "--points", (dir / "bend.json").string(), "--out",
       (dir / "bent.nrrd").string(), "--map-out", (dir / "map.nrrd").string(), "--labels",
       (dir / "labels.nrrd").string(), "--rigid-labels", "4+5,6+7,8+11,9+11", "--report",
       (dir / "report.json").string(), "--psnr"});
  const auto out = io::loadVolume(dir / "bent.nrrd");
  ASSERT_TRUE(std::holds_alternative<VolumeI16>(out.volume));
  EXPECT_TRUE(geometryOf(out.volume).approxEqual(ph.ct.geometry()));
  EXPECT_NE(std::get<VolumeI16>(out.volume).voxels(), ph.ct.voxels());

  const nlohmann::json r = nlohmann::json::parse(std::ifstream(dir / "report.json"));
  for (const char* stage : {"load", "control_volume", "rigidity", "synthesis", "save", "map_out", "total"})
    EXPECT_TRUE(r["timings_ms"].contains(stage)) << stage;
  // Process CPU per stage: laps of one clock, so they add up to no more than the total.
  double laps = 0;
  for (const char* stage : {"before_command", "points", "load", "control_volume", "rigidity", "synthesis", "psnr", "save"}) {
    ASSERT_TRUE(r["cpu_ms"].contains(stage)) << stage;
    EXPECT_GE(r["cpu_ms"][stage].get<double>(), 0.0) << stage;
    laps += r["cpu_ms"][stage].get<double>();
  }
  EXPECT_LE(laps, r["cpu_ms"]["total"].get<double>() + 1e-6);
  EXPECT_EQ(r["rigidity"]["after"]["level"].get<std::string>(), "voxels");
  EXPECT_EQ(r["rigidity"]["after_nodes"]["level"].get<std::string>(), "control-grid nodes");
  EXPECT_EQ(r["rigidity"]["after"]["samples"].get<int64_t>(), 48 * 48 * 56);
  EXPECT_LT(r["rigidity"]["after"]["bone_rms_residual_mm"].get<double>(), 0.1);
  EXPECT_LT(r["rigidity"]["after_nodes"]["bone_rms_residual_mm"].get<double>(), 0.1);
  EXPECT_GT(r["rigidity"]["before"]["bone_rms_residual_mm"].get<double>(), 0.1);
  EXPECT_EQ(r["rigidity"]["after"]["fold_fraction"].get<double>(), 0.0);
  EXPECT_GT(r["psnr_db_vs_s1"].get<double>(), 35.0);

  // The map NRRD: header + 3 floats per voxel.
  std::ifstream m(dir / "map.nrrd", std::ios::binary);
  std::string line, header;
  while (std::getline(m, line) && !line.empty()) header += line + "\n";
  EXPECT_NE(header.find("sizes: 3 48 48 56"), std::string::npos) << header;
  EXPECT_NE(header.find("kinds: vector domain domain domain"), std::string::npos);
  EXPECT_NE(header.find("encoding: gzip"), std::string::npos);
  const auto pos = m.tellg();
  m.seekg(0, std::ios::end);
  EXPECT_LT(static_cast<int64_t>(m.tellg() - pos), int64_t{48} * 48 * 56 * 3 * 4);  // compressed
  // The values: the same map as the library computes (defaults: affine, s = 2, falloff 10 mm).
  Geometry mg;
  const std::vector<float> map = deformation::loadBackwardMapNrrd(dir / "map.nrrd", &mg);
  EXPECT_TRUE(mg.approxEqual(ph.ct.geometry(), 1e-9));
  const AnyVolume ct = ph.ct;
  deformation::ControlVolume cv = deformation::computeControlVolume(ct, pf.points, {});
  // One body per bone: cortex + marrow, and the shared cancellous id 11 split between the
  // fibula and the patella (at 48 voxels the cortex is in fragments: the flat list of ids
  // would make each id its own body).
  deformation::RigidityParams rp(10.0);
  rp.repairFolds = true;  // as deform runs it
  deformation::applyRigidity(cv, deformation::RigidBodies::fromLabelGroups(ph.labels, {{4, 5}, {6, 7}, {8, 11}, {9, 11}}),
                             rp);
  const std::vector<float> expect = deformation::upsampleMap(cv, ph.ct.geometry());
  ASSERT_EQ(map.size(), expect.size());
  double maxDiff = 0;
  for (size_t t = 0; t < map.size(); ++t) maxDiff = std::max(maxDiff, double(std::abs(map[t] - expect[t])));
  EXPECT_LT(maxDiff, 1e-3);

  // Bad input names the file.
  EXPECT_THROW(run({"deform", (dir / "knee.nrrd").string(), "--points", (dir / "nope.json").string(),
                    "--out", (dir / "x.nrrd").string()}),
               FileError);
  // Never overwrites the input.
  EXPECT_THROW(run({"deform", (dir / "knee.nrrd").string(), "--points", (dir / "bend.json").string(),
                    "--out", (dir / "knee.nrrd").string()}),
               Error);
}

// Issue 7: a given --power must win over the point file's, even when it equals the default.
TEST(DeformCli, GivenPowerOverridesThePointFilesPower) {
  const auto dir = vellum::test::tempDir("deform-power");
  phantom::PhantomOptions o;
  o.dims = {24, 24, 24};
  const auto ph = phantom::makePhantom(o);
  io::saveVolume(ph.ct, dir / "ct.nrrd");
  run({"controls", (dir / "ct.nrrd").string(), "--out", (dir / "cp.json").string()});
  auto pf = deformation::loadControlPoints(dir / "cp.json");
  pf.power = 3;
  pf.points[0].target = pf.points[0].source + Vec3{2, 0, 0};
  deformation::saveControlPoints(pf, dir / "p3.json");
  const auto powerUsed = [&](std::vector<std::string> extra) {
    std::vector<std::string> args{"deform", (dir / "ct.nrrd").string(), "--points", (dir / "p3.json").string(),
                                  "--out", (dir / "out.nrrd").string(), "--report", (dir / "r.json").string()};
    args.insert(args.end(), extra.begin(), extra.end());
    run(args);
    return nlohmann::json::parse(std::ifstream(dir / "r.json"))["params"]["power"].get<double>();
  };
  EXPECT_EQ(powerUsed({}), 3.0);                  // the file's
  EXPECT_EQ(powerUsed({"--power", "2"}), 2.0);    // given, equal to the default: still wins
  EXPECT_EQ(powerUsed({"--power", "4"}), 4.0);
}

// Issue 13: --downsample / --crop reduce the volume on load, and the command's label map
// gets the same region (else the rigid labels would not match the grid).
TEST(DeformCli, DownsampleAndCropApplyToTheVolumeAndItsLabels) {
  const auto dir = vellum::test::tempDir("deform-region");
  const phantom::Phantom ph = vellum::test::writePhantomFiles(dir, {32, 32, 40});
  run({"controls", (dir / "ct.nrrd").string(), "--out", (dir / "cp.json").string()});
  for (const std::vector<std::string>& region :
       {std::vector<std::string>{"--downsample", "2"}, std::vector<std::string>{"--crop", "4", "27", "0", "31", "8", "39"}}) {
    std::vector<std::string> args{"deform", (dir / "ct.nrrd").string(), "--points", (dir / "cp.json").string(),
                                  "--out", (dir / "out.nrrd").string(), "--labels", (dir / "labels.nrrd").string(),
                                  "--rigid-labels", "4,5,6,7,8,9,11"};
    args.insert(args.end(), region.begin(), region.end());
    run(args);
    const Geometry g = geometryOf(io::loadVolume(dir / "out.nrrd").volume);
    if (region[0] == "--downsample") {
      EXPECT_EQ(g.dims, (Dims{16, 16, 20}));
      EXPECT_NEAR(g.spacing.x, 2 * ph.ct.geometry().spacing.x, 1e-9);
    } else {
      EXPECT_EQ(g.dims, (Dims{24, 32, 32}));
      EXPECT_LT(norm(g.origin - ph.ct.geometry().indexToPhysical({4, 0, 8})), 1e-6);
    }
  }
}

// Issue 23 §4 (no cuts) and §6 (one gzip stream): a block of tissue near the +x face moves 8 mm
// out of the box. Without padding the box cuts it; with --pad-mm -1 (automatic, per side) only
// the +x side grows and every tissue voxel is in the output, at its world position + 8 mm. The map file is
// one gzip member (zlib inflates it in one go to its end) or raw with --no-gzip; both load.
TEST(DeformCli, PaddingKeepsEveryMovedVoxelAndTheMapIsOneGzipStream) {
  const auto dir = vellum::test::tempDir("deform-pad");
  Geometry g;
  g.dims = {32, 32, 32};
  g.spacing = {1, 1, 1};
  g.origin = {-10, 5, 20};
  VolumeI16 ct(g, -1000, -1000);
  int64_t tissue = 0;
  for (int64_t k = 8; k < 24; ++k)
    for (int64_t j = 8; j < 24; ++j)
      for (int64_t i = 4; i < 28; ++i) {
        ct(i, j, k) = static_cast<int16_t>(40 + i);  // values tell the voxels apart
        ++tissue;
      }
  io::saveVolume(ct, dir / "in.nrrd");
  const Vec3 shift{8, 0, 0};
  deformation::PointFile pf;
  for (int q = 0; q < 9; ++q) {
    const Vec3 idx = q == 8 ? Vec3{15.5, 15.5, 15.5} : Vec3{(q & 1) ? 31.0 : 0.0, (q & 2) ? 31.0 : 0.0, (q & 4) ? 31.0 : 0.0};
    const Vec3 s = g.indexToPhysical(idx);
    pf.points.push_back({s, s + shift, {}});
  }
  deformation::saveControlPoints(pf, dir / "cp.json");
  auto countTissue = [](const VolumeI16& v) {
    int64_t n = 0;
    for (int16_t x : v.voxels()) n += x > -500;
    return n;
  };
  run({"deform", (dir / "in.nrrd").string(), "--points", (dir / "cp.json").string(), "--out", (dir / "cut.nrrd").string()});
  const auto cut = std::get<VolumeI16>(io::loadVolume(dir / "cut.nrrd").volume);
  EXPECT_LT(countTissue(cut), tissue) << "the box should cut the moved block (else the test proves nothing)";

  run({"deform", (dir / "in.nrrd").string(), "--points", (dir / "cp.json").string(), "--out",
       (dir / "pad.nrrd").string(), "--pad-mm", "-1", "--map-out", (dir / "map.nrrd").string(), "--report",
       (dir / "pad.json").string()});
  const auto pad = std::get<VolumeI16>(io::loadVolume(dir / "pad.nrrd").volume);
  const Geometry& pg = pad.geometry();
  // Automatic: the block's +x face (x index 27) goes 4 voxels past the box's (31), + half a
  // lattice step and a control cell diagonal (0.5 + 2 x 1.73) -> 8 voxels above x, nothing else.
  EXPECT_EQ(pg.dims, (Dims{40, 32, 32}));
  EXPECT_LT(norm(pg.origin - g.origin), 1e-9);
  EXPECT_EQ(countTissue(pad), tissue);
  for (int64_t k = 8; k < 24; ++k)
    for (int64_t j = 8; j < 24; ++j)
      for (int64_t i = 4; i < 28; ++i) {
        const Vec3 o = pg.physicalToIndex(g.indexToPhysical({double(i), double(j), double(k)}) + shift);
        ASSERT_EQ(pad(std::llround(o.x), std::llround(o.y), std::llround(o.z)), ct(i, j, k)) << i << "," << j << "," << k;
      }
  const nlohmann::json r = nlohmann::json::parse(std::ifstream(dir / "pad.json"));
  EXPECT_EQ(r["pad_voxels"]["low"], nlohmann::json({0, 0, 0}));
  EXPECT_EQ(r["pad_voxels"]["high"], nlohmann::json({8, 0, 0}));

  // The map: one gzip member after the header, which zlib inflates to exactly the map's bytes.
  std::ifstream m(dir / "map.nrrd", std::ios::binary);
  const std::string file((std::istreambuf_iterator<char>(m)), std::istreambuf_iterator<char>());
  const size_t body = file.find("\n\n") + 2;
  ASSERT_NE(file.find("encoding: gzip"), std::string::npos);
  std::vector<uint8_t> bytes(size_t{40} * 32 * 32 * 3 * 4 + 16);
  z_stream zs{};
  inflateInit2(&zs, 15 + 16);
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(file.data() + body));
  zs.avail_in = static_cast<uInt>(file.size() - body);
  zs.next_out = bytes.data();
  zs.avail_out = static_cast<uInt>(bytes.size());
  EXPECT_EQ(inflate(&zs, Z_FINISH), Z_STREAM_END);
  EXPECT_EQ(zs.total_in, file.size() - body) << "more than one gzip member";
  EXPECT_EQ(zs.total_out, size_t{40} * 32 * 32 * 3 * 4);
  inflateEnd(&zs);
  Geometry mg;
  const std::vector<float> map = deformation::loadBackwardMapNrrd(dir / "map.nrrd", &mg);
  EXPECT_TRUE(mg.approxEqual(pg, 1e-9));
  EXPECT_EQ(std::memcmp(map.data(), bytes.data(), map.size() * sizeof(float)), 0);
  // --no-gzip: raw, the same values.
  run({"deform", (dir / "in.nrrd").string(), "--points", (dir / "cp.json").string(), "--out",
       (dir / "raw.nrrd").string(), "--pad-mm", "-1", "--map-out", (dir / "map-raw.nrrd").string(), "--no-gzip"});
  std::ifstream mr(dir / "map-raw.nrrd", std::ios::binary);
  const std::string rawFile((std::istreambuf_iterator<char>(mr)), std::istreambuf_iterator<char>());
  EXPECT_NE(rawFile.find("encoding: raw"), std::string::npos);
  EXPECT_EQ(deformation::loadBackwardMapNrrd(dir / "map-raw.nrrd"), map);
  EXPECT_EQ(std::get<VolumeI16>(io::loadVolume(dir / "raw.nrrd").volume).voxels(), pad.voxels());
  // A label map on the input's grid is padded with the volume: the block as a rigid bone.
  LabelVolume labels(g);
  for (int64_t t = 0; t < g.dims.voxelCount(); ++t) labels.ids().data()[t] = ct.data()[t] > -500 ? 2 : 0;
  io::saveLabels(labels, dir / "labels.nrrd");
  run({"deform", (dir / "in.nrrd").string(), "--points", (dir / "cp.json").string(), "--out", (dir / "bone.nrrd").string(),
       "--pad-mm", "10", "--labels", (dir / "labels.nrrd").string(), "--rigid-labels", "2", "--report",
       (dir / "bone.json").string()});
  const nlohmann::json b = nlohmann::json::parse(std::ifstream(dir / "bone.json"));
  EXPECT_EQ(b["pad_voxels"]["low"], nlohmann::json({10, 10, 10}));
  EXPECT_EQ(b["pad_voxels"]["high"], nlohmann::json({10, 10, 10}));
  EXPECT_EQ(b["rigidity"]["after"]["bodies"][0]["samples"].get<int64_t>(), tissue);
  EXPECT_LT(b["rigidity"]["after"]["bone_rms_residual_mm"].get<double>(), 1e-3);
  EXPECT_EQ(countTissue(std::get<VolumeI16>(io::loadVolume(dir / "bone.nrrd").volume)), tissue);
}
