// `vellum compare`'s numbers against hand-computed ones, and its exit codes.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "test_volumes.hpp"
#include "child_process.hpp"
#include "test_data.hpp"
#include "vellum/app/compare.hpp"
#include "vellum/core/json_input.hpp"
#include "vellum/io/image_io.hpp"
#include "vellum/io/volume_io.hpp"

using namespace vellum;
namespace fs = std::filesystem;

namespace {

/// A 10-voxel cube of label `id` at i0.. in a 24x20x20 grid of spacing 0.5 x 1 x 2 mm.
LabelVolume cube(int i0, uint16_t id = 1) {
  LabelVolume l(test::grid({24, 20, 20}, {0.5, 1.0, 2.0}));
  return test::fillWhere(l, test::voxelBox(i0, i0 + 10, 5, 15, 5, 15), id);
}

RgbaImage flat(int w, int h, uint8_t v) {
  RgbaImage im(w, h);
  for (size_t p = 0; p < im.pixels.size(); p += 4) {
    im.pixels[p] = im.pixels[p + 1] = im.pixels[p + 2] = v;
    im.pixels[p + 3] = 255;
  }
  return im;
}

int runVellum(const std::vector<std::string>& args, const fs::path& dir, std::string* log = nullptr) {
  const int rc = test::Child(args, dir / "log.txt").wait();
  if (log) *log = test::readAll(dir / "log.txt");
  fs::remove(dir / "log.txt");
  return rc;
}

}  // namespace

// A cube shifted by one voxel along x (0.5 mm): |A∩B| = 9/10 of each, so Dice 0.9, Jaccard
// 900/1100. Boundary voxels (6-neighbour): 10³ - 8³ = 488 per cube. Distances to the other
// surface are 0.5 mm for the 100 voxels of the trailing face and the 64 inner voxels of the
// leading face (the next face voxel along x; the y and z faces are >= 1 mm away), 0 for the
// rest (shared y/z faces). HD95 (nearest rank 464 of 488) = 0.5 mm, ASSD = 0.5 * 164 / 488.
TEST(Compare, MaskShiftedByOneVoxel) {
  const fs::path dir = test::tempDir("qa-compare-shift");
  io::saveLabels(cube(5), dir / "a.nrrd");
  io::saveLabels(cube(6), dir / "b.nrrd");
  app::CompareRequest q;
  q.a = dir / "a.nrrd";
  q.b = dir / "b.nrrd";
  const app::CompareResult r = app::compareFiles(q);
  EXPECT_EQ(r.kind, app::CompareKind::Labels);
  ASSERT_EQ(r.report["labels"].size(), 1u);
  const auto& m = r.report["labels"][0];
  EXPECT_EQ(m["id"].get<int>(), 1);
  EXPECT_DOUBLE_EQ(m["dice"].get<double>(), 0.9);
  EXPECT_DOUBLE_EQ(m["jaccard"].get<double>(), 900.0 / 1100.0);
  EXPECT_DOUBLE_EQ(m["hd95_mm"].get<double>(), 0.5);
  EXPECT_DOUBLE_EQ(m["hausdorff_mm"].get<double>(), 0.5);
  EXPECT_NEAR(m["assd_mm"].get<double>(), 0.5 * 164.0 / 488.0, 1e-12);
  EXPECT_DOUBLE_EQ(m["volume_difference_mm3"].get<double>(), 0.0);
  EXPECT_DOUBLE_EQ(m["volume_a_mm3"].get<double>(), 1000.0);  // 1000 voxels of 1 mm³
  EXPECT_FALSE(r.pass);  // the default minimum Dice is 1
  ASSERT_EQ(r.failures.size(), 1u);
  EXPECT_NE(r.failures[0].find("Dice 0.9"), std::string::npos) << r.failures[0];
  // Within tolerances: Dice >= 0.85 and HD95 <= 0.5 mm pass; HD95 <= 0.4 mm does not.
  q.tolerances.minDice = 0.85;
  q.tolerances.maxHd95Mm = 0.5;
  EXPECT_TRUE(app::compareFiles(q).pass);
  q.tolerances.maxHd95Mm = 0.4;
  EXPECT_FALSE(app::compareFiles(q).pass);
}

