// Curve analogy end to end on an analytic ellipsoid: the outline moves toward a bulging
// drawing, meshes stay valid, the CT backward map is the identity for an undeformed cage.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>

#include "test_meshes.hpp"
#include "vellum/illustration/curve_analogy.hpp"

namespace ill = vellum::illustration;
using namespace vellum;

namespace {

Geometry cube(int64_t n) {
  Geometry g;
  g.dims = {n, n, n};
  g.spacing = {1, 1, 1};
  const double c = -0.5 * double(n - 1);
  g.origin = {c, c, c};
  return g;
}

render::RenderSettings frontView(int size) {
  render::RenderSettings s;
  s.width = s.height = size;
  s.camera.azimuthDeg = 0;
  s.camera.elevationDeg = 0;
  s.camera.fieldOfViewDeg = 0;  // orthographic
  return s;
}

/// The outline with a smooth bulge pushed out around angle `at` (radians about its centre).
ill::Polyline2 bulge(const ill::Polyline2& c, double at, double amountPx) {
  double cx = 0, cy = 0;
  for (const auto& p : c) { cx += p.x / double(c.size()); cy += p.y / double(c.size()); }
  ill::Polyline2 out;
  for (const auto& p : c) {
    const double a = std::atan2(p.y - cy, p.x - cx);
    double d = std::remainder(a - at, 2 * std::numbers::pi);
    const double w = std::exp(-d * d / (2 * 0.35 * 0.35));
    const double r = std::hypot(p.x - cx, p.y - cy);
    const double k = (r + amountPx * w) / r;
    out.push_back({cx + (p.x - cx) * k, cy + (p.y - cy) * k});
  }
  return out;
}

}  // namespace

TEST(CurveAnalogy, SilhouetteOfEllipsoidFromFront) {
  const auto m = vellum::test::ellipsoid(15, 10, 25, 3);
  const Geometry g = cube(64);
  const render::Projection proj(g, frontView(256));
  const auto sil = ill::silhouetteLoop(m, proj);
  ASSERT_GE(sil.vertices.size(), 20u);
  // Seen from the front (anterior, -y) the outline is the x-z ellipse: 15 x 25 mm.
  double xmin = 1e9, xmax = -1e9;
  for (const auto& p : sil.pixels) { xmin = std::min(xmin, p.x); xmax = std::max(xmax, p.x); }
  EXPECT_NEAR((xmax - xmin) / proj.pixelsPerMm(), 30.0, 1.0);
}

TEST(CurveAnalogy, OutlineMovesTowardDrawingAndMeshesStayValid) {
  const auto m0 = vellum::test::ellipsoid(15, 10, 25, 4);  // 5120 faces
  const auto inner = vellum::test::ellipsoid(6, 5, 15, 3);  // "bone" carried along
  const Geometry g = cube(64);
  const render::Projection proj(g, frontView(256));
  const auto c1 = ill::silhouetteLoop(m0, proj).pixels;
  const auto c0 = bulge(ill::resampleByArcLength(c1, 300, true), 0.0, 12.0);  // bulge to the right

  ill::CurveAnalogyOptions o;
  o.proxyFaces = 1000;
  const auto r = ill::curveAnalogy(m0, c0, proj, o);
  std::printf("Hausdorff before %.2f px, after %.2f px (proxy %zu faces; %.0f + %.0f + %.0f ms)\n",
              r.hausdorffBeforePx, r.hausdorffAfterPx, r.proxy.faces.size(), r.proxyMs, r.curveMs, r.arapMs);
  EXPECT_GT(r.hausdorffBeforePx, 3.0);
  EXPECT_LE(r.hausdorffAfterPx, 0.5 * r.hausdorffBeforePx);

  ill::TriMesh deformedProxy = r.proxy;
  for (size_t i = 0; i < r.proxyDeformed.size(); ++i)
    deformedProxy.vertices[i] = {float(r.proxyDeformed[i].x), float(r.proxyDeformed[i].y), float(r.proxyDeformed[i].z)};
  const ill::Cage cage = ill::cageOf(r.proxy);
  for (const auto* mesh : {&deformedProxy}) {
    const auto c = ill::checkMesh(*mesh);
    EXPECT_TRUE(c.closed && c.manifold && c.outward);
    EXPECT_EQ(c.selfIntersections, 0);
  }
  for (const auto& src : {m0, inner}) {
    const auto out = ill::transferMesh(src, cage, r.proxyDeformed);
    const auto c = ill::checkMesh(out);
    EXPECT_TRUE(c.closed && c.manifold && c.outward);
    EXPECT_EQ(c.selfIntersections, 0);
  }
  // The transferred M0's own silhouette also moved toward the drawing.
  const auto m0After = ill::transferMesh(m0, cage, r.proxyDeformed);
  const double after0 = ill::hausdorff(ill::silhouetteLoop(m0After, proj).pixels, r.c0Aligned, true, true);
  EXPECT_LE(after0, 0.5 * r.hausdorffBeforePx);

  // The CT backward map (MVC w.r.t. the deformed cage applied to the rest cage) sends the
  // deformed surface back onto the original one, within a voxel (1 mm here).
  std::vector<Vec3> moved;
  for (const auto& v : m0After.vertices) moved.push_back({v[0], v[1], v[2]});
  const ill::Cage deformedCage{r.proxyDeformed, r.proxy.faces};
  const auto back = ill::transferByMeanValueCoordinates(deformedCage, cage.vertices, moved);
  double worst = 0;
  for (size_t i = 0; i < back.size(); ++i)
    worst = std::max(worst, norm(back[i] - Vec3{m0.vertices[i][0], m0.vertices[i][1], m0.vertices[i][2]}));
  std::printf("backward map round trip of the surface: max %.3f mm\n", worst);
  EXPECT_LE(worst, 1.0);
}

TEST(CurveAnalogy, BackwardMapIsIdentityForUndeformedCage) {
  const ill::Cage cage = ill::cageOf(vellum::test::ellipsoid(15, 10, 25, 2));
  const Geometry g = cube(24);
  const auto map = ill::cageBackwardMap(cage, cage.vertices, g, 4);
  ASSERT_EQ(map.size(), size_t(24 * 24 * 24 * 3));
  double worst = 0;
  for (int64_t k = 0; k < 24; ++k)
    for (int64_t j = 0; j < 24; ++j)
      for (int64_t i = 0; i < 24; ++i) {
        const Vec3 p = g.indexToPhysical(Vec3{double(i), double(j), double(k)});
        const float* m = &map[size_t(((k * 24 + j) * 24 + i) * 3)];
        worst = std::max(worst, norm(Vec3{m[0], m[1], m[2]} - p));
      }
  EXPECT_LE(worst, 1e-5);  // float storage of coordinates ~12 mm: 1e-6 relative
}

TEST(CurveAnalogy, CurveJsonErrorsNameTheFile) {
  const auto dir = std::filesystem::temp_directory_path() / "vellum_curve_json_test";
  std::filesystem::create_directories(dir);
  const auto bad = dir / "bad.json";
  { std::ofstream(bad) << "{\"points\": [[1, 2], [3]]}"; }
  try {
    ill::loadCurveJson(bad);
    FAIL();
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("bad.json"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("point 1"), std::string::npos);
  }
  std::filesystem::remove_all(dir);
}
