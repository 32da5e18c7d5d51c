#pragma once
// The separable exact Euclidean distance transform behind distance_transform.cpp and
// segmentation's morphology (an engine for library code; users call distance_transform.hpp). Three passes, each parallel over lines:
//   x: binary two-sided scan along contiguous rows (integer distances, no parabolas needed),
//   y, z: lower envelope of parabolas (Felzenszwalb & Huttenlocher) with that axis's spacing.
// The y and z passes gather blocks of kBlock neighbouring columns at once, so every cache line
// read or written is used kBlock times instead of once. The last pass hands each voxel's
// squared distance (mm²) to a callback instead of storing it, so morphology thresholds in place
// (no float volume read back).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "vellum/core/parallel.hpp"
#include "vellum/core/volume.hpp"

namespace vellum::detail {

inline constexpr float kEdtInf = std::numeric_limits<float>::infinity();
inline constexpr int64_t kEdtBlock = 16;  ///< columns per gathered block (one cache line of floats)

/// Scratch of one envelope computation (allocated once per task, not per line).
struct EnvelopeScratch {
  std::vector<int64_t> v;
  std::vector<double> z;
  explicit EnvelopeScratch(int64_t n) : v(static_cast<size_t>(n)), z(static_cast<size_t>(n + 1)) {}
};

/// d[q] = min_p s2*(q-p)² + f[p] over p in [0, n).
inline void envelope1d(const float* f, float* d, int64_t n, double s2, EnvelopeScratch& S) {
  // Lines entirely on features or entirely without a reachable feature are common (background
  // and deep inside masks, especially with a distance cap): answer them without parabolas.
  bool allZero = true, allInf = true;
  for (int64_t q = 0; q < n; ++q) {
    allZero = allZero && f[q] == 0.0f;
    allInf = allInf && f[q] == kEdtInf;
  }
  if (allZero || allInf) {
    std::fill(d, d + n, allZero ? 0.0f : kEdtInf);
    return;
  }
  int64_t k = -1;
  for (int64_t q = 0; q < n; ++q) {
    if (f[q] == kEdtInf) continue;
    const double fq = f[q] + s2 * double(q) * double(q);
    if (k < 0) {
      k = 0;
      S.v[0] = q;
      S.z[0] = -std::numeric_limits<double>::infinity();
      S.z[1] = std::numeric_limits<double>::infinity();
      continue;
    }
    double s;
    while (true) {
      const int64_t p = S.v[k];
      s = (fq - (f[p] + s2 * double(p) * double(p))) / (2.0 * s2 * double(q - p));
      if (s > S.z[k] || k == 0) break;
      --k;
    }
    if (s <= S.z[k]) {
      S.v[k] = q;  // replaces the only parabola left (k == 0)
    } else {
      ++k;
      S.v[k] = q;
      S.z[k] = s;
    }
    S.z[k + 1] = std::numeric_limits<double>::infinity();
  }
  if (k < 0) {
    std::fill(d, d + n, kEdtInf);
    return;
  }
  int64_t j = 0;
  for (int64_t q = 0; q < n; ++q) {
    while (S.z[j + 1] < double(q)) ++j;
    const double dq = double(q - S.v[j]);
    d[q] = static_cast<float>(s2 * dq * dq + f[S.v[j]]);
  }
}

/// Envelope pass along y (axis 1) or z (axis 2) over `work`, in blocks of kEdtBlock columns.
/// `emit(q, d2)` receives the results when given; otherwise they are written back to `work`.
template <class Emit>
void envelopePass(float* work, const Dims& d, int axis, double spacing, Emit&& emit, bool writeBack) {
  const int64_t sy = d.x, sz = d.x * d.y;
  const int64_t n = axis == 1 ? d.y : d.z, stride = axis == 1 ? sy : sz;
  const int64_t outer = axis == 1 ? d.z : d.y, outerStride = axis == 1 ? sz : sy;
  const double s2 = spacing * spacing;
  parallelFor(outer, [&](int64_t o0, int64_t o1) {
    std::vector<float> in(static_cast<size_t>(kEdtBlock * n)), out(static_cast<size_t>(kEdtBlock * n));
    EnvelopeScratch S(n);
    for (int64_t o = o0; o < o1; ++o)
      for (int64_t i0 = 0; i0 < d.x; i0 += kEdtBlock) {
        const int64_t nb = std::min(kEdtBlock, d.x - i0);
        const int64_t base = o * outerStride + i0;
        for (int64_t t = 0; t < n; ++t) {
          const float* src = work + base + t * stride;
          for (int64_t b = 0; b < nb; ++b) in[b * n + t] = src[b];
        }
        for (int64_t b = 0; b < nb; ++b) envelope1d(in.data() + b * n, out.data() + b * n, n, s2, S);
        for (int64_t t = 0; t < n; ++t) {
          const int64_t q = base + t * stride;
          for (int64_t b = 0; b < nb; ++b) {
            if (writeBack) work[q + b] = out[b * n + t];
            else emit(q + b, out[b * n + t]);
          }
        }
      }
  });
}

/// Squared distances (mm²) to the nearest feature voxel, where a voxel is a feature when
/// (mask != 0) == featureIsNonZero. `work` (voxelCount floats) is scratch; emit(q, d2) is called
/// once per voxel (in parallel, each q once). With a finite `maxD2`, distances beyond it may be
/// reported as infinity (enough for thresholding at maxD2, and much faster: far rows drop out).
template <class Emit>
void squaredEdt(const uint8_t* mask, bool featureIsNonZero, const Geometry& g, float* work, Emit&& emit,
                double maxD2 = std::numeric_limits<double>::infinity()) {
  const Dims d = g.dims;
  const int64_t sy = d.x, sz = d.x * d.y;
  const double sx = g.spacing.x;
  // Pass x: distance in voxels to the nearest feature of the row, both directions.
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j) {
        const uint8_t* m = mask + k * sz + j * sy;
        float* o = work + k * sz + j * sy;
        int64_t last = -1;
        for (int64_t i = 0; i < d.x; ++i) {
          if ((m[i] != 0) == featureIsNonZero) last = i;
          o[i] = last < 0 ? kEdtInf : static_cast<float>(double(i - last));
        }
        last = -1;
        for (int64_t i = d.x - 1; i >= 0; --i) {
          if ((m[i] != 0) == featureIsNonZero) last = i;
          if (last >= 0) o[i] = std::min(o[i], static_cast<float>(double(last - i)));
          if (o[i] != kEdtInf) {
            const double d2 = sx * sx * double(o[i]) * double(o[i]);
            o[i] = d2 > maxD2 ? kEdtInf : static_cast<float>(d2);
          }
        }
      }
  });
  auto none = [](int64_t, float) {};
  if (d.z == 1) {
    envelopePass(work, d, 1, g.spacing.y, emit, false);
    return;
  }
  envelopePass(work, d, 1, g.spacing.y, none, true);
  envelopePass(work, d, 2, g.spacing.z, emit, false);
}

}  // namespace vellum::detail