TEST(Compare, PerLabelIdsAndIdGroups) {
  const fs::path dir = test::tempDir("qa-compare-ids");
  LabelVolume a = cube(5, 2), b = cube(5, 3);
  io::saveLabels(a, dir / "a.nrrd");
  io::saveLabels(b, dir / "b.nrrd");
  app::CompareRequest q;
  q.a = dir / "a.nrrd";
  q.b = dir / "b.nrrd";
  app::CompareResult r = app::compareFiles(q);  // ids 2 and 3 each present on one side only
  ASSERT_EQ(r.report["labels"].size(), 2u);
  EXPECT_EQ(r.report["labels"][0]["dice"].get<double>(), 0.0);
  EXPECT_TRUE(r.report["labels"][0]["hd95_mm"].is_null());  // one side empty: infinite
  q.ids = {2};
  EXPECT_EQ(app::compareFiles(q).report["labels"].size(), 1u);
  q.ids.clear();
  q.aIds = {2};
  q.bIds = {3};  // the same cube under another id
  r = app::compareFiles(q);
  ASSERT_EQ(r.report["labels"].size(), 1u);
  EXPECT_EQ(r.report["labels"][0]["dice"].get<double>(), 1.0);
  EXPECT_TRUE(r.pass);
}

// A 64x64 grey image and a copy with an 8x8 patch 50 brighter: 64 of 4096 pixels differ by 50.
TEST(Compare, ImageWithAKnownPatch) {
  const RgbaImage a = flat(64, 64, 100);
  RgbaImage b = a;
  for (int y = 10; y < 18; ++y)
    for (int x = 20; x < 28; ++x) b.at(x, y)[0] = b.at(x, y)[1] = b.at(x, y)[2] = 150;
  app::CompareTolerances t;
  app::ImageDiff d = app::diffImages(a, b, t);
  EXPECT_EQ(d.maxDifference, 50.0);
  EXPECT_DOUBLE_EQ(d.meanDifference, 50.0 * 64 / 4096);
  EXPECT_EQ(d.differingPixels, 64);
  EXPECT_DOUBLE_EQ(d.differingPercent, 100.0 * 64 / 4096);
  EXPECT_EQ(d.percentileDifference, 50.0);  // 1.56% of pixels differ: the 99th percentile is one
  // MSE over the RGB samples = 64 * 3 * 50² / (3 * 4096).
  EXPECT_NEAR(d.psnrDb, 10 * std::log10(255.0 * 255.0 / (64.0 * 2500 / 4096)), 1e-9);
  EXPECT_GT(d.ssim, 0.5);
  EXPECT_LT(d.ssim, 1.0);
  t.percentile = 98;
  EXPECT_EQ(app::diffImages(a, b, t).percentileDifference, 0.0);
  t.tolerance = 50;  // a difference of exactly the tolerance is within it
  EXPECT_EQ(app::diffImages(a, b, t).differingPixels, 0);
  // The heat map is dark where nothing changed and bright on the patch.
  const uint8_t* quiet = d.heatmap.at(0, 0);
  const uint8_t* loud = d.heatmap.at(22, 12);
  EXPECT_LT(quiet[0] + quiet[1] + quiet[2], 120);
  EXPECT_GT(loud[0] + loud[1] + loud[2], 300);

  const app::ImageDiff same = app::diffImages(a, a, {});
  EXPECT_EQ(same.maxDifference, 0.0);
  EXPECT_TRUE(std::isinf(same.psnrDb));
  EXPECT_DOUBLE_EQ(same.ssim, 1.0);
  EXPECT_THROW(app::diffImages(a, flat(32, 64, 100), {}), Error);
}

