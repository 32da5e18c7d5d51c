// MLS backward mapping ([HVD 1.1, 1.2] in docs/references.md): analytic properties.
#include <gtest/gtest.h>

#include "test_helpers.hpp"
#include "vellum/deformation/mls.hpp"

using namespace vellum;
using namespace vellum::deformation;
using namespace vellum::deformation::test;

namespace {
const Vec3 kLo{-60, -50, -80}, kHi{70, 40, 90};
}

TEST(Mls, IdentityPointsGiveIdentityMap) {
  const auto src = spreadPoints(kLo, kHi);
  const auto cp = pointsFrom(src, src);
  const auto vs = randomPositions(kLo - Vec3{30, 30, 30}, kHi + Vec3{30, 30, 30}, 2000);
  for (MlsMethod m : {MlsMethod::Affine, MlsMethod::Similarity, MlsMethod::Rigid}) {
    MlsParams p;
    p.method = m;
    const auto u = evaluateMls(cp, p, vs);
    for (size_t i = 0; i < vs.size(); ++i) ASSERT_LT(norm(u[i] - vs[i]), 1e-9) << mlsMethodName(m);
  }
}

TEST(Mls, GlobalAffineTargetsGiveExactInverseForEveryPower) {
  const auto src = spreadPoints(kLo, kHi);
  const Affine a = someAffine();
  std::vector<Vec3> tgt;
  for (const auto& x : src) tgt.push_back(a.apply(x));
  const auto cp = pointsFrom(src, tgt);
  auto vs = randomPositions(kLo - Vec3{40, 40, 40}, kHi + Vec3{40, 40, 40}, 3000);
  for (const auto& y : tgt) vs.push_back(y + Vec3{1e-4, -2e-4, 3e-5});  // right next to targets
  for (double n : {1.0, 2.0, 2.5, 3.0, 4.0, 6.0}) {
    MlsParams p;
    p.power = n;
    const auto u = evaluateMls(cp, p, vs);
    double worst = 0;
    for (size_t i = 0; i < vs.size(); ++i) worst = std::max(worst, norm(u[i] - a.inverse(vs[i])));
    EXPECT_LT(worst, 1e-6) << "n = " << n;
  }
}

TEST(Mls, RigidAndSimilarityReproduceTheirTransforms) {
  const auto src = spreadPoints(kLo, kHi);
  const Mat3 r = rotation({1, 2, -0.5}, 27);
  const Vec3 t{3, -7, 11};
  const auto vs = randomPositions(kLo, kHi, 500);
  for (double scale : {1.0, 1.3}) {
    std::vector<Vec3> tgt;
    for (const auto& x : src) tgt.push_back(r * x * scale + t);
    const auto cp = pointsFrom(src, tgt);
    MlsParams p;
    p.method = scale == 1.0 ? MlsMethod::Rigid : MlsMethod::Similarity;
    const auto u = evaluateMls(cp, p, vs);
    for (size_t i = 0; i < vs.size(); ++i) {
      const Vec3 expect = r.transposed() * (vs[i] - t) / scale;
      ASSERT_LT(norm(u[i] - expect), 1e-6) << mlsMethodName(p.method);
    }
  }
}

TEST(Mls, MapInterpolatesTheControlPoints) {
  const auto src = spreadPoints(kLo, kHi);
  std::vector<Vec3> tgt;
  std::mt19937 rng(11);
  std::normal_distribution<double> nd(0, 8);
  for (const auto& x : src) tgt.push_back(x + Vec3{nd(rng), nd(rng), nd(rng)});  // non-affine
  const auto cp = pointsFrom(src, tgt);
  for (MlsMethod m : {MlsMethod::Affine, MlsMethod::Similarity, MlsMethod::Rigid}) {
    MlsParams p;
    p.method = m;
    const auto u = evaluateMls(cp, p, tgt);
    for (size_t i = 0; i < tgt.size(); ++i) EXPECT_EQ(u[i], src[i]);
  }
}

