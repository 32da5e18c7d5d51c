#include <gtest/gtest.h>

#include "test_volumes.hpp"
#include "vellum/segmentation/metrics.hpp"
#include "vellum/segmentation/snake.hpp"

using namespace vellum;
using namespace vellum::segmentation;
using namespace vellum::segmentation::test;

namespace {
// A 50-HU ball of radius 15 mm in air on an anisotropic grid.
struct Scene {
  Geometry g = grid(48, 40, 24, {0.8, 1.0, 1.7});
  Vec3 c = centreMm(g);
  VolumeI16 ct = sphereCt(g, c, 15.0, 50, -1000);
  Mask truth = sphereMask(g, c, 15.0);
};
}  // namespace

TEST(Snake, ThresholdSpeedFillsTheBallFromASmallBubble) {
  Scene s;
  const SpeedImage speed = thresholdSpeed(s.ct, {-500, 300, 60});
  EXPECT_FLOAT_EQ(speed.values(0, 0, 0), -1.0f);
  SnakeParams p;
  p.coarseLevels = 0;
  const SnakeResult r = evolveSnake(speed, {{s.c + Vec3{3, 0, 0}, 4.0}}, p);
  EXPECT_TRUE(r.converged);
  EXPECT_LT(r.iterations, p.maxIterations);
  EXPECT_GT(overlap(r.mask, s.truth).dice, 0.97);
}

TEST(Snake, EdgeSpeedStopsAtTheBoundary) {
  Scene s;
  const SpeedImage speed = edgeSpeed(s.ct, {1.0, 100, 2});
  // g is ~1 in flat regions and small on the boundary.
  EXPECT_GT(speed.values(24, 20, 12), 0.95f);
  SnakeParams p;
  p.coarseLevels = 0;
  p.advection = 1.0;
  const SnakeResult r = evolveSnake(speed, {{s.c, 5.0}}, p);
  EXPECT_TRUE(r.converged);
  EXPECT_GT(overlap(r.mask, s.truth).dice, 0.97);
}

TEST(Snake, CoarseToFineMatchesSingleResolution) {
  const Geometry g = grid(96, 96, 96, {1, 1, 1});
  const Vec3 c = centreMm(g);
  const VolumeI16 ct = sphereCt(g, c, 30.0, 50, -1000);
  const SpeedImage speed = thresholdSpeed(ct);
  SnakeParams p;
  p.coarseLevels = 1;
  const SnakeResult r = evolveSnake(speed, {{c, 5.0}}, p);
  EXPECT_GT(r.coarseIterations, 0);
  EXPECT_TRUE(r.converged);
  EXPECT_GT(overlap(r.mask, sphereMask(g, c, 30.0)).dice, 0.98);
}

// Odd sizes (the coarse grid has one voxel fewer than half on each axis) and anisotropic
// spacing: the fine level starts only from the coarse band and must still fill the ball.
TEST(Snake, CoarseToFineOnOddAnisotropicGrid) {
  const Geometry g = grid(95, 81, 67, {0.8, 1.0, 1.3});
  const Vec3 c = centreMm(g) + Vec3{2.5, -1.5, 0.7};
  const VolumeI16 ct = sphereCt(g, c, 24.0, 50, -1000);
  SnakeParams p;
  p.coarseLevels = 2;
  const SnakeResult r = evolveSnake(thresholdSpeed(ct), {{c, 5.0}}, p);
  EXPECT_GT(r.coarseIterations, 0);
  EXPECT_TRUE(r.converged);
  EXPECT_GT(overlap(r.mask, sphereMask(g, c, 24.0)).dice, 0.98);
  // Far from the contour phi holds +-clamp with the right sign (inside / outside).
  const auto in = nearestVoxel(g, c), out = nearestVoxel(g, g.indexToPhysical({1, 1, 1}));
  EXPECT_LT(r.phi(in->i, in->j, in->k), 0.0f);
  EXPECT_GT(r.phi(out->i, out->j, out->k), 0.0f);
}

