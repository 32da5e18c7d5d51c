// Figure annotations: projection, scale bar, orientation letters, labels and leader lines.
#include <gtest/gtest.h>

#include <cmath>

#include "render_common.hpp"
#include "vellum/render/annotations.hpp"

using namespace vellum;
using namespace vellum::render;

namespace {

Geometry cube(int n, double spacing) {
  Geometry g;
  g.dims = {n, n, n};
  g.spacing = {spacing, spacing, spacing};
  g.origin = {-40, 10, 5};
  return g;
}

RenderSettings ortho(int w, int h, double az = 0, double el = 0) {
  RenderSettings s;
  s.width = w;
  s.height = h;
  s.camera.fieldOfViewDeg = 0;
  s.camera.azimuthDeg = az;
  s.camera.elevationDeg = el;
  return s;
}

}  // namespace

TEST(Projection, InvertsThePixelRaysOfTheRenderer) {
  const Geometry g = cube(40, 1.5);
  for (double fov : {0.0, 30.0}) {
    RenderSettings s = ortho(200, 150, 35, 20);
    s.camera.fieldOfViewDeg = fov;
    const Projection p(g, s);
    const detail::Frame f = detail::makeFrame(g, nullptr, s);
    for (auto [px, py] : {std::pair{0, 0}, {199, 149}, {57, 93}}) {
      const detail::Ray r = detail::pixelRay(f, px, py);
      const auto q = p.toPixel(r.origin + r.dir * 120.0);
      ASSERT_TRUE(q);
      EXPECT_NEAR(q->x, px, 1e-6) << fov;
      EXPECT_NEAR(q->y, py, 1e-6) << fov;
    }
  }
  // Orthographic: a 50 mm segment across the screen is 50 * pixelsPerMm pixels long anywhere.
  const Projection o(g, ortho(300, 300, 35, 20));
  const Vec3 a = g.center() + Vec3{3, -7, 11};
  const auto pa = o.toPixel(a), pb = o.toPixel(a + o.screenRight() * 50.0);
  EXPECT_NEAR(pb->x - pa->x, 50 * o.pixelsPerMm(), 1e-6);
  EXPECT_NEAR(pb->y - pa->y, 0, 1e-6);
}

TEST(Annotations, ScaleBarIsAsLongAsItSaysUnderTheCamera) {
  const Geometry g = cube(64, 2.0);
  const Projection p(g, ortho(512, 512));
  RgbaImage image(512, 512);
  for (size_t i = 3; i < image.pixels.size(); i += 4) image.pixels[i] = 255;  // opaque black
  AnnotationOptions o;
  o.scaleBar = true;
  const AnnotationLayout l = annotate(image, p, o);
  EXPECT_NEAR(l.scaleBarPixels, l.scaleBarMm * p.pixelsPerMm(), 1e-9);
  // Count the bar's ink pixels along its bottom row.
  const int y = l.scaleBarStart[1];
  int lit = 0;
  for (int x = 0; x < 512; ++x) lit += image.at(x, y)[0] > 200;
  EXPECT_NEAR(lit, l.scaleBarPixels, 1.0);
  const double mantissa = l.scaleBarMm / std::pow(10.0, std::floor(std::log10(l.scaleBarMm)));
  EXPECT_TRUE(mantissa == 1 || mantissa == 2 || mantissa == 5) << l.scaleBarMm;
}

TEST(Annotations, OrientationLettersFollowTheCamera) {
  const Geometry g = cube(16, 1.0);
  EXPECT_EQ(anatomicalLetters({1, 0, 0}), "L");
  EXPECT_EQ(anatomicalLetters({0, -1, 0}), "A");
  EXPECT_EQ(anatomicalLetters({0.7, 0.7, 0}), "LP");
  RgbaImage image(128, 128);
  AnnotationOptions o;
  o.orientation = true;
  // From the front (azimuth 0): patient left on screen right, superior up.
  auto l = annotate(image, Projection(g, ortho(128, 128, 0, 0)), o);
  EXPECT_EQ(l.orientationLetters, (std::array<std::string, 4>{"L", "R", "S", "I"}));
  // From the patient's left side (azimuth 90): anterior... screen right = posterior.
  l = annotate(image, Projection(g, ortho(128, 128, 90, 0)), o);
  EXPECT_EQ(l.orientationLetters[0], "P");
  EXPECT_EQ(l.orientationLetters[1], "A");
}

