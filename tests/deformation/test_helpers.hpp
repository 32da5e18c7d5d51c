#pragma once
// Shared helpers of the deformation tests: analytic control-point sets and volumes.
#include <random>
#include <vector>

#include "vellum/core/volume.hpp"
#include "vellum/deformation/control_point.hpp"

namespace vellum::deformation::test {

/// 16 points spread over a box (a 2x2x4 grid, jittered so that no 4 are coplanar).
inline std::vector<Vec3> spreadPoints(const Vec3& lo, const Vec3& hi, unsigned seed = 7) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> jitter(-0.08, 0.08);
  std::vector<Vec3> pts;
  for (int k = 0; k < 4; ++k)
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i) {
        const Vec3 f{0.2 + 0.6 * i + jitter(rng), 0.2 + 0.6 * j + jitter(rng),
                     0.1 + 0.8 * k / 3.0 + jitter(rng)};
        pts.push_back(lo + mul(hi - lo, f));
      }
  return pts;
}

/// Column-convention affine y = T x + t.
struct Affine {
  Mat3 T;
  Vec3 t;
  Vec3 apply(const Vec3& x) const { return T * x + t; }
  Vec3 inverse(const Vec3& y) const {
    Mat3 inv;
    (void)T.inverse(inv);
    return inv * (y - t);
  }
};

inline Affine someAffine() {
  Affine a;
  a.T.m = {{{1.10, 0.12, -0.05}, {-0.08, 0.93, 0.10}, {0.04, -0.11, 1.05}}};
  a.t = {6.5, -4.0, 9.25};
  return a;
}

inline ControlPoints pointsFrom(const std::vector<Vec3>& sources, const std::vector<Vec3>& targets) {
  ControlPoints cp;
  for (size_t i = 0; i < sources.size(); ++i) cp.push_back({sources[i], targets[i], {}});
  return cp;
}

/// Random positions inside a box (mm).
inline std::vector<Vec3> randomPositions(const Vec3& lo, const Vec3& hi, int n, unsigned seed = 3) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Vec3> out;
  for (int i = 0; i < n; ++i) out.push_back(lo + mul(hi - lo, Vec3{u(rng), u(rng), u(rng)}));
  return out;
}

/// A rotation about an arbitrary axis (degrees).
inline Mat3 rotation(Vec3 axis, double deg) {
  axis = normalized(axis);
  const double a = deg * 3.14159265358979323846 / 180.0, c = std::cos(a), s = std::sin(a);
  Mat3 r;
  const double x = axis.x, y = axis.y, z = axis.z;
  r.m = {{{c + x * x * (1 - c), x * y * (1 - c) - z * s, x * z * (1 - c) + y * s},
          {y * x * (1 - c) + z * s, c + y * y * (1 - c), y * z * (1 - c) - x * s},
          {z * x * (1 - c) - y * s, z * y * (1 - c) + x * s, c + z * z * (1 - c)}}};
  return r;
}

/// CT-like analytic volume: soft tissue (40 HU) cylinder along z with a dense "bone" rod
/// (1200 HU) inside, air (-1000) outside; anisotropic spacing and a rotated direction.
inline VolumeI16 analyticCt(Dims dims = {40, 36, 30}, Vec3 spacing = {1.0, 1.5, 2.5},
                            bool rotated = true) {
  Geometry g;
  g.dims = dims;
  g.spacing = spacing;
  g.origin = {-20, -25, -30};
  if (rotated) g.direction = rotation({0.3, -0.2, 1.0}, 20);
  VolumeI16 v(g, -1000, -1000);
  const Vec3 c{dims.x * spacing.x * 0.5, dims.y * spacing.y * 0.5, 0};
  for (int64_t k = 0; k < dims.z; ++k)
    for (int64_t j = 0; j < dims.y; ++j)
      for (int64_t i = 0; i < dims.x; ++i) {
        const double x = i * spacing.x - c.x, y = j * spacing.y - c.y;
        const double r = std::sqrt(x * x + y * y);
        const double rb = std::sqrt((x - 4) * (x - 4) + y * y);
        v(i, j, k) = static_cast<int16_t>(rb < 5 ? 1200 : r < 17 ? 40 : -1000);
      }
  return v;
}

}  // namespace vellum::deformation::test
