#include "vellum/segmentation/distance_transform.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <limits>
#include <vector>

#include "vellum/core/parallel.hpp"

namespace vellum::segmentation {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

/// Scratch buffers of one 1D pass (allocated once per task, not per line).
struct Line {
  std::vector<float> f, d;
  std::vector<int64_t> v;
  std::vector<double> z;
  explicit Line(int64_t n) : f(n), d(n), v(n), z(n + 1) {}
};

/// d[q] = min_p s2*(q-p)² + f[p]: lower envelope of parabolas (Felzenszwalb & Huttenlocher).
void envelope1d(Line& L, int64_t n, double s2) {
  const float* f = L.f.data();
  int64_t k = -1;
  for (int64_t q = 0; q < n; ++q) {
    if (f[q] == kInf) continue;
    const double fq = f[q] + s2 * double(q) * double(q);
    if (k < 0) {
      k = 0; L.v[0] = q;
      L.z[0] = -std::numeric_limits<double>::infinity();
      L.z[1] = std::numeric_limits<double>::infinity();
      continue;
    }
    double s;
    while (true) {
      const int64_t p = L.v[k];
      s = (fq - (f[p] + s2 * double(p) * double(p))) / (2.0 * s2 * double(q - p));
      if (s > L.z[k] || k == 0) break;
      --k;
    }
    if (s <= L.z[k]) {  // only possible at k == 0 with z[0] = -inf: never; kept for clarity
      L.v[k] = q;
    } else {
      ++k;
      L.v[k] = q;
      L.z[k] = s;
    }
    L.z[k + 1] = std::numeric_limits<double>::infinity();
  }
  if (k < 0) {
    for (int64_t q = 0; q < n; ++q) L.d[q] = kInf;
    return;
  }
  int64_t j = 0;
  for (int64_t q = 0; q < n; ++q) {
    while (L.z[j + 1] < double(q)) ++j;
    const double dq = double(q - L.v[j]);
    L.d[q] = static_cast<float>(s2 * dq * dq + f[L.v[j]]);
  }
}

}  // namespace

VolumeF32 squaredDistanceMm(const Mask& features, Progress& progress) {
  const Geometry& g = features.geometry();
  const Dims d = g.dims;
  VolumeF32 out(g, 0.0f, 0.0);
  float* o = out.data();
  const uint8_t* m = features.data();
  const int64_t sx = 1, sy = d.x, sz = d.x * d.y;
  progress.begin("distance transform", 3);

  // Pass x (contiguous rows), seeding with 0 on features and infinity elsewhere.
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    Line L(d.x);
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j) {
        const int64_t base = k * sz + j * sy;
        for (int64_t i = 0; i < d.x; ++i) L.f[i] = m[base + i] ? 0.0f : kInf;
        envelope1d(L, d.x, g.spacing.x * g.spacing.x);
        for (int64_t i = 0; i < d.x; ++i) o[base + i] = L.d[i];
      }
  });
  progress.advance();
  // Pass y.
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    Line L(d.y);
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t i = 0; i < d.x; ++i) {
        const int64_t base = k * sz + i;
        for (int64_t j = 0; j < d.y; ++j) L.f[j] = o[base + j * sy];
        envelope1d(L, d.y, g.spacing.y * g.spacing.y);
        for (int64_t j = 0; j < d.y; ++j) o[base + j * sy] = L.d[j];
      }
  });
  progress.advance();
  // Pass z (parallel over rows j; columns walk i innermost to reuse cache lines).
  parallelFor(d.y, [&](int64_t j0, int64_t j1) {
    Line L(d.z);
    for (int64_t j = j0; j < j1; ++j)
      for (int64_t i = 0; i < d.x; ++i) {
        const int64_t base = j * sy + i * sx;
        for (int64_t k = 0; k < d.z; ++k) L.f[k] = o[base + k * sz];
        envelope1d(L, d.z, g.spacing.z * g.spacing.z);
        for (int64_t k = 0; k < d.z; ++k) o[base + k * sz] = L.d[k];
      }
  });
  progress.end();
  return out;
}

VolumeF32 signedDistanceMm(const Mask& mask, Progress& progress) {
  VolumeF32 toInside = squaredDistanceMm(mask, progress);
  const VolumeF32 toOutside = squaredDistanceMm(maskNot(mask), progress);
  float* a = toInside.data();
  const float* b = toOutside.data();
  const uint8_t* m = mask.data();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, mask.size(), 1 << 16),
                    [&](const tbb::blocked_range<size_t>& r) {
                      for (size_t i = r.begin(); i < r.end(); ++i)
                        a[i] = m[i] ? -std::sqrt(b[i]) : std::sqrt(a[i]);
                    });
  return toInside;
}

}  // namespace vellum::segmentation
