// MP4 writing through ffmpeg: atomic, validated.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>

#include "test_data.hpp"
#include "vellum/core/error.hpp"
#include "vellum/io/video_io.hpp"

using namespace vellum;

TEST(Video, WritesAnMp4AtomicallyAndChecksFrames) {
  if (!io::videoEncoderAvailable()) GTEST_SKIP() << "no ffmpeg on PATH";
  const auto dir = vellum::test::tempDir("deform-video");
  const auto path = dir / "movie.mp4";
  {
    io::VideoWriter w(path, 65, 48, 12);  // odd width: padded to even
    for (int f = 0; f < 12; ++f) {
      RgbaImage img(65, 48);
      for (int y = 0; y < 48; ++y)
        for (int x = 0; x < 65; ++x) {
          uint8_t* p = img.at(x, y);
          p[0] = uint8_t(x * 3 + f * 10); p[1] = uint8_t(y * 5); p[2] = 128; p[3] = 255;
        }
      w.addFrame(img);
      EXPECT_FALSE(std::filesystem::exists(path)) << "visible before finish()";
    }
    EXPECT_THROW(w.addFrame(RgbaImage(10, 10)), FileError);
    w.finish();
  }
  ASSERT_TRUE(std::filesystem::exists(path));
  std::ifstream in(path, std::ios::binary);
  char head[12] = {};
  in.read(head, 12);
  EXPECT_EQ(std::string(head + 4, 4), "ftyp");  // an MP4 container
  // Nothing but the movie is left behind.
  int files = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) { (void)e; ++files; }
  EXPECT_EQ(files, 1);
  // Abandoned writer: no file appears.
  { io::VideoWriter w(dir / "abandoned.mp4", 16, 16, 10); w.addFrame(RgbaImage(16, 16)); }
  EXPECT_FALSE(std::filesystem::exists(dir / "abandoned.mp4"));
  EXPECT_THROW(io::VideoWriter(dir / "x.mp4", 16, 16, 0), FileError);
  EXPECT_THROW(io::saveVideo({}, dir / "y.mp4", 10), FileError);
}
