// `vellum shape` end to end on a small phantom.
#include <gtest/gtest.h>

#include <cstdlib>
#include <sys/wait.h>
#include <fstream>
#include <nlohmann/json.hpp>

#include "child_process.hpp"
#include "phantom_files.hpp"
#include "test_data.hpp"
#include "vellum/illustration/shape.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/phantom/phantom.hpp"

using namespace vellum;
namespace fs = std::filesystem;
namespace ill = vellum::illustration;

namespace {
int run(const std::string& args, const fs::path& log) {
  const std::string cmd = std::string(VELLUM_CLI_PATH) + " shape " + args + " > " + log.string() + " 2>&1";
  return std::system(cmd.c_str());
}
std::string slurp(const fs::path& p) {
  std::ifstream f(p);
  return {std::istreambuf_iterator<char>(f), {}};
}
}  // namespace

TEST(ShapeCli, EndToEndOnPhantom) {
  const fs::path dir = test::tempDir("shape-cli");
  const phantom::Phantom ph = test::writePhantomFiles(dir, {48, 48, 48});
  const fs::path out = dir / "shape";
  const std::string base = (dir / "ct.nrrd").string() + " --labels " + (dir / "labels.nrrd").string();
  ASSERT_EQ(run(base + " --segment body=1,2,3,4,5,6,7,8,9,10,11 --segment femur=4,5 --segment 3"
                       " --shell femur:2 --grow muscle:-0.5 --target-faces 4000 --mesh-format stl --out " +
                    out.string() + " --report " + (dir / "r.json").string(),
                dir / "log.txt"),
            0)
      << slurp(dir / "log.txt");
  for (const char* f : {"distance.nrrd", "segments.nrrd", "shape.json", "meshes/body.stl",
                        "meshes/femur.stl", "meshes/muscle.stl", "distances.json", "distance-1.nrrd",
                        "distance-2.nrrd", "distance-3.nrrd"})
    EXPECT_TRUE(fs::exists(out / f)) << f;
  EXPECT_TRUE(fs::exists(dir / "r.json"));
  const auto j = nlohmann::json::parse(slurp(out / "shape.json"));
  ASSERT_EQ(j["segments"].size(), 3u);
  EXPECT_EQ(j["segments"][2]["name"], "muscle");
  for (const auto& s : j["segments"]) {
    EXPECT_TRUE(s["closed"].get<bool>()) << s["name"];
    EXPECT_TRUE(s["manifold"].get<bool>()) << s["name"];
    EXPECT_EQ(s["self_intersections"].get<int>(), 0) << s["name"];
    const double ratio = s["volume_mm3"].get<double>() / s["voxel_volume_mm3"].get<double>();
    EXPECT_GT(ratio, 0.8) << s["name"];
    EXPECT_LT(ratio, 1.25) << s["name"];
    EXPECT_GT(s["max_boundary_distance_mm"].get<double>(), 0.0);
  }
  EXPECT_LE(j["segments"][0]["faces"].get<int>(), 4000);  // muscle's constraints may stop above
  for (const char* stage : {"denoise", "mesh", "process", "distances", "segmentation", "write"})
    EXPECT_GE(j["timings_ms"][stage].get<double>(), 0.0) << stage;
  // STL binary size: 84 + 50 bytes a face.
  EXPECT_EQ(fs::file_size(out / "meshes/femur.stl"), 84u + 50u * j["segments"][1]["faces"].get<uint64_t>());

  const LabelVolume seg = io::loadLabels(out / "segments.nrrd");
  ASSERT_EQ(seg.table().size(), 4u);
  EXPECT_EQ(seg.table()[0].name, "body");
  EXPECT_EQ(seg.table()[1].name, "femur");
  EXPECT_EQ(seg.table()[2].name, "muscle");
  EXPECT_EQ(seg.table()[3].name, "femur boundary");
  const auto hist = seg.histogram();
  ASSERT_GE(hist.size(), 5u);
  for (int id = 1; id <= 4; ++id) EXPECT_GT(hist[id], 0u) << id;
  // Painter's order: femur and muscle (listed after body) paint over it; femur's outer 2 mm
  // are its boundary segment.
  EXPECT_GT(hist[1], 0u);
  EXPECT_GT(hist[4], 0u);
  const auto dist = io::loadVolume(out / "distance.nrrd");
  EXPECT_TRUE(std::holds_alternative<VolumeF32>(dist.volume));
  const auto& d = std::get<VolumeF32>(dist.volume);
  EXPECT_TRUE(d.geometry().approxEqual(ph.ct.geometry()));
  // Inside the union negative, outside positive.
  for (size_t n = 0; n < d.size(); n += 97)
    EXPECT_EQ(d.data()[n] < 0, seg.ids().data()[n] != 0) << n;
  // Per-segment fields: femur (id 2) with its 2 mm shell (id 4); negative where its voxels are.
  const auto fields = ill::loadSegmentFields(out);
  ASSERT_EQ(fields.size(), 3u);
  EXPECT_EQ(fields[1].name, "femur");
  EXPECT_EQ(fields[1].shellId, 4);
  EXPECT_FLOAT_EQ(fields[1].shellMm, 2.0f);
  for (size_t n = 0; n < d.size(); n += 97) {
    const auto id = seg.ids().data()[n];
    if (id == 2 || id == 4) {
      EXPECT_LT(fields[1].distance.data()[n], 0) << n;
    }
  }
}

