// `vellum slice`: each pixel shows the voxel under it (index and mm position, anisotropic
// spacing at physical aspect), labels in their table colours, and the command's refusals.
#include <gtest/gtest.h>

#include "child_process.hpp"
#include "test_data.hpp"
#include "test_volumes.hpp"
#include "vellum/app/slice_pipeline.hpp"
#include "vellum/io/image_io.hpp"
#include "vellum/io/volume_io.hpp"

using namespace vellum;
namespace fs = std::filesystem;

namespace {

/// 16 x 12 x 6 voxels of 1 x 1 x 3 mm at the origin; each voxel's value tells where it is.
int16_t value(int64_t i, int64_t j, int64_t k) { return static_cast<int16_t>((i * 13 + j * 7 + k * 29) % 256); }

VolumeI16 codedVolume() {
  VolumeI16 v(test::grid({16, 12, 6}, {1, 1, 3}));
  test::forEachVoxel(v.geometry().dims, [&](int64_t i, int64_t j, int64_t k) { v(i, j, k) = value(i, j, k); });
  return v;
}

/// Grey = value: window 0..255.
app::SliceRequest plainRequest(const fs::path& in, const fs::path& out) {
  app::SliceRequest r;
  r.input = in;
  r.output = out;
  r.windowCenter = 127.5;
  r.windowWidth = 255;
  r.orientation = false;
  return r;
}

}  // namespace

TEST(Slice, PixelsAreTheVoxelsAtIndexAndMmWithAnisotropicSpacingAtPhysicalAspect) {
  const fs::path dir = test::tempDir("slice-pixels");
  io::saveVolume(codedVolume(), dir / "ct.nrrd");
  // Axial at index 4: 16 x 12 pixels, x right, y (posterior) down.
  app::SliceRequest r = plainRequest(dir / "ct.nrrd", dir / "axial.png");
  r.indices = {4};
  app::SliceResult res = app::runSlice(r);
  ASSERT_EQ(res.figures.size(), 1u);
  EXPECT_DOUBLE_EQ(res.figures[0].positionMm, 12.0);
  RgbaImage img = io::loadImage(dir / "axial.png");
  ASSERT_EQ(img.width, 16);
  ASSERT_EQ(img.height, 12);
  for (int y = 0; y < 12; ++y)
    for (int x = 0; x < 16; ++x) ASSERT_EQ(img.at(x, y)[0], value(x, y, 4)) << x << "," << y;

  // Coronal at y = 5 mm (j 5): square pixels of 1 mm, so the 18 mm of z are 18 rows (not 6);
  // superior on top: the centre of row 16 - 3k is voxel k's centre.
  r = plainRequest(dir / "ct.nrrd", dir / "coronal.png");
  r.axis = app::SliceAxis::Coronal;
  r.positionsMm = {5.0};
  res = app::runSlice(r);
  EXPECT_EQ(res.figures[0].index, 5);
  img = io::loadImage(dir / "coronal.png");
  ASSERT_EQ(img.width, 16);
  ASSERT_EQ(img.height, 18);
  // (Within a grey level: the studio's slice views truncate, and a position that is a voxel
  // centre up to rounding may sample 229.9999.)
  for (int k = 0; k < 6; ++k)
    for (int x = 0; x < 16; ++x) ASSERT_NEAR(img.at(x, 16 - 3 * k)[0], value(x, 5, k), 1) << x << "," << k;
  // Between two voxels' centres (row 15 is a third of the way from k 0 to k 1): trilinear, as
  // the studio's slice views.
  EXPECT_NEAR(img.at(3, 15)[0], value(3, 5, 0) + (value(3, 5, 1) - value(3, 5, 0)) / 3.0, 1.0);

  // Several slices: one file each, named by index; --every as well.
  r = plainRequest(dir / "ct.nrrd", dir / "s.png");
  r.axis = app::SliceAxis::Sagittal;
  r.every = 5;
  res = app::runSlice(r);
  ASSERT_EQ(res.figures.size(), 4u);  // x 0, 5, 10, 15
  EXPECT_TRUE(fs::exists(dir / "s-10.png"));
  img = io::loadImage(dir / "s-10.png");
  ASSERT_EQ(img.width, 12);  // y: anterior on the left
  ASSERT_EQ(img.height, 18);
  EXPECT_NEAR(img.at(7, 16 - 3 * 2)[0], value(10, 7, 2), 1);
}

