// Progress reporting and cancellation through loaders and writers.
#include <gtest/gtest.h>

#include "io_test_util.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/io/volume_io.hpp"

using namespace vellum;
using namespace vellum::test;
namespace fs = std::filesystem;

class CancelledSave : public ::testing::TestWithParam<const char*> {};

TEST_P(CancelledSave, LeavesOldFileAndNoTemporaries) {
  const fs::path dir = tempDir(std::string("cancel-save-") + GetParam());
  const fs::path target = dir / GetParam();
  io::saveVolume(makeCt(), target);
  const std::string before = readFile(target);

  Progress* self = nullptr;
  Progress progress([&](const std::string& stage, double) {
    if (stage.rfind("writing", 0) == 0) self->cancel();
  });
  self = &progress;
  io::SaveOptions opt;
  opt.progress = &progress;
  VolumeI16 other = makeCt({9, 9, 9});
  EXPECT_THROW(io::saveVolume(other, target, opt), Cancelled);
  EXPECT_EQ(readFile(target), before);
  EXPECT_EQ(leftoverTemps(dir), 0);
}

INSTANTIATE_TEST_SUITE_P(Formats, CancelledSave, ::testing::Values("c.nrrd", "c.raw", "c.mha", "c.vti"),
                         [](const auto& info) {
                           std::string n = info.param;
                           return n.substr(n.find('.') + 1);
                         });

TEST(Progress, LoadReportsCompletionAndHonoursCancel) {
  const fs::path dir = tempDir("progress-load");
  io::saveVolume(makeCt(), dir / "c.nrrd");
  double last = -1;
  Progress progress([&](const std::string&, double f) { last = f; });
  io::LoadOptions opt;
  opt.progress = &progress;
  io::loadVolume(dir / "c.nrrd", opt);
  EXPECT_EQ(last, 1.0);
  progress.cancel();
  EXPECT_THROW(io::loadVolume(dir / "c.nrrd", opt), Cancelled);
}