TEST(ShapeCli, BadSegmentSpecsGiveOneLineErrors) {
  const fs::path dir = test::tempDir("shape-cli-errors");
  test::writePhantomFiles(dir, {24, 24, 24});
  const std::string base = (dir / "ct.nrrd").string() + " --labels " + (dir / "labels.nrrd").string() +
                           " --out " + (dir / "o").string();
  struct Case { std::string args, needle; };
  for (const Case& c : {Case{" --segment bone=99", "unknown label id 99"},
                        Case{" --segment bone=4,x", "'x' is not a label id"},
                        Case{" --segment bone=4 --shell nope:1", "unknown segment 'nope'"},
                        Case{" --segment bone=4 --grow bone:abc", "is not a number"},
                        Case{" --segment 4,5", "need a name"}}) {
    EXPECT_NE(run(base + c.args, dir / "log.txt"), 0) << c.args;
    const std::string log = slurp(dir / "log.txt");
    EXPECT_NE(log.find(c.needle), std::string::npos) << c.args << ": " << log;
    EXPECT_LE(std::count(log.begin(), log.end(), '\n'), 1) << log;
  }
}

TEST(ShapeCli, AMissingOpenVdbModuleIsAOneLineError) {
  // OpenVDB is a module opened on first use: without it `vellum shape` must say which file it
  // could not load, in one line, and write nothing.
  const fs::path dir = test::tempDir("shape-cli-module");
  test::writePhantomFiles(dir, {24, 24, 24});
  const fs::path missing = dir / "no-such-module.so";
  const std::string cmd = "VELLUM_VDB_MODULE='" + missing.string() + "' " + std::string(VELLUM_CLI_PATH) + " shape " +
                          (dir / "ct.nrrd").string() + " --labels " + (dir / "labels.nrrd").string() +
                          " --segment bone=4 --out " + (dir / "o").string() + " > " + (dir / "log.txt").string() +
                          " 2>&1";
  EXPECT_NE(std::system(cmd.c_str()), 0);
  const std::string log = slurp(dir / "log.txt");
  EXPECT_NE(log.find("cannot load the OpenVDB module " + missing.string()), std::string::npos) << log;
  EXPECT_LE(std::count(log.begin(), log.end(), '\n'), 1) << log;
  EXPECT_FALSE(fs::exists(dir / "o" / "shape.json"));
}

TEST(ShapeCli, InterruptExitsCleanly) {
  // SIGINT in the middle of the pipeline: exit 130 ("cancelled"), no shape.json, no
  // temporaries (never a crash: cancellation is checked between stages, outside TBB tasks).
  const fs::path dir = test::tempDir("shape-cli-interrupt");
  test::writePhantomFiles(dir, {160, 160, 160});
  test::Child child({"shape", (dir / "ct.nrrd").string(), "--labels", (dir / "labels.nrrd").string(), "--segment",
                     "body=1,2,3,4,5,6,7,8,9,10,11", "--segment", "muscle=3", "--out", (dir / "o").string()},
                    dir / "log.txt");
  ASSERT_TRUE(child.waitUntilCatching(SIGINT));  // not before the handler is there
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  ::kill(child.pid, SIGINT);
  const int rc = child.wait();
  if (rc == 0) GTEST_SKIP() << "finished before the interrupt (fast machine)";
  EXPECT_EQ(rc, 130) << slurp(dir / "log.txt");
  EXPECT_NE(slurp(dir / "log.txt").find("cancelled"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir / "o" / "shape.json"));
  for (const auto& e : fs::recursive_directory_iterator(dir))
    EXPECT_EQ(e.path().filename().string().find(".vellum-tmp-"), std::string::npos) << e.path();
}

