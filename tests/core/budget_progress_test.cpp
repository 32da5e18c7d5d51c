#include <gtest/gtest.h>

#include <cstdlib>
#include <string>
#include <vector>

#include "vellum/core/memory_budget.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/core/volume.hpp"

using namespace vellum;

TEST(MemoryBudget, RefusesHugeVolumeWithClearMessage) {
  try {
    checkMemoryBudget(Dims{2048, 2048, 4000}, 2, "int16");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("volume of 2048x2048x4000 int16 needs 31.3 GiB"), std::string::npos) << msg;
    EXPECT_NE(msg.find("limit is"), std::string::npos) << msg;
  }
}

TEST(MemoryBudget, EnvironmentLimitIsHonouredBeforeAllocating) {
  ::setenv("VELLUM_MEMORY_LIMIT", "1M", 1);
  EXPECT_EQ(memoryLimitBytes(), 1u << 20);
  Geometry g;
  g.dims = {128, 128, 64};  // 2 MiB of int16
  EXPECT_THROW(VolumeI16 v(g), Error);
  g.dims = {64, 64, 64};  // 512 KiB
  EXPECT_NO_THROW(VolumeI16 v(g));
  ::unsetenv("VELLUM_MEMORY_LIMIT");
}

TEST(MemoryBudget, OverflowIsAnError) {
  EXPECT_THROW(checkMemoryBudget(Dims{1ll << 40, 1ll << 40, 1ll << 40}, 2, "int16"), Error);
}

TEST(MemoryBudget, FormatBytes) {
  EXPECT_EQ(formatBytes(512), "512 B");
  EXPECT_EQ(formatBytes(1536ull << 20), "1.5 GiB");
}

TEST(Progress, ReportsMonotoneFractionsAndCancels) {
  std::vector<double> seen;
  Progress p([&](const std::string& stage, double f) {
    EXPECT_EQ(stage, "work");
    seen.push_back(f);
  });
  p.begin("work", 10);
  for (int i = 0; i < 10; ++i) p.advance();
  p.end();
  ASSERT_GE(seen.size(), 2u);
  EXPECT_EQ(seen.front(), 0.0);
  EXPECT_EQ(seen.back(), 1.0);
  for (size_t i = 1; i < seen.size(); ++i) EXPECT_GE(seen[i], seen[i - 1]);
  p.cancel();
  EXPECT_THROW(p.advance(), Cancelled);
}

TEST(Parallel, CoversRangeExactlyOnceAndPropagatesCancel) {
  std::vector<int> hits(1000, 0);
  parallelFor(1000, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) hits[static_cast<size_t>(i)]++;
  });
  for (int h : hits) EXPECT_EQ(h, 1);
  Progress p;
  p.begin("x", 100);
  p.cancel();
  EXPECT_THROW(parallelFor(100, [&](int64_t, int64_t) { p.advance(); }), Cancelled);
}
