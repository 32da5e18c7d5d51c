// The motion score of a hinge (joint_motion.hpp) against an analytic congruent hinge: a round
// "condyle" (child) turning inside a half shell (parent) 2 mm away. About the cylinders' common
// axis every contact voxel keeps its distance to the other bone and nothing digs in: the score
// is (nearly) 0 (the voxels' staircase: 0.13 mm²); an axis shifted across by d lifts one side of
// the contact and drives the other into the shell, so the score grows with d. The search finds
// the axis from a shifted start, also on a grid of 0.4 mm voxels (whose distance fields it
// makes every second voxel).
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <numbers>

#include "vellum/core/error.hpp"
#include "vellum/deformation/joint_motion.hpp"

namespace vellum::deformation {
namespace {

struct Hinge {
  LabelVolume labels;
  Vec3 centre, axis;
  std::vector<Vec3> contact[2];  ///< parent's, child's boundary voxels within 3 mm of the other bone
};

/// Child id 2: a cylinder of radius `r` about `axis` through `centre`, 2·halfLength long; parent
/// id 1: the upper half of a shell from r + 2 to r + 7 mm over the same length.
Hinge makeHinge(double voxelMm, double r, double halfLength) {
  Geometry g;
  const int n = int(std::lround((2 * r + 24) / voxelMm));
  const int len = int(std::lround((2 * halfLength + 12) / voxelMm));
  g.dims = {len, n, n};
  g.spacing = {voxelMm, voxelMm, voxelMm};
  Hinge h{LabelVolume(g), g.indexToPhysical({len / 2.0 + 0.3, n / 2.0 - 0.4, n / 2.0 + 0.2}),
          normalized(Vec3{1, 0.1, -0.05}), {}};
  const Vec3 up = normalized(cross(h.axis, cross(Vec3{0, 0, 1}, h.axis)));
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < len; ++i) {
        const Vec3 p = g.indexToPhysical({double(i), double(j), double(k)}) - h.centre;
        const double s = dot(p, h.axis), rho = norm(p - h.axis * s);
        if (std::abs(s) > halfLength) continue;
        if (rho <= r) h.labels(i, j, k) = 2;
        if (rho >= r + 2 && rho <= r + 7 && dot(p, up) >= 0) h.labels(i, j, k) = 1;
      }
  // Contact voxels: a bone's voxels with a face neighbour outside it and the other bone within 3 mm.
  const int reach = int(std::ceil(3.0 / voxelMm));
  const auto id = [&](int i, int j, int k) { return g.contains(i, j, k) ? h.labels(i, j, k) : uint16_t(0); };
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < len; ++i) {
        const uint16_t own = id(i, j, k);
        if (!own || (id(i - 1, j, k) == own && id(i + 1, j, k) == own && id(i, j - 1, k) == own &&
                     id(i, j + 1, k) == own && id(i, j, k - 1) == own && id(i, j, k + 1) == own))
          continue;
        bool near = false;
        for (int c = -reach; c <= reach && !near; ++c)
          for (int b = -reach; b <= reach && !near; ++b)
            for (int a = -reach; a <= reach && !near; ++a)
              near = id(i + a, j + b, k + c) == 3 - own && (a * a + b * b + c * c) * voxelMm * voxelMm <= 9.0;
        if (near) h.contact[own - 1].push_back(g.indexToPhysical({double(i), double(j), double(k)}));
      }
  return h;
}

const std::vector<double> kAngles{-20, -10, 10, 20};

TEST(HingeMotion, ScoreIsZeroForACongruentHingeAndGrowsOffIt) {
  const Hinge h = makeHinge(1.0, 12, 15);
  ASSERT_GT(h.contact[0].size(), 200u);
  ASSERT_GT(h.contact[1].size(), 200u);
  const HingeMotion m(h.labels, {1}, {2}, h.contact[0], h.contact[1], kAngles, 10);
  const Vec3 across = normalized(cross(h.axis, Vec3{0, 0, 1}));  // horizontal, across the axis
  const double atAxis = m.score(h.centre, h.axis);
  EXPECT_LT(atAxis, 0.2) << "voxel staircase only";  // mm²; measured 0.134 (RMS 0.37 mm)
  EXPECT_LT(m.insideFraction(h.centre, h.axis), 0.001);
  double before = atAxis;
  for (const double d : {2.0, 4.0, 8.0}) {
    const double off = m.score(h.centre + across * d, h.axis);
    EXPECT_GT(off, before + 0.1) << d << " mm off the axis";
    std::cout << d << " mm off the axis: score " << off << " mm²" << std::endl;
    before = off;
  }
  EXPECT_GT(m.insideFraction(h.centre + across * 8.0, h.axis), 0.002);  // one side digs into the shell (0.5 %)
  // Tilting the axis out of the cylinders' makes the ends dig in and lift off.
  const double tilted = m.score(h.centre, normalized(h.axis + across * std::tan(10 * std::numbers::pi / 180)));
  std::cout << "tilted 10°: score " << tilted << " mm²" << std::endl;
  EXPECT_GT(tilted, atAxis + 0.05);

  Vec3 point = h.centre + across * 5.0 + h.axis * 7.0, direction = h.axis;
  const MotionFit fit = m.search(point, direction, 0, 10);
  EXPECT_TRUE(fit.searched);
  const Vec3 off = (point - h.centre) - h.axis * dot(point - h.centre, h.axis);
  EXPECT_LT(norm(off), 0.5);
  EXPECT_NEAR(fit.shiftMm, 5.0, 0.5);
  EXPECT_EQ(direction, h.axis);  // cone 0
  EXPECT_LT(fit.rmsMm, 0.45);
  EXPECT_GT(fit.startRmsMm, 1.0);
}

// 0.4 mm voxels: the fields are made on every second voxel (0.8 mm), the search still lands on
// the axis; a start outside the reach is brought to the reach's edge.
TEST(HingeMotion, FineVoxelsAreScoredOnACoarserGrid) {
  const Hinge h = makeHinge(0.4, 8, 8);
  const HingeMotion m(h.labels, {1}, {2}, h.contact[0], h.contact[1], kAngles, 6);
  const Vec3 across = normalized(cross(h.axis, Vec3{0, 0, 1}));
  Vec3 point = h.centre + across * 3.0, direction = normalized(h.axis + across * 0.1);
  const MotionFit fit = m.search(point, direction, 10, 6);
  EXPECT_LT(norm((point - h.centre) - h.axis * dot(point - h.centre, h.axis)), 0.5);
  EXPECT_LT(std::acos(std::min(1.0, std::abs(dot(direction, h.axis)))) * 180 / std::numbers::pi, 1.0);
  EXPECT_NEAR(fit.turnDeg, 5.7, 1.0);

  Vec3 far = h.centre + across * 9.0, along = h.axis;
  const MotionFit edge = m.search(far, along, 0, 6);
  EXPECT_NEAR(edge.shiftMm, 6.0, 0.05);  // it went as far towards the axis as it may
}

// Cancelling while the distance fields are made stops there (the studio's joint worker).
TEST(HingeMotion, CancelStopsTheFields) {
  const Hinge h = makeHinge(0.4, 8, 8);
  Progress cancelled;
  cancelled.cancel();
  EXPECT_THROW(HingeMotion(h.labels, {1}, {2}, h.contact[0], h.contact[1], kAngles, 6, cancelled), Cancelled);
}

}  // namespace
}  // namespace vellum::deformation
