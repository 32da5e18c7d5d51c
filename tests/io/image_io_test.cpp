#include <gtest/gtest.h>

#include "io_test_util.hpp"
#include "vellum/core/error.hpp"
#include "vellum/io/image_io.hpp"

using namespace vellum;
using namespace vellum::test;
namespace fs = std::filesystem;

namespace {
RgbaImage pattern() {
  RgbaImage img(5, 3);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 5; ++x) {
      uint8_t* p = img.at(x, y);
      p[0] = static_cast<uint8_t>(40 * x);
      p[1] = static_cast<uint8_t>(100 * y);
      p[2] = static_cast<uint8_t>(7 + x * y);
      p[3] = static_cast<uint8_t>(255 - 50 * x);
    }
  return img;
}
}  // namespace

TEST(ImageIo, PngAndTiffKeepRgbaExactly) {
  const fs::path dir = tempDir("image-io");
  const RgbaImage img = pattern();
  for (const char* name : {"a.png", "a.tif", "a.TIFF"}) {
    io::saveImage(img, dir / name);
    const RgbaImage back = io::loadImage(dir / name);
    EXPECT_EQ(back.width, 5);
    EXPECT_EQ(back.height, 3);
    EXPECT_EQ(back.pixels, img.pixels) << name;  // channel order and row order preserved
  }
  EXPECT_EQ(leftoverTemps(dir), 0);
}

TEST(ImageIo, JpegDropsAlphaAndIsClose) {
  const fs::path dir = tempDir("image-jpeg");
  RgbaImage img(16, 16);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x) {
      uint8_t* p = img.at(x, y);
      p[0] = 200; p[1] = 60; p[2] = 30; p[3] = 10;
    }
  io::saveImage(img, dir / "a.jpg");
  const RgbaImage back = io::loadImage(dir / "a.jpg");
  ASSERT_EQ(back.width, 16);
  EXPECT_NEAR(back.at(8, 8)[0], 200, 6);
  EXPECT_NEAR(back.at(8, 8)[1], 60, 6);
  EXPECT_NEAR(back.at(8, 8)[2], 30, 6);
  EXPECT_EQ(back.at(8, 8)[3], 255);
}

TEST(ImageIo, ErrorsNameTheFile) {
  const fs::path dir = tempDir("image-errors");
  try {
    io::saveImage(pattern(), dir / "a.gif");
    FAIL();
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("a.gif"), std::string::npos);
  }
  EXPECT_THROW(io::saveImage(RgbaImage(), dir / "e.png"), FileError);
  EXPECT_THROW(io::loadImage(dir / "absent.png"), FileError);
  writeFile(dir / "junk.png", "not a png");
  EXPECT_THROW(io::loadImage(dir / "junk.png"), FileError);
  EXPECT_FALSE(fs::exists(dir / "a.gif"));
  EXPECT_EQ(leftoverTemps(dir), 0);
}