// Issue 12: labels thresholded from a real scan include the CT table; --remove-table keeps
// only what lies in the body, so the table gets no mesh.
TEST(ShapeCli, RemoveTableDropsLabelledTableVoxels) {
  const fs::path dir = test::tempDir("shape-cli-table");
  phantom::PhantomOptions po;
  po.dims = {48, 48, 48};
  auto ph = phantom::makePhantom(po);
  int64_t yMax = 0;
  for (int64_t k = 0; k < 48; ++k)
    for (int64_t j = 0; j < 48; ++j)
      for (int64_t i = 0; i < 48; ++i)
        if (ph.labels(i, j, k) != phantom::kAir) yMax = std::max(yMax, j);
  ASSERT_LT(yMax + 5, 48);
  for (int64_t k = 0; k < 48; ++k)  // a table slab behind the leg, labelled like bone
    for (int64_t j = yMax + 3; j <= yMax + 5; ++j)
      for (int64_t i = 0; i < 48; ++i) ph.ct(i, j, k) = 400, ph.labels(i, j, k) = phantom::kFemurCortex;
  io::saveVolume(ph.ct, dir / "ct.nrrd");
  io::saveLabels(ph.labels, dir / "labels.nrrd");
  const std::string base = (dir / "ct.nrrd").string() + " --labels " + (dir / "labels.nrrd").string() +
                           " --segment femur=4,5 --target-faces 4000";
  ASSERT_EQ(run(base + " --out " + (dir / "with").string(), dir / "log1.txt"), 0) << slurp(dir / "log1.txt");
  ASSERT_EQ(run(base + " --remove-table --out " + (dir / "without").string(), dir / "log2.txt"), 0)
      << slurp(dir / "log2.txt");
  const auto volume = [&](const char* folder) {
    const auto j = nlohmann::json::parse(std::ifstream(dir / folder / "shape.json"));
    return j["segments"][0]["voxel_volume_mm3"].get<double>();
  };
  // The slab (48 x 3 x 48 voxels) is most of "femur" with the table; without it only the femur.
  EXPECT_GT(volume("with"), 1.5 * volume("without"));
  int64_t femurVoxels = 0;
  const auto clean = phantom::makePhantom(po);  // the labels before the table was added
  for (uint16_t id : clean.labels.ids().voxels()) femurVoxels += id == 4 || id == 5;
  const double voxelMm3 = ph.ct.geometry().spacing.x * ph.ct.geometry().spacing.y * ph.ct.geometry().spacing.z;
  EXPECT_NEAR(volume("without"), femurVoxels * voxelMm3, 0.01 * femurVoxels * voxelMm3);
}

// Issue 13: --crop / --downsample reduce the CT on load and the label map gets the same
// region, so shape (and illustrate, given the same flags) work on a region of a big scan.
TEST(ShapeCli, CropAndDownsampleApplyToTheLabelsToo) {
  const fs::path dir = test::tempDir("shape-cli-region");
  const phantom::Phantom ph = test::writePhantomFiles(dir, {40, 40, 48});
  const std::string base = (dir / "ct.nrrd").string() + " --labels " + (dir / "labels.nrrd").string() +
                           " --segment body=1,2,3,4,5,6,7,8,9,10,11 --target-faces 2000 --out ";
  struct Case { std::string flags; Dims dims; Vec3 originVoxel; double spacingFactor; };
  for (const Case& c : {Case{" --crop 4 35 2 37 8 47", {32, 36, 40}, {4, 2, 8}, 1.0},
                        Case{" --downsample 2", {20, 20, 24}, {0.5, 0.5, 0.5}, 2.0}}) {
    const fs::path out = dir / "shape";
    ASSERT_EQ(run(base + out.string() + c.flags, dir / "log.txt"), 0) << c.flags << slurp(dir / "log.txt");
    const LabelVolume seg = io::loadLabels(out / "segments.nrrd");
    EXPECT_EQ(seg.geometry().dims, c.dims) << c.flags;
    EXPECT_NEAR(seg.geometry().spacing.x, c.spacingFactor * ph.ct.geometry().spacing.x, 1e-9) << c.flags;
    EXPECT_LT(norm(seg.geometry().origin - ph.ct.geometry().indexToPhysical(c.originVoxel)), 1e-6) << c.flags;
    const auto dist = io::loadVolume(out / "distance.nrrd");
    EXPECT_TRUE(geometryOf(dist.volume).approxEqual(seg.geometry())) << c.flags;
    // The cropped body matches the cropped source labels voxel for voxel where they are clear.
    if (c.spacingFactor == 1.0) {
      int64_t agree = 0, total = 0;
      for (int64_t k = 0; k < c.dims.z; ++k)
        for (int64_t j = 0; j < c.dims.y; ++j)
          for (int64_t i = 0; i < c.dims.x; ++i, ++total)
            agree += (seg.ids()(i, j, k) != 0) == (ph.labels.ids()(i + 4, j + 2, k + 8) != 0);
      EXPECT_GT(double(agree) / double(total), 0.97) << c.flags;
    }
    fs::remove_all(out);
  }
}