TEST(Slice, LabelsAreDrawnInTheirTableColoursWhereTheyAre) {
  const fs::path dir = test::tempDir("slice-labels");
  const VolumeI16 ct = codedVolume();
  io::saveVolume(ct, dir / "ct.nrrd");
  LabelVolume labels(ct.geometry());
  test::fillWhere(labels, test::voxelBox(4, 10, 3, 8, 2, 3), 7);
  labels.setLabel({7, "bone", {10, 200, 30}});
  io::saveLabels(labels, dir / "labels.nrrd");
  app::SliceRequest r = plainRequest(dir / "ct.nrrd", dir / "fill.png");
  r.labels = dir / "labels.nrrd";
  r.indices = {2};
  r.labelOpacity = 1;
  r.labelOutlines = false;
  app::runSlice(r);
  RgbaImage img = io::loadImage(dir / "fill.png");
  for (int y = 0; y < 12; ++y)
    for (int x = 0; x < 16; ++x) {
      const bool in = x >= 4 && x < 10 && y >= 3 && y < 8;
      const uint8_t* p = img.at(x, y);
      if (in) {
        ASSERT_EQ(p[0], 10);
        ASSERT_EQ(p[1], 200);
        ASSERT_EQ(p[2], 30);
      } else {
        ASSERT_EQ(p[0], value(x, y, 2));
        ASSERT_EQ(p[1], value(x, y, 2));
      }
    }
  // Outlines only: the region's border in colour, its inside grey.
  r.output = dir / "outline.png";
  r.labelOpacity = 0;
  r.labelOutlines = true;
  app::runSlice(r);
  img = io::loadImage(dir / "outline.png");
  EXPECT_EQ(img.at(4, 5)[1], 200);  // left edge
  EXPECT_EQ(img.at(9, 7)[1], 200);  // corner
  EXPECT_EQ(img.at(6, 5)[1], value(6, 5, 2));
  EXPECT_EQ(img.at(2, 5)[1], value(2, 5, 2));
}

TEST(SliceCli, RefusesBadAxisOutOfRangeIndexAndANonPictureOrForeignOutputLeavingTheInput) {
  const fs::path dir = test::tempDir("slice-cli");
  io::saveVolume(codedVolume(), dir / "ct.nrrd");
  const std::string ct = (dir / "ct.nrrd").string(), before = test::readAll(dir / "ct.nrrd");
  std::ofstream(dir / "notes.png") << "my notes, not a picture";
  const auto run = [&](std::vector<std::string> args) {
    args.insert(args.begin(), "slice");
    const int rc = test::Child(args, dir / "log.txt").wait();
    std::pair<int, std::string> r{rc, test::readAll(dir / "log.txt")};
    fs::remove(dir / "log.txt");
    return r;
  };
  const auto expectError = [&](const std::pair<int, std::string>& r, int rc, const std::string& what) {
    EXPECT_EQ(r.first, rc) << r.second;
    EXPECT_EQ(std::count(r.second.begin(), r.second.end(), '\n'), 1) << r.second;
    EXPECT_NE(r.second.find(what), std::string::npos) << r.second;
  };
  expectError(run({ct, "--axis", "oblique", "--out", (dir / "a.png").string()}), 2, "--axis");
  expectError(run({ct, "--index", "6", "--out", (dir / "a.png").string()}), 2, "--index 6: outside 0..5");
  expectError(run({ct, "--out", ct}), 2, ct);  // the input itself: not a picture
  expectError(run({ct, "--out", (dir / "notes.png").string()}), 1, (dir / "notes.png").string());
  EXPECT_EQ(test::readAll(dir / "ct.nrrd"), before);
  EXPECT_EQ(test::readAll(dir / "notes.png"), "my notes, not a picture");
  EXPECT_FALSE(fs::exists(dir / "a.png"));
  // And a good call writes its picture.
  EXPECT_EQ(run({ct, "--axis", "coronal", "--mm", "5", "--out", (dir / "a.png").string()}).first, 0);
  EXPECT_TRUE(fs::exists(dir / "a.png"));
}
