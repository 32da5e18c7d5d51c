#pragma once
// Analytic shape scenes for the illustration renderer tests (what `vellum shape` would write:
// signed distance in mm, negative inside; exclusive segment labels with a table).
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "vellum/illustration/illustration_renderer.hpp"
#include "vellum/illustration/style.hpp"

namespace vellum::test {

/// One segment: its own signed distance (mm, negative inside) at a physical point.
struct AnalyticSegment {
  std::string name;
  std::function<double(const Vec3&)> sdf;
};

/// Scene on an n^3 grid of `spacing` mm centred at the origin: label = first segment whose
/// sdf < 0 (exclusive), distance = min over segments (the union, as the shape pipeline), and
/// every segment its own field (its sdf, quantised as `vellum shape` writes it).
illustration::ShapeScene makeScene(int n, const std::vector<AnalyticSegment>& segments, double spacing = 1.0);

double sphereSdf(const Vec3& p, const Vec3& c, double r);
double boxSdf(const Vec3& p, const Vec3& c, const Vec3& halfSize);

/// bone (r = 0.18 n) inside muscle (to 0.3 n) inside skin (to 0.36 n), centred.
illustration::ShapeScene nestedScene(int n);
/// nestedScene(48), made once per test program (the scene most GL vs CPU checks draw).
const illustration::ShapeScene& nestedScene48();
/// "bone" sphere left (-x), "muscle" sphere right (+x), radius 0.22 n, separated.
illustration::ShapeScene twoSpheres(int n);
/// A style for those two segments: ivory bone and red muscle, both 0.8 opaque.
illustration::Style twoRowStyle();

/// Writes DIR/distance.nrrd, DIR/segments.nrrd and the per-segment distances as `vellum shape` does.
void writeShapeFolder(const illustration::ShapeScene& scene, const std::filesystem::path& dir);

}  // namespace vellum::test
