// The OpenCV image codecs are a module opened on first use (io/image_codecs.hpp): executables
// that link io do not load libopencv_imgcodecs (and its ~95 dependencies) at start-up.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "io_test_util.hpp"
#include "vellum/core/error.hpp"
#include "vellum/io/image_io.hpp"

using namespace vellum;
using namespace vellum::test;
namespace fs = std::filesystem;

namespace {

std::string commandOutput(const std::string& cmd) {
  std::string out;
  FILE* p = ::popen(cmd.c_str(), "r");
  if (!p) return out;
  std::array<char, 4096> buf{};
  while (size_t n = std::fread(buf.data(), 1, buf.size(), p)) out.append(buf.data(), n);
  ::pclose(p);
  return out;
}

bool mapped(const std::string& library) { return readFile("/proc/self/maps").find(library) != std::string::npos; }

}  // namespace

TEST(ImageCodecs, ExecutablesDoNotLinkTheCodecsAndLoadThemOnFirstUse) {
  const std::string needed = commandOutput("readelf -d /proc/" + std::to_string(::getpid()) + "/exe");
  if (needed.find("NEEDED") == std::string::npos) GTEST_SKIP() << "no readelf";
  EXPECT_EQ(needed.find("libopencv_imgcodecs"), std::string::npos) << "linked at build time again";
  const fs::path dir = tempDir("image-codecs");
  RgbaImage img(4, 2);
  for (size_t i = 0; i < img.pixels.size(); ++i) img.pixels[i] = static_cast<uint8_t>(i * 9);
  io::saveImage(img, dir / "a.png");
  EXPECT_TRUE(mapped("libopencv_imgcodecs")) << "the module was not opened by saveImage";
  EXPECT_EQ(io::loadImage(dir / "a.png").pixels, img.pixels);
}

// Run by the next test in a fresh process (the module is opened once per process).
TEST(ImageCodecs, DISABLED_MissingModuleChild) {
  const char* file = std::getenv("VELLUM_CODECS_MODULE");
  ASSERT_NE(file, nullptr);
  const fs::path dir = tempDir("image-codecs-missing");
  writeFile(dir / "a.png", "not really a png");
  try {
    io::loadImage(dir / "a.png");
    FAIL() << "loaded without the codec module";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(std::string("cannot load the image codec module ") + file), std::string::npos)
        << e.what();
  }
}

TEST(ImageCodecs, AMissingModuleIsNamedInTheError) {
  const std::string self = fs::read_symlink("/proc/self/exe").string();
  const int status = std::system(("VELLUM_CODECS_MODULE=/nonexistent/libvellum_codecs.so '" + self +
                                  "' --gtest_also_run_disabled_tests --gtest_filter=ImageCodecs.DISABLED_MissingModuleChild"
                                  " > /dev/null 2>&1").c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "the child test failed";
}
