#include <gtest/gtest.h>

#include <cmath>

#include "vellum/core/geometry.hpp"
#include "vellum/core/error.hpp"

using namespace vellum;

namespace {
Geometry rotatedGeometry() {
  Geometry g;
  g.dims = {10, 20, 30};
  g.spacing = {0.5, 0.75, 2.0};
  g.origin = {-12.0, 3.5, 100.0};
  const double c = std::cos(0.5), s = std::sin(0.5);
  g.direction = Mat3::fromColumns({c, s, 0}, {-s, c, 0}, {0, 0, 1});
  return g;
}
}  // namespace

TEST(Geometry, IndexToPhysicalFollowsConvention) {
  Geometry g = rotatedGeometry();
  // physical = origin + D * (ijk * spacing)
  const Vec3 p = g.indexToPhysical({2, 4, 1});
  const Vec3 expected = g.origin + g.direction.column(0) * (2 * 0.5) +
                        g.direction.column(1) * (4 * 0.75) + g.direction.column(2) * 2.0;
  EXPECT_NEAR(norm(p - expected), 0.0, 1e-12);
  EXPECT_EQ(g.indexToPhysical({0, 0, 0}), g.origin);
}

TEST(Geometry, RoundTripIndexPhysical) {
  Geometry g = rotatedGeometry();
  for (Vec3 ijk : {Vec3{0, 0, 0}, Vec3{9, 19, 29}, Vec3{3.25, -1.5, 7.75}}) {
    const Vec3 back = g.physicalToIndex(g.indexToPhysical(ijk));
    EXPECT_NEAR(norm(back - ijk), 0.0, 1e-10);
  }
}

TEST(Geometry, NonOrthogonalDirectionUsesTrueInverse) {
  Geometry g = rotatedGeometry();
  g.direction = Mat3::fromColumns({1, 0, 0}, {0, 1, 0}, normalized(Vec3{0, 0.2, 1}));  // sheared
  const Vec3 ijk{1.5, 2.5, 3.5};
  EXPECT_NEAR(norm(g.physicalToIndex(g.indexToPhysical(ijk)) - ijk), 0.0, 1e-10);
}

TEST(Geometry, CenterAndExtent) {
  Geometry g;
  g.dims = {11, 21, 5};
  g.spacing = {1, 0.5, 3};
  EXPECT_EQ(g.extent(), (Vec3{10, 10, 12}));
  EXPECT_EQ(g.center(), (Vec3{5, 5, 6}));
}

TEST(Geometry, ValidateRejectsBadValues) {
  Geometry g = rotatedGeometry();
  EXPECT_NO_THROW(g.validate("x"));
  Geometry z = g;
  z.spacing.y = 0;
  EXPECT_THROW(z.validate("file.nrrd"), Error);
  try {
    z.validate("file.nrrd");
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("file.nrrd"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("spacing"), std::string::npos);
  }
  Geometry n = g;
  n.spacing.x = std::nan("");
  EXPECT_THROW(n.validate("x"), Error);
  Geometry d = g;
  d.dims.z = 0;
  EXPECT_THROW(d.validate("x"), Error);
  Geometry s = g;
  s.direction = Mat3::fromColumns({1, 0, 0}, {1, 0, 0}, {0, 0, 1});
  EXPECT_THROW(s.validate("x"), Error);
  Geometry h = g;
  h.dims.x = 1 << 20;
  EXPECT_THROW(h.validate("x"), Error);
}

TEST(Mat3, InverseAndDeterminant) {
  Mat3 a = Mat3::fromColumns({2, 0, 1}, {0, 3, 0}, {1, 0, 4});
  Mat3 inv;
  ASSERT_TRUE(a.inverse(inv));
  EXPECT_LT(maxAbsDiff(a * inv, Mat3::identity()), 1e-12);
  EXPECT_NEAR(a.determinant(), 2 * 3 * 4 - 3 * 1, 1e-12);
  Mat3 singular = Mat3::fromColumns({1, 2, 3}, {2, 4, 6}, {0, 0, 1});
  EXPECT_FALSE(singular.inverse(inv));
}
