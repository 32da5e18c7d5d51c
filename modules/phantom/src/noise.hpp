#pragma once
// Counter-based Gaussian noise: the value for voxel n depends only on (seed, n), so the
// phantom is identical whatever the thread count or scheduling.
#include <cmath>
#include <cstdint>
#include <numbers>

namespace vellum::phantom::detail {

inline uint64_t splitmix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

/// Two independent standard normal deviates for counter `pair` under `seed` (Box-Muller on
/// the two 32-bit halves of one hash). Voxel n uses component n & 1 of pair n >> 1.
struct GaussianPair {
  double a, b;
};
inline GaussianPair gaussianPair(uint64_t seed, uint64_t pair) {
  const uint64_t h = splitmix64(splitmix64(seed) ^ pair);
  // u1 in (0, 1] so that log(u1) is finite; u2 in [0, 1).
  const double u1 = (static_cast<double>(h >> 32) + 1.0) * (1.0 / 4294967296.0);
  const double u2 = static_cast<double>(h & 0xFFFFFFFFull) * (1.0 / 4294967296.0);
  const double r = std::sqrt(-2.0 * std::log(u1)), t = 2.0 * std::numbers::pi * u2;
  return {r * std::cos(t), r * std::sin(t)};
}

/// The deviate of voxel `n` (what makePhantom adds, times sigma).
inline double gaussian(uint64_t seed, uint64_t n) {
  const GaussianPair g = gaussianPair(seed, n >> 1);
  return (n & 1) ? g.b : g.a;
}

}  // namespace vellum::phantom::detail
