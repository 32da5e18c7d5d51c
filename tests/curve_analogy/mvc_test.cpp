// Mean value coordinates: reproduction, linear precision, points on the cage surface.
#include <gtest/gtest.h>

#include <random>

#include "test_meshes.hpp"
#include "vellum/illustration/mean_value_coordinates.hpp"

namespace ill = vellum::illustration;
using vellum::Vec3;

namespace {

std::vector<Vec3> samplePoints(const ill::Cage& cage) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.3, 1.3);
  std::vector<Vec3> pts;
  for (int i = 0; i < 300; ++i) pts.push_back({u(rng) * 20, u(rng) * 12, u(rng) * 30});  // in and out
  // On the surface: vertices, edge midpoints, face centroids.
  for (size_t f = 0; f < cage.faces.size(); f += 17) {
    const auto& t = cage.faces[f];
    const Vec3 &a = cage.vertices[t[0]], &b = cage.vertices[t[1]], &c = cage.vertices[t[2]];
    pts.push_back(a);
    pts.push_back((a + b) * 0.5);
    pts.push_back((a + b + c) / 3.0);
    pts.push_back((a + b + c) / 3.0 * (1 + 1e-7));  // just off the face
    pts.push_back((a + b) * 0.5 * (1 - 1e-8));       // just inside an edge
    pts.push_back(a * (1 + 1e-6));                    // just outside a vertex
  }
  return pts;
}

}  // namespace

TEST(MeanValueCoordinates, UndeformedCageReproducesPoints) {
  const ill::Cage cage = ill::cageOf(vellum::test::ellipsoid(20, 12, 30, 2));
  const auto pts = samplePoints(cage);
  const auto out = ill::transferByMeanValueCoordinates(cage, cage.vertices, pts);
  for (size_t i = 0; i < pts.size(); ++i)
    EXPECT_LE(norm(out[i] - pts[i]), 1e-9 * std::max(1.0, norm(pts[i]))) << "point " << i;
}

TEST(MeanValueCoordinates, WeightsSumToOneAndArePositiveInside) {
  const ill::Cage cage = ill::cageOf(vellum::test::ellipsoid(20, 12, 30, 1));
  const auto w = ill::meanValueCoordinates(cage, {1, 2, 3});
  double sum = 0;
  for (double x : w) {
    sum += x;
    EXPECT_GT(x, 0);  // convex cage, interior point
  }
  EXPECT_NEAR(sum, 1.0, 1e-12);
}

TEST(MeanValueCoordinates, AffineMapOfCageMovesPointsAffinely) {
  const ill::Cage cage = ill::cageOf(vellum::test::ellipsoid(20, 12, 30, 2));
  auto affine = [](const Vec3& p) {
    return Vec3{1.2 * p.x + 0.3 * p.y - 0.1 * p.z + 5, -0.2 * p.x + 0.9 * p.y + 0.4 * p.z - 3,
                0.1 * p.x - 0.3 * p.y + 1.5 * p.z + 11};
  };
  std::vector<Vec3> moved;
  for (const auto& v : cage.vertices) moved.push_back(affine(v));
  const auto pts = samplePoints(cage);
  const auto out = ill::transferByMeanValueCoordinates(cage, moved, pts);
  for (size_t i = 0; i < pts.size(); ++i)
    EXPECT_LE(norm(out[i] - affine(pts[i])), 1e-9 * std::max(1.0, norm(affine(pts[i])))) << "point " << i;
}

TEST(MeanValueCoordinates, VertexAndEdgeAreBarycentric) {
  const ill::Cage cage = ill::cageOf(vellum::test::ellipsoid(20, 12, 30, 1));
  const auto& t = cage.faces[3];
  const auto w = ill::meanValueCoordinates(cage, cage.vertices[t[0]]);
  EXPECT_NEAR(w[t[0]], 1.0, 1e-12);
  const auto we = ill::meanValueCoordinates(cage, cage.vertices[t[0]] * 0.25 + cage.vertices[t[1]] * 0.75);
  EXPECT_NEAR(we[t[0]], 0.25, 1e-9);
  EXPECT_NEAR(we[t[1]], 0.75, 1e-9);
}
