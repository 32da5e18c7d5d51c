#pragma once
// Signed-distance primitives in mm (negative inside) for the phantom's anatomy.
// Approximate where exact forms are costly (ellipses): the anatomy is DEFINED by these
// functions, so approximation changes the shape slightly but never the truth's consistency.
#include <algorithm>
#include <cmath>

namespace vellum::phantom::sdf {

/// Ellipse with semi-axes a, b (first-order distance: k0 (k0 - 1) / k1, accurate near the
/// boundary, which is where it decides labels and partial volume).
inline double ellipse(double x, double y, double a, double b) {
  const double ux = x / a, uy = y / b;
  const double k0 = std::sqrt(ux * ux + uy * uy);
  const double vx = ux / a, vy = uy / b;
  const double k1 = std::sqrt(vx * vx + vy * vy);
  if (k1 < 1e-12) return -std::min(a, b);
  return k0 * (k0 - 1.0) / k1;
}

/// Ellipsoid centred at the origin with semi-axes a, b, c (same first-order form).
inline double ellipsoid(double x, double y, double z, double a, double b, double c) {
  const double ux = x / a, uy = y / b, uz = z / c;
  const double k0 = std::sqrt(ux * ux + uy * uy + uz * uz);
  const double vx = ux / a, vy = uy / b, vz = uz / c;
  const double k1 = std::sqrt(vx * vx + vy * vy + vz * vz);
  if (k1 < 1e-12) return -std::min({a, b, c});
  return k0 * (k0 - 1.0) / k1;
}

/// Vertical capsule: segment from (cx, cy, z0) to (cx, cy, z1), radius r. Exact.
inline double capsuleZ(double x, double y, double z, double cx, double cy, double z0, double z1,
                       double r) {
  const double dz = z - std::clamp(z, z0, z1);
  const double dx = x - cx, dy = y - cy;
  return std::sqrt(dx * dx + dy * dy + dz * dz) - r;
}

/// Intersection of a radial (cross-section) distance and an axial slab distance, with the
/// edges rounded by `rounding` mm (exact for exact inputs away from the rounded edge).
inline double roundedCap(double radial, double axial, double rounding) {
  const double wx = radial + rounding, wy = axial + rounding;
  const double ox = std::max(wx, 0.0), oy = std::max(wy, 0.0);
  return std::min(std::max(wx, wy), 0.0) + std::sqrt(ox * ox + oy * oy) - rounding;
}

/// Polynomial smooth minimum with blend radius k (mm): a fillet between two shapes.
/// Equals min(a, b) where |a - b| >= k; never above min(a, b); 1-Lipschitz.
inline double smoothMin(double a, double b, double k) {
  const double h = std::max(k - std::abs(a - b), 0.0) / k;
  return std::min(a, b) - h * h * k * 0.25;
}

/// Cubic smoothstep of t from e0 to e1 (clamped).
inline double smoothstep(double e0, double e1, double t) {
  const double u = std::clamp((t - e0) / (e1 - e0), 0.0, 1.0);
  return u * u * (3.0 - 2.0 * u);
}

}  // namespace vellum::phantom::sdf
