#include "analytic_volumes.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "vellum/core/box_corners.hpp"

namespace vellum::test {
namespace {

/// 1 inside, 0 outside, linear over `edge` mm centred on the surface (signed distance d).
double inside(double signedDistance, double edge = 2.5) {
  return std::clamp(0.5 - signedDistance / edge, 0.0, 1.0);
}

/// Approximate signed distance (mm) to an axis-aligned ellipsoid with semi-axes r.
double ellipsoidDistance(const Vec3& q, const Vec3& r) {
  const double k0 = norm(div(q, r));
  const double k1 = norm(div(q, mul(r, r)));
  return k1 > 0 ? k0 * (k0 - 1.0) / k1 : -std::min({r.x, r.y, r.z});
}

Mat3 rotation(Vec3 axis, double degrees) {
  axis = normalized(axis);
  const double a = degrees * std::numbers::pi / 180, c = std::cos(a), s = std::sin(a);
  const double x = axis.x, y = axis.y, z = axis.z;
  Mat3 r;
  r.m = {{{c + x * x * (1 - c), x * y * (1 - c) - z * s, x * z * (1 - c) + y * s},
          {y * x * (1 - c) + z * s, c + y * y * (1 - c), y * z * (1 - c) - x * s},
          {z * x * (1 - c) - y * s, z * y * (1 - c) + x * s, c + z * z * (1 - c)}}};
  return r;
}

Geometry centredGeometry(int n, Vec3 spacing, Mat3 direction, Vec3 centre) {
  Geometry g;
  g.dims = {n, n, n};
  g.spacing = spacing;
  g.direction = direction;
  const Vec3 halfIndex{(n - 1) * 0.5, (n - 1) * 0.5, (n - 1) * 0.5};
  g.origin = centre - direction * mul(halfIndex, spacing);
  return g;
}

}  // namespace

VolumeI16 makeAnalyticVolume(int n) {
  const Vec3 centre{10, -20, 30};
  // Spacing scales with 64/n so the physical size stays ~64 x 83 x 102 mm.
  const double f = 64.0 / n;
  const Geometry g = centredGeometry(n, Vec3{1.0, 1.3, 1.6} * f, rotation({1, 2, 3}, 20), centre);
  VolumeI16 vol(g, -1000, kCtAirHu);
  const Vec3 cylAxis = normalized({1, 0.5, 2});
  const Vec3 cylPoint{-8, 4, 0};
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const Vec3 q = g.indexToPhysical({double(i), double(j), double(k)}) - centre;
        double v = -1000;
        v += inside(ellipsoidDistance(q, {26, 32, 40})) * (40 - v);
        v += inside(norm(q - Vec3{6, 0, 4}) - 11.0) * (1000 - v);
        const Vec3 r = q - cylPoint;
        const double along = dot(r, cylAxis);
        const double radial = norm(r - cylAxis * along);
        v += std::min(inside(radial - 4.0), inside(std::abs(along) - 26.0)) * (500 - v);
        vol(i, j, k) = static_cast<int16_t>(std::lround(v));
      }
  return vol;
}

VolumeI16 makeBallVolume(int n, double spacing, double radiusMm, double value, Vec3 centre) {
  const Geometry g = centredGeometry(n, {spacing, spacing, spacing}, Mat3::identity(), {0, 0, 0});
  VolumeI16 vol(g, -1000, kCtAirHu);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const Vec3 q = g.indexToPhysical({double(i), double(j), double(k)}) - centre;
        vol(i, j, k) = static_cast<int16_t>(std::lround(-1000 + inside(norm(q) - radiusMm) * (value + 1000)));
      }
  return vol;
}

render::BackwardMap makeTwistMap(const Geometry& volume, int nodes, bool withAttributes) {
  render::BackwardMap map;
  const Vec3 c = volume.center();
  // Grid: axis-aligned, isotropic, covering the volume's bounding sphere's cube.
  double radius = 0;
  const Dims& d = volume.dims;
  for (const Vec3& p : indexBoxCorners(volume, {0, 0, 0}, {d.x - 1.0, d.y - 1.0, d.z - 1.0}))
    radius = std::max(radius, norm(p - c));
  const double spacing = 2 * radius / (nodes - 1);
  map.grid.dims = {nodes, nodes, nodes};
  map.grid.spacing = {spacing, spacing, spacing};
  map.grid.origin = c - Vec3{radius, radius, radius};
  const size_t count = static_cast<size_t>(nodes) * nodes * nodes;
  map.sourceMm.resize(3 * count);
  if (withAttributes) map.attributes.resize(4 * count);
  size_t n = 0;
  for (int k = 0; k < nodes; ++k)
    for (int j = 0; j < nodes; ++j)
      for (int i = 0; i < nodes; ++i, ++n) {
        const Vec3 v = map.grid.indexToPhysical({double(i), double(j), double(k)});
        const Vec3 q = v - c;
        const double a = 0.6 * q.z / radius;  // up to ~34 degrees of twist
        const Vec3 u = c + Vec3{std::cos(a) * q.x - std::sin(a) * q.y,
                                std::sin(a) * q.x + std::cos(a) * q.y, q.z} + Vec3{3, -2, 0};
        map.sourceMm[3 * n] = float(u.x);
        map.sourceMm[3 * n + 1] = float(u.y);
        map.sourceMm[3 * n + 2] = float(u.z);
        if (withAttributes) {
          const double s = q.x / radius;  // -1..1 left to right
          map.attributes[4 * n] = float(15 * s);       // lightness
          map.attributes[4 * n + 1] = float(30 * s);   // a: green -> red
          map.attributes[4 * n + 2] = float(-20 * s);  // b: yellow -> blue
          map.attributes[4 * n + 3] = float(1.0 + 0.8 * q.z / radius);  // density
        }
      }
  return map;
}

render::BackwardMap makeIdentityMap(const Geometry& volume) {
  render::BackwardMap map;
  map.grid = volume;
  const Dims& d = volume.dims;
  map.sourceMm.reserve(static_cast<size_t>(d.voxelCount()) * 3);
  for (int64_t k = 0; k < d.z; ++k)
    for (int64_t j = 0; j < d.y; ++j)
      for (int64_t i = 0; i < d.x; ++i) {
        const Vec3 p = volume.indexToPhysical({double(i), double(j), double(k)});
        map.sourceMm.insert(map.sourceMm.end(), {float(p.x), float(p.y), float(p.z)});
      }
  return map;
}

}  // namespace vellum::test