TEST(Mls, FewOrCoplanarPointsNeverGiveNaN) {
  const auto vs = randomPositions(kLo, kHi, 400);
  MlsParams p;
  // One point: a pure translation.
  {
    const ControlPoints cp{{{1, 2, 3}, {4, 6, 8}, {}}};
    const auto u = evaluateMls(cp, p, vs);
    for (size_t i = 0; i < vs.size(); ++i) ASSERT_LT(norm(u[i] - (vs[i] - Vec3{3, 4, 5})), 1e-9);
  }
  // Two and three points, and 9 coplanar points (z = 5): finite; identity stays identity.
  std::vector<std::vector<Vec3>> sets = {{{0, 0, 0}, {10, 0, 0}},
                                         {{0, 0, 0}, {10, 0, 0}, {0, 10, 0}}};
  std::vector<Vec3> plane;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) plane.push_back({i * 20.0, j * 15.0, 5.0});
  sets.push_back(plane);
  for (const auto& s : sets) {
    for (MlsMethod m : {MlsMethod::Affine, MlsMethod::Similarity, MlsMethod::Rigid}) {
      p.method = m;
      const auto id = evaluateMls(pointsFrom(s, s), p, vs);
      for (size_t i = 0; i < vs.size(); ++i) ASSERT_LT(norm(id[i] - vs[i]), 1e-6);
      std::vector<Vec3> moved;
      for (const auto& x : s) moved.push_back(x + Vec3{x.y * 0.1, 3, -2});
      const auto u = evaluateMls(pointsFrom(s, moved), p, vs);
      for (const auto& x : u) ASSERT_TRUE(isFinite(x));
    }
  }
  // Coplanar points moved by an in-plane affine: exact in the plane, identity off it.
  p.method = MlsMethod::Affine;
  std::vector<Vec3> moved;
  for (const auto& x : plane) moved.push_back({1.1 * x.x + 0.2 * x.y + 3, 0.9 * x.y - 2, x.z});
  const auto u = evaluateMls(pointsFrom(plane, moved), p, vs);
  for (size_t i = 0; i < vs.size(); ++i) {
    const double y = (vs[i].y + 2) / 0.9;
    const Vec3 expect{(vs[i].x - 3 - 0.2 * y) / 1.1, y, vs[i].z};
    ASSERT_LT(norm(u[i] - expect), 1e-4);
  }
}

TEST(Mls, AttributesReproduceAnAffineAttributeField) {
  const auto src = spreadPoints(kLo, kHi);
  std::vector<Vec3> tgt;
  std::mt19937 rng(5);
  std::normal_distribution<double> nd(0, 6);
  for (const auto& x : src) tgt.push_back(x + Vec3{nd(rng), nd(rng), nd(rng)});
  // z(y) = c + g . y for each attribute, evaluated at the TARGETS.
  const std::array<Vec3, 4> g = {Vec3{0.1, -0.2, 0.05}, Vec3{0.3, 0, 0}, Vec3{0, 0, -0.4},
                                 Vec3{0.002, 0.001, -0.003}};
  const std::array<double, 4> c = {5, -3, 7, 1};
  auto field = [&](const Vec3& y, int a) { return c[size_t(a)] + dot(g[size_t(a)], y); };
  ControlPoints cp = pointsFrom(src, tgt);
  for (auto& p : cp) {
    p.attributes.lightness = field(p.target, 0);
    p.attributes.a = field(p.target, 1);
    p.attributes.b = field(p.target, 2);
    p.attributes.density = field(p.target, 3);
  }
  const auto vs = randomPositions(kLo, kHi, 1000);
  std::vector<std::array<double, 4>> attrs;
  (void)evaluateMls(cp, {}, vs, &attrs);
  for (size_t i = 0; i < vs.size(); ++i)
    for (int a = 0; a < 4; ++a) ASSERT_NEAR(attrs[i][size_t(a)], field(vs[i], a), 1e-7);
  // At a target the attributes are the point's own.
  (void)evaluateMls(cp, {}, tgt, &attrs);
  EXPECT_EQ(attrs[3][0], cp[3].attributes.lightness);
}

TEST(Mls, RejectsBadParameters) {
  const ControlPoints cp{{{0, 0, 0}, {1, 0, 0}, {}}};
  MlsParams p;
  p.power = 0;
  EXPECT_THROW(evaluateMls(cp, p, {{0, 0, 0}}), Error);
  EXPECT_THROW(evaluateMls({}, {}, {{0, 0, 0}}), Error);
  EXPECT_THROW(parseMlsMethod("bogus"), Error);
}