TEST(Snake, CurvatureShrinksABubbleWithoutPropagation) {
  Scene s;
  SpeedImage speed{VolumeF32(s.g, 0.0f, 0.0), SpeedType::Threshold};
  SnakeParams p;
  p.coarseLevels = 0;
  p.propagation = 0;
  p.curvature = 1.0;
  p.maxIterations = 30;
  const SnakeResult r = evolveSnake(speed, {{s.c, 8.0}}, p);
  EXPECT_LT(countVoxels(r.mask), countVoxels(sphereMask(s.g, s.c, 8.0)));
  EXPECT_GT(countVoxels(r.mask), 0);
}

TEST(Snake, CancelAndBadInput) {
  Scene s;
  const SpeedImage speed = thresholdSpeed(s.ct);
  Progress progress;
  progress.cancel();
  EXPECT_THROW(evolveSnake(speed, {{s.c, 4.0}}, {}, progress), Cancelled);
  EXPECT_THROW(evolveSnake(speed, {}, {}), Error);
  EXPECT_THROW(evolveSnake(speed, {{{1000, 0, 0}, 4.0}}, {}), Error);
  EXPECT_THROW(evolveSnake(speed, {{s.c, -1.0}}, {}), Error);
}

// The studio draws the snake live through the observer: it sees the inside grow from the
// bubble towards the ball, at the iterations asked for, and the result is the last state.
TEST(Snake, ObserverSeesTheContourGrow) {
  Scene s;
  const SpeedImage speed = thresholdSpeed(s.ct, {-500, 300, 60});
  SnakeParams p;
  p.coarseLevels = 0;
  p.curvature = 0;  // pure propagation: the inside only grows
  std::vector<int> iterations;
  std::vector<int64_t> voxels;
  const SnakeResult r = evolveSnake(speed, {{s.c, 4.0}}, p, Progress::none(), [&](const Mask& inside, int it) {
    EXPECT_EQ(inside.geometry().dims, s.g.dims);
    iterations.push_back(it);
    voxels.push_back(countVoxels(inside));
  }, 3);
  ASSERT_GE(iterations.size(), 2u);
  for (size_t i = 0; i < iterations.size(); ++i) EXPECT_EQ(iterations[i], 3 * int(i + 1));
  for (size_t i = 1; i < voxels.size(); ++i) EXPECT_GE(voxels[i], voxels[i - 1]);
  EXPECT_GT(voxels.back(), voxels.front());
  EXPECT_LE(voxels.back(), countVoxels(r.mask));
  EXPECT_EQ(int(iterations.size()), r.iterations / 3);
}

// A snake continued from a region (the studio's grown box) reaches the snake from a bubble;
// with the per-step test switched off, the settle test (the inside's volume no longer changes)
// stops it long before the iteration limit.
TEST(Snake, ContinuedFromARegionAndSettled) {
  Scene s;
  const SpeedImage speed = thresholdSpeed(s.ct, {-500, 300, 60});
  SnakeParams p;
  p.coarseLevels = 0;
  p.convergenceWindow = 1 << 20;  // the per-step test never passes: only the settle test can stop it
  p.maxIterations = 1000;
  const SnakeResult fromBubble = evolveSnake(speed, {{s.c, 4.0}}, p);
  EXPECT_TRUE(fromBubble.settled);
  EXPECT_LT(fromBubble.iterations, 400);
  EXPECT_GT(overlap(fromBubble.mask, s.truth).dice, 0.97);
  // A 9 mm cube off the centre, as the start region (the truth's half-width is 15 mm).
  Mask start(s.g, 0, 0.0);
  for (int64_t k = 0; k < s.g.dims.z; ++k)
    for (int64_t j = 0; j < s.g.dims.y; ++j)
      for (int64_t i = 0; i < s.g.dims.x; ++i) {
        const Vec3 d = s.g.indexToPhysical({double(i), double(j), double(k)}) - (s.c + Vec3{-4, 2, 0});
        start(i, j, k) = std::abs(d.x) <= 4.5 && std::abs(d.y) <= 4.5 && std::abs(d.z) <= 4.5;
      }
  const SnakeResult fromRegion = evolveSnakeFrom(speed, start, p);
  EXPECT_TRUE(fromRegion.settled);
  EXPECT_GT(overlap(fromRegion.mask, s.truth).dice, 0.97);
  EXPECT_GT(overlap(fromRegion.mask, fromBubble.mask).dice, 0.98);
  EXPECT_THROW(evolveSnakeFrom(speed, Mask(s.g, 0, 0.0), p), Error);
}