TEST(Annotations, LabelsDoNotOverlapAndLeadersEndOnTheirStructures) {
  // Six small cubes of different ids at different heights, seen from the front.
  const Geometry g = cube(60, 1.0);
  LabelVolume labels(g);
  for (uint16_t id = 1; id <= 6; ++id) {
    labels.setLabel({id, "structure " + std::to_string(id), {200, 100, 50}});
    const int64_t x0 = id % 2 ? 8 : 40, z0 = 4 + 8 * (id - 1);
    for (int64_t k = z0; k < z0 + 6; ++k)
      for (int64_t j = 20; j < 40; ++j)
        for (int64_t i = x0; i < x0 + 10; ++i) labels(i, j, k) = id;
  }
  const Projection p(g, ortho(320, 320));
  RgbaImage rendered(320, 320);
  for (size_t i = 3; i < rendered.pixels.size(); i += 4) rendered.pixels[i] = 255;
  std::vector<uint16_t> footprint;
  const auto anchors = structureAnchors(labels, {}, p, rendered, 10, &footprint);
  ASSERT_EQ(anchors.size(), 6u);
  for (const auto& a : anchors) EXPECT_EQ(footprint[size_t(a.y) * 320 + a.x], a.id) << a.name;
  AnnotationOptions o;
  o.labels = true;
  o.orientation = true;
  RgbaImage image = rendered;
  const auto l = annotate(image, p, o, anchors);
  ASSERT_EQ(l.labelBoxes.size(), 6u);
  for (size_t i = 0; i < l.labelBoxes.size(); ++i)
    for (size_t j = i + 1; j < l.labelBoxes.size(); ++j) {
      const auto& a = l.labelBoxes[i];
      const auto& b = l.labelBoxes[j];
      const bool apart = a.x1 < b.x0 || b.x1 < a.x0 || a.y1 < b.y0 || b.y1 < a.y0;
      EXPECT_TRUE(apart) << i << " and " << j << " overlap";
    }
  for (const auto& line : l.leaderLines) {
    const uint16_t id = footprint[size_t(line[3]) * 320 + line[2]];
    EXPECT_NE(id, 0) << "leader ends off every structure";
  }
}

// Deformed frames: a structure's centre is its voxel nearest the centroid, and its drawn
// position is the forward image through the backward map (here u(x) = R^T (x - c - t) + c,
// a turn R about a tilted axis and a shift t, on an anisotropic node grid; both kernels).
TEST(Annotations, DeformedPositionsInvertTheBackwardMap) {
  Geometry g = cube(24, 2.0);
  LabelVolume labels(g);
  labels.setLabel({3, "ball", {}});
  const Vec3 centre = g.indexToPhysical({14, 9, 11});
  for (int64_t k = 0; k < 24; ++k)
    for (int64_t j = 0; j < 24; ++j)
      for (int64_t i = 0; i < 24; ++i)
        if (norm(g.indexToPhysical({double(i), double(j), double(k)}) - centre) <= 6.5) labels(i, j, k) = 3;
  const auto centres = structureCentres(labels, {});
  ASSERT_EQ(centres.size(), 1u);
  EXPECT_EQ(centres[0].id, 3);
  EXPECT_LT(norm(centres[0].mm - centre), 1e-9);

  const Vec3 c = g.center(), t{5, -3, 2}, axis = normalized(Vec3{1, 2, 3});
  const double a = 0.5;  // radians
  const auto turn = [&](const Vec3& v, double s) {  // Rodrigues, angle s * a about axis
    return v * std::cos(s * a) + cross(axis, v) * std::sin(s * a) + axis * (dot(axis, v) * (1 - std::cos(s * a)));
  };
  BackwardMap map;
  map.grid.dims = {14, 12, 10};
  map.grid.spacing = {4.5, 5.0, 6.0};
  map.grid.origin = c - Vec3{30, 28, 27};
  for (int64_t k = 0; k < 10; ++k)
    for (int64_t j = 0; j < 12; ++j)
      for (int64_t i = 0; i < 14; ++i) {
        const Vec3 u = turn(map.grid.indexToPhysical({double(i), double(j), double(k)}) - c - t, -1) + c;
        map.sourceMm.insert(map.sourceMm.end(), {float(u.x), float(u.y), float(u.z)});
      }
  for (const Upsampling up : {Upsampling::Trilinear, Upsampling::Gaussian}) {
    map.upsampling = up;
    const std::vector<Vec3> points{centre, c, c + Vec3{-9, 7, 4}, c + Vec3{1000, 0, 0}};
    const auto drawn = deformedPositions(map, g, points);
    ASSERT_EQ(drawn.size(), 4u);
    for (size_t p = 0; p < 3; ++p) {
      ASSERT_TRUE(drawn[p]) << p;
      EXPECT_LT(norm(*drawn[p] - (turn(points[p] - c, 1) + c + t)), 0.02) << p;  // a hundredth of a voxel
    }
    EXPECT_FALSE(drawn[3]) << "a point no output position maps to";
  }
}
