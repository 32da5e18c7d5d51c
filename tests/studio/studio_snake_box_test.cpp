// The studio's snake job at real size (issue #22): its box about the seed grows where the
// contour reaches a cut face, so a region longer than the box is segmented whole.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <thread>

#include "snake_job.hpp"
#include "vellum/segmentation/metrics.hpp"

namespace vellum::studio {
namespace {
namespace seg = vellum::segmentation;

TEST(StudioSnakeBox, GrowsWhereTheContourReachesItsEdge) {
  // A soft-tissue rod (40 HU, radius 28 mm) in air along z, 480 mm long on 4 mm voxels: far
  // longer than the 180 mm box about a seed near one end.
  Geometry g;
  g.dims = {24, 24, 120};
  g.spacing = {4, 4, 4};
  VolumeI16 ct(g, -1000, -1000);
  seg::Mask rod(g, 0, 0.0);
  for (int64_t k = 2; k < g.dims.z - 2; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i) {
        const Vec3 p = g.indexToPhysical({double(i), double(j), double(k)});
        const Vec3 c = g.indexToPhysical({11.5, 11.5, double(k)});
        if (norm(p - c) <= 28) ct(i, j, k) = 40, rod(i, j, k) = 1;
      }
  SnakeRequest req;
  req.ct = ct;
  req.segment.method = "snake";
  req.segment.preset = "soft-tissue";
  req.segment.bubbleRadiusMm = 8;
  req.segment.seedsMm = {g.indexToPhysical({11.5, 11.5, 10})};
  const VoxelBox first = snakeBox(g, req.segment.seedsMm.front(), kSnakeRoiHalfMm);
  ASSERT_LT(first.hi[2], g.dims.z / 2) << "the first box holds a part of the rod only";

  SnakeJob job;
  ASSERT_TRUE(job.start(std::move(req)));
  std::optional<SnakeJobResult> out;
  // Waits on the job's own state (no time limit: a slow CI machine only takes longer).
  while (!(out = job.take())) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_TRUE(out->error.empty()) << out->error;
  EXPECT_NE(out->note.find("grew"), std::string::npos) << out->note;
  EXPECT_EQ(out->note.find("reached the edge"), std::string::npos) << out->note;
  const double dice = seg::overlap(out->mask, rod).dice;
  EXPECT_GT(dice, 0.95) << out->note;
  // Both ends of the rod are reached, the far one beyond the first box.
  EXPECT_TRUE(out->mask(11, 11, 3));
  EXPECT_TRUE(out->mask(11, 11, g.dims.z - 4));
}

}  // namespace
}  // namespace vellum::studio