TEST(Compare, VolumesGeometryAndHuDifferences) {
  const fs::path dir = test::tempDir("qa-compare-volume");
  Geometry g;
  g.dims = {16, 12, 8};
  g.spacing = {0.7, 0.7, 2.5};
  VolumeI16 a(g, 40, kCtAirHu);
  VolumeI16 b = a;
  b(3, 4, 5) = 140;  // one voxel 100 HU off
  b(7, 1, 2) = 50;   // one 10 HU off
  io::saveVolume(a, dir / "a.nrrd");
  io::saveVolume(b, dir / "b.mha");
  app::CompareRequest q;
  q.a = dir / "a.nrrd";
  q.b = dir / "b.mha";
  app::CompareResult r = app::compareFiles(q);
  EXPECT_EQ(r.kind, app::CompareKind::Volume);
  const auto& v = r.report["volume"];
  EXPECT_TRUE(v["geometry_equal"].get<bool>());
  EXPECT_EQ(v["max_abs_difference"].get<double>(), 100.0);
  EXPECT_DOUBLE_EQ(v["mean_abs_difference"].get<double>(), 110.0 / (16 * 12 * 8));
  EXPECT_EQ(v["differing_voxels"].get<int64_t>(), 2);
  EXPECT_EQ(v["max_at_index"], nlohmann::json({3, 4, 5}));
  EXPECT_EQ(v["unit"], "HU");
  EXPECT_FALSE(r.pass);
  q.tolerances.tolerance = 100;
  EXPECT_TRUE(app::compareFiles(q).pass);
  // Another grid: a difference (exit 1), not an error.
  Geometry g2 = g;
  g2.spacing.z = 3.0;
  VolumeI16 c(g2, 40, kCtAirHu);
  io::saveVolume(c, dir / "c.nrrd");
  q.b = dir / "c.nrrd";
  r = app::compareFiles(q);
  EXPECT_FALSE(r.pass);
  EXPECT_FALSE(r.report["volume"]["geometry_equal"].get<bool>());
}

TEST(CompareCli, ExitCodesJsonAndHeatMap) {
  const fs::path dir = test::tempDir("qa-compare-cli");
  io::saveLabels(cube(5), dir / "a.nrrd");
  io::saveLabels(cube(6), dir / "b.nrrd");
  const std::string a = (dir / "a.nrrd").string(), b = (dir / "b.nrrd").string();
  std::string log;
  EXPECT_EQ(runVellum({"compare", a, a}, dir, &log), 0) << log;
  EXPECT_NE(log.find("PASS"), std::string::npos) << log;
  EXPECT_EQ(runVellum({"compare", a, b, "--json", (dir / "cmp.json").string(), "--heatmap",
                       (dir / "diff.png").string()}, dir, &log), 1) << log;
  const nlohmann::json j = readJsonFile(dir / "cmp.json", 1 << 20, "test");
  EXPECT_EQ(j["kind"], "labels");
  EXPECT_FALSE(j["pass"].get<bool>());
  EXPECT_DOUBLE_EQ(j["labels"][0]["dice"].get<double>(), 0.9);
  EXPECT_EQ(j["tolerances"]["min_dice"].get<double>(), 1.0);
  // The envelope every command's report shares (run_report.hpp): both inputs, the heat map.
  ASSERT_TRUE(j.contains("inputs") && j.contains("outputs") && j.contains("vellum")) << j.dump(1);
  EXPECT_EQ(j["inputs"].size(), 2u);
  EXPECT_EQ(j["outputs"].size(), 1u);
  const RgbaImage heat = io::loadImage(dir / "diff.png");
  EXPECT_EQ(heat.width, 24);
  EXPECT_EQ(heat.height, 20);
  EXPECT_EQ(runVellum({"compare", a, b, "--min-dice", "0.85", "--max-hd95", "0.5", "-q"}, dir, &log), 0) << log;
  EXPECT_TRUE(log.empty()) << log;
  // Errors: a missing input, an image against a volume.
  EXPECT_EQ(runVellum({"compare", a, (dir / "missing.nrrd").string()}, dir, &log), 2) << log;
  EXPECT_NE(log.find("missing.nrrd"), std::string::npos) << log;
  EXPECT_EQ(std::count(log.begin(), log.end(), '\n'), 1) << log;
  io::saveImage(flat(8, 8, 10), dir / "x.png");
  EXPECT_EQ(runVellum({"compare", a, (dir / "x.png").string(), "--kind", "labels"}, dir, &log), 2) << log;
  // Images through the CLI: a one-level change passes with --tolerance 1.
  RgbaImage other = flat(8, 8, 10);
  other.at(3, 3)[1] = 11;
  io::saveImage(other, dir / "y.png");
  const std::string x = (dir / "x.png").string(), y = (dir / "y.png").string();
  EXPECT_EQ(runVellum({"compare", x, y}, dir, &log), 1) << log;
  EXPECT_EQ(runVellum({"compare", x, y, "--tolerance", "1"}, dir, &log), 0) << log;
}

