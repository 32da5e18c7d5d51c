// Weighted rigid / similarity fit (core/rigid_fit.hpp) against transforms made up here.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "vellum/core/error.hpp"
#include "vellum/core/rigid_fit.hpp"

using namespace vellum;

namespace {

// Rotation by `angle` (rad) about the unit `axis` (Rodrigues).
Mat3 rotationAbout(Vec3 axis, double angle) {
  axis = normalized(axis);
  const double c = std::cos(angle), s = std::sin(angle);
  Mat3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r(i, j) = (i == j ? c : 0) + (1 - c) * axis[i] * axis[j];
  r(0, 1) -= s * axis.z; r(1, 0) += s * axis.z;
  r(0, 2) += s * axis.y; r(2, 0) -= s * axis.y;
  r(1, 2) -= s * axis.x; r(2, 1) += s * axis.x;
  return r;
}

std::vector<Vec3> randomPoints(int n, unsigned seed, bool planar = false) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-80, 80);
  std::vector<Vec3> p;
  for (int i = 0; i < n; ++i) p.push_back({u(rng), u(rng), planar ? 0.0 : u(rng)});
  return p;
}

}  // namespace

TEST(RigidFit, ReproducesAKnownRotationAndTranslation) {
  const Mat3 r = rotationAbout({1, -2, 0.5}, 0.7);
  const Vec3 t{12.5, -40, 7};
  for (bool planar : {false, true}) {
    const auto src = randomPoints(25, 3, planar);
    std::vector<Vec3> dst;
    for (const Vec3& p : src) dst.push_back(r * p + t);
    const RigidTransform f = fitRigid(src, dst);
    EXPECT_LT(maxAbsDiff(f.rotation, r), 1e-9) << "planar " << planar;
    EXPECT_LT(norm(f.translation - t), 1e-9);
    EXPECT_DOUBLE_EQ(f.scale, 1.0);
  }
}

TEST(RigidFit, MirroredPointsGiveARotationNotAReflection) {
  const auto src = randomPoints(30, 5);
  std::vector<Vec3> dst;
  for (const Vec3& p : src) dst.push_back({-p.x, p.y, p.z});  // the best orthogonal map is a mirror
  const RigidTransform f = fitRigid(src, dst);
  EXPECT_NEAR(f.rotation.determinant(), 1.0, 1e-12);
  EXPECT_LT(maxAbsDiff(f.rotation * f.rotation.transposed(), Mat3::identity()), 1e-12);
}

TEST(RigidFit, WeightsCountLikeRepeatedPairsAndZeroWeightsDrop) {
  const Mat3 r = rotationAbout({0, 0, 1}, 0.3);
  auto src = randomPoints(10, 9);
  std::vector<Vec3> dst;
  for (const Vec3& p : src) dst.push_back(r * p);
  dst[0] += Vec3{5, -3, 2};  // a disturbed pair
  std::vector<double> w(src.size(), 1.0);
  w[0] = 3.0;
  std::vector<Vec3> src3 = src, dst3 = dst;
  for (int copy = 0; copy < 2; ++copy) { src3.push_back(src[0]); dst3.push_back(dst[0]); }
  const RigidTransform weighted = fitRigid(src, dst, w), repeated = fitRigid(src3, dst3);
  EXPECT_LT(maxAbsDiff(weighted.rotation, repeated.rotation), 1e-12);
  EXPECT_LT(norm(weighted.translation - repeated.translation), 1e-9);
  w[0] = 0.0;  // without the disturbed pair the fit is exact again
  const RigidTransform clean = fitRigid(src, dst, w);
  EXPECT_LT(maxAbsDiff(clean.rotation, r), 1e-9);
  EXPECT_LT(norm(clean.translation), 1e-9);
}

TEST(RigidFit, SimilarityRecoversTheScale) {
  const Mat3 r = rotationAbout({2, 1, 1}, -1.1);
  const Vec3 t{-3, 4, 100};
  const auto src = randomPoints(12, 11);
  std::vector<Vec3> dst;
  for (const Vec3& p : src) dst.push_back(r * p * 2.5 + t);
  const RigidTransform f = fitRigid(src, dst, {}, true);
  EXPECT_NEAR(f.scale, 2.5, 1e-9);
  EXPECT_LT(maxAbsDiff(f.rotation, r), 1e-9);
  EXPECT_LT(norm(f.apply(src[4]) - dst[4]), 1e-9);
}

TEST(RigidFit, NearestRotationAndBadInput) {
  // diag(3, 2, -1) = I diag(3, 2, 1) diag(1, 1, -1): the nearest rotation is I, trace 3 + 2 - 1.
  double tr = 0;
  const Mat3 r = nearestRotation(Mat3::fromColumns({3, 0, 0}, {0, 2, 0}, {0, 0, -1}), &tr);
  EXPECT_LT(maxAbsDiff(r, Mat3::identity()), 1e-12);
  EXPECT_NEAR(tr, 4.0, 1e-12);
  EXPECT_THROW(fitRigid(RigidFitSums{}), Error);
  EXPECT_THROW(fitRigid({{0, 0, 0}}, {}), Error);
}

// The inverse undoes the transform and compose applies inner, then outer (scale included).
TEST(RigidFit, InverseAndComposeAgreeWithApplyingInTurn) {
  const RigidTransform a{rotationAbout({1, -2, 0.5}, 0.7), {12.5, -40, 7}, 1.3};
  const RigidTransform b{rotationAbout({0, 1, 1}, -1.1), {-3, 8, 21}, 0.8};
  for (const Vec3& p : randomPoints(10, 5)) {
    EXPECT_LT(norm(a.inverse().apply(a.apply(p)) - p), 1e-9);
    EXPECT_LT(norm(compose(a, b).apply(p) - a.apply(b.apply(p))), 1e-9);
    EXPECT_LT(norm(compose(a.inverse(), a).apply(p) - p), 1e-9);
  }
}
