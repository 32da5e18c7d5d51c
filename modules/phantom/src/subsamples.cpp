// The partial-volume sub-sample pattern of a voxel: 4x4x4 strata of the point-spread
// function, each with one jittered sample, arranged so that along every axis the 64 samples
// also fall in 64 distinct slices (a 3-D "multi-jittered" pattern), then mapped through the
// inverse CDF of the PSF profile. Why: a regular 4x4x4 grid over the voxel's box changes a
// voxel's tissue fraction in steps of 1/4 as a near-axis-aligned surface moves through it,
// and even an exact box average has kinks that the renderer's interpolation and gradients
// alias; both terrace iso-surfaces along voxel layers (rings in renders). Jitter makes the
// fraction unbiased (the per-axis slices bound the error for axis-aligned surfaces to one
// sample), the smooth trapezoid profile removes the aliasing. A voxel takes one of
// kSubSamplePatterns precomputed patterns, picked by a hash of its index (cheap, and still
// uncorrelated between neighbours).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

#include "noise.hpp"
#include "subsamples.hpp"
#include "vellum/phantom/phantom.hpp"

namespace vellum::phantom {
namespace {

/// Counter-based 16-bit draws for one voxel: independent of thread scheduling.
class Draws {
 public:
  explicit Draws(uint64_t key) : key_(key) {}
  uint32_t next16() {
    if (left_ == 0) {
      bits_ = detail::splitmix64(key_ + counter_++);
      left_ = 4;
    }
    const uint32_t r = static_cast<uint32_t>(bits_ & 0xFFFFu);
    bits_ >>= 16;
    --left_;
    return r;
  }
  /// Uniform in [0, 1) on a 1/65536 lattice.
  double unit() { return (next16() + 0.5) * (1.0 / 65536.0); }

 private:
  uint64_t key_, counter_ = 0, bits_ = 0;
  int left_ = 0;
};

/// A pseudo-random permutation of 0..15 (Fisher-Yates).
std::array<uint8_t, 16> permutation16(Draws& r) {
  std::array<uint8_t, 16> p{};
  for (uint8_t n = 0; n < 16; ++n) p[n] = n;
  for (uint32_t n = 15; n > 0; --n) {
    const uint32_t m = (r.next16() * (n + 1)) >> 16;  // 0..n
    std::swap(p[n], p[m]);
  }
  return p;
}

/// Inverse CDF of the density of U(-1/2, 1/2) + h U(-1/2, 1/2) (a trapezoid; h = 0: the
/// voxel's box, h = 1: the tent): maps a stratified uniform to a stratified offset.
double trapezoidInverse(double u, double h) {
  if (u < 0.5 * h) return -0.5 * (1 + h) + std::sqrt(2.0 * h * u);
  if (u > 1.0 - 0.5 * h) return 0.5 * (1 + h) - std::sqrt(2.0 * h * (1.0 - u));
  return u - 0.5;
}

}  // namespace

namespace detail {

uint32_t subSamplePatternIndex(int64_t i, int64_t j, int64_t k) {
  // Fixed salts, not the noise seed: the anatomy (and so the truth) is the same for every seed.
  const uint64_t h = splitmix64(
      splitmix64(splitmix64(0xA5C3E1F00D5EEDull ^ static_cast<uint64_t>(i)) ^
                 static_cast<uint64_t>(j)) ^
      static_cast<uint64_t>(k));
  return static_cast<uint32_t>(h >> 56) % kSubSamplePatterns;
}

std::array<Vec3, kSubSamples> subSamplePattern(uint32_t pattern, double psfSmoothingVoxels) {
  const double h = std::clamp(psfSmoothingVoxels, 0.0, 1.0);
  Draws r(splitmix64(0x5EB5A3D1C0FFEE01ull ^ pattern));
  // Sample (a, b, c) lies in stratum a along x; within it, in slice px[(b, c)] of 16, so the
  // 16 samples of stratum a occupy all 16 slices (likewise for y and z).
  const auto px = permutation16(r), py = permutation16(r), pz = permutation16(r);
  std::array<Vec3, kSubSamples> off{};
  for (int c = 0; c < 4; ++c)
    for (int b = 0; b < 4; ++b)
      for (int a = 0; a < 4; ++a) {
        const double x = trapezoidInverse((a + (px[b + 4 * c] + r.unit()) / 16.0) / 4.0, h);
        const double y = trapezoidInverse((b + (py[a + 4 * c] + r.unit()) / 16.0) / 4.0, h);
        const double z = trapezoidInverse((c + (pz[a + 4 * b] + r.unit()) / 16.0) / 4.0, h);
        off[a + 4 * b + 16 * c] = Vec3{x, y, z};
      }
  return off;
}

}  // namespace detail

std::array<Vec3, kSubSamples> subSampleOffsets(int64_t i, int64_t j, int64_t k,
                                               double psfSmoothingVoxels) {
  return detail::subSamplePattern(detail::subSamplePatternIndex(i, j, k), psfSmoothingVoxels);
}

}  // namespace vellum::phantom