// The JSON of each kind has the keys docs/qa.md lists (a renamed key breaks CI scripts).
TEST(Compare, ReportSchema) {
  const fs::path dir = test::tempDir("qa-compare-schema");
  auto keys = [](const nlohmann::json& j) {
    std::set<std::string> k;
    for (auto it = j.begin(); it != j.end(); ++it) k.insert(it.key());
    return k;
  };
  const std::set<std::string> top{"tool", "vellum_version", "kind", "pass", "failures", "tolerances", "a", "b"};
  auto expectTop = [&](const nlohmann::json& j, const std::string& part) {
    std::set<std::string> want = top;
    want.insert(part);
    if (part != "image") want.insert("picture_slice");
    EXPECT_EQ(keys(j), want) << j.dump(1);
  };
  io::saveLabels(cube(5), dir / "a.nrrd");
  app::CompareRequest q;
  q.a = q.b = dir / "a.nrrd";
  nlohmann::json j = app::compareFiles(q).report;
  expectTop(j, "labels");
  EXPECT_EQ(keys(j["labels"][0]),
            (std::set<std::string>{"id", "dice", "jaccard", "hd95_mm", "assd_mm", "hausdorff_mm", "voxels_a", "voxels_b",
                                   "volume_a_mm3", "volume_b_mm3", "volume_difference_mm3", "volume_difference_percent"}));
  EXPECT_EQ(keys(j["tolerances"]), (std::set<std::string>{"min_dice", "tolerance", "max_differing_percent", "percentile"}));
  io::saveImage(flat(8, 8, 3), dir / "a.png");
  q.a = q.b = dir / "a.png";
  j = app::compareFiles(q).report;
  expectTop(j, "image");
  EXPECT_EQ(keys(j["image"]), (std::set<std::string>{"max_difference", "mean_difference", "percentile", "percentile_difference",
                                                     "differing_pixels", "differing_percent", "psnr_db", "ssim"}));
  EXPECT_TRUE(j["image"]["psnr_db"].is_null());  // identical: infinite
  Geometry g;
  g.dims = {4, 4, 4};
  io::saveVolume(VolumeI16(g, 0, kCtAirHu), dir / "v.nrrd");
  q.a = q.b = dir / "v.nrrd";
  j = app::compareFiles(q).report;
  expectTop(j, "volume");
  EXPECT_EQ(keys(j["volume"]), (std::set<std::string>{"dims_equal", "geometry_equal", "types_equal", "max_abs_difference",
                                                      "mean_abs_difference", "differing_voxels", "differing_percent",
                                                      "max_at_index", "max_at_mm", "unit"}));
}
