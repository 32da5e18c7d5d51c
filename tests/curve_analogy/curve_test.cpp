// Curve tools: resampling, similarity fit, Laplacian curve deformation.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "hostile_json.hpp"
#include "test_data.hpp"
#include "vellum/illustration/curve.hpp"
#include "vellum/illustration/curve_analogy.hpp"

namespace ill = vellum::illustration;

namespace {
ill::Polyline2 wobblyLoop(int n) {
  ill::Polyline2 c;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * std::numbers::pi * i / n;
    const double r = 40 + 6 * std::sin(3 * a) + 2 * std::cos(7 * a);
    c.push_back({100 + r * std::cos(a), 80 + 0.7 * r * std::sin(a)});
  }
  return c;
}
}  // namespace

TEST(Curve, ResampleEvenlySpaced) {
  const ill::Polyline2 square = {{0, 0}, {10, 0}, {10, 10}, {0, 10}};
  const auto r = ill::resampleByArcLength(square, 8, true);
  ASSERT_EQ(r.size(), 8u);
  for (size_t i = 0; i < r.size(); ++i) {
    const auto& p = r[i];
    const auto& q = r[(i + 1) % r.size()];
    EXPECT_NEAR(std::abs(p.x - q.x) + std::abs(p.y - q.y), 5.0, 1e-12);  // along the sides
  }
  const auto open = ill::resampleByArcLength({{0, 0}, {3, 4}}, 6, false);
  EXPECT_NEAR(open.back().x, 3, 1e-12);
  EXPECT_NEAR(open[1].y, 0.8, 1e-12);
}

TEST(Curve, SimilarityFitIsExact) {
  const auto c = wobblyLoop(50);
  ill::Similarity2 s;
  s.scale = 1.7;
  s.cosA = std::cos(0.6);
  s.sinA = std::sin(0.6);
  s.tx = -12;
  s.ty = 30;
  ill::Polyline2 d;
  for (const auto& p : c) d.push_back(s.apply(p));
  const auto f = ill::fitSimilarity(c, d);
  EXPECT_NEAR(f.scale, 1.7, 1e-12);
  EXPECT_NEAR(f.cosA, std::cos(0.6), 1e-12);
  EXPECT_NEAR(f.tx, -12, 1e-9);
}

TEST(Curve, LaplacianOntoSimilarityCopyIsExact) {
  const auto u = wobblyLoop(120);
  ill::Similarity2 s;
  s.scale = 0.8;
  s.cosA = std::cos(-0.4);
  s.sinA = std::sin(-0.4);
  s.tx = 7;
  s.ty = -3;
  ill::Polyline2 target;
  for (const auto& p : u) target.push_back(s.apply(p));
  // Details of the aligned copy, anchors on the copy: the copy itself is the exact optimum.
  const auto aligned = [&] {
    const auto f = ill::fitSimilarity(u, target);
    ill::Polyline2 a;
    for (const auto& p : u) a.push_back(f.apply(p));
    return a;
  }();
  ill::LaplacianOptions o;
  o.anchors = {0, 40, 80};
  std::vector<ill::Point2> anchorTargets;
  for (int a : o.anchors) anchorTargets.push_back(target[size_t(a)]);
  const auto v = ill::deformCurveLaplacian(aligned, anchorTargets, o);
  for (size_t i = 0; i < v.size(); ++i) {
    EXPECT_NEAR(v[i].x, target[i].x, 1e-8);
    EXPECT_NEAR(v[i].y, target[i].y, 1e-8);
  }
}

TEST(Curve, AnchorsStayPut) {
  const auto u = wobblyLoop(100);
  ill::Polyline2 shifted = u;
  for (auto& p : shifted) p.y += 0.3 * (p.x - 100);  // a shear: not representable by L alone
  ill::LaplacianOptions o;
  o.anchors = {5, 30, 55, 80};
  o.lambda = 1e6;
  std::vector<ill::Point2> anchorTargets;
  for (int a : o.anchors) anchorTargets.push_back(u[size_t(a)]);
  const auto v = ill::deformCurveLaplacian(shifted, anchorTargets, o);
  for (size_t k = 0; k < o.anchors.size(); ++k) {
    EXPECT_NEAR(v[size_t(o.anchors[k])].x, anchorTargets[k].x, 1e-3);
    EXPECT_NEAR(v[size_t(o.anchors[k])].y, anchorTargets[k].y, 1e-3);
  }
  // Open curve: the end points are free rows, anchors still hold.
  o.closed = false;
  const auto w = ill::deformCurveLaplacian(shifted, anchorTargets, o);
  EXPECT_NEAR(w[5].x, u[5].x, 1e-3);
}

TEST(Curve, Hausdorff) {
  const ill::Polyline2 a = {{0, 0}, {10, 0}, {10, 10}, {0, 10}};
  ill::Polyline2 b = a;
  for (auto& p : b) p.x += 2;
  EXPECT_NEAR(ill::hausdorff(a, b, true, true), 2.0, 1e-12);
}

TEST(Curve, DeepOrOversizeCurveFilesAreRefused) {
  const auto dir = vellum::test::tempDir("curve-hostile");
  vellum::test::expectHostileJsonRefused(dir / "c0.json", 16u << 20, [&] { (void)ill::loadCurveJson(dir / "c0.json"); });
}
