// Separable Gaussian blur (gaussian_blur.hpp).
#include "vellum/core/gaussian_blur.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "vellum/core/parallel.hpp"

namespace vellum {
namespace {

std::vector<float> gaussianKernel(double sigmaVoxels) {
  const int r = std::max(1, static_cast<int>(std::ceil(3.0 * sigmaVoxels)));
  std::vector<float> k(2 * r + 1);
  double sum = 0;
  for (int i = -r; i <= r; ++i) sum += k[i + r] = static_cast<float>(std::exp(-0.5 * i * i / (sigmaVoxels * sigmaVoxels)));
  for (auto& v : k) v = static_cast<float>(v / sum);
  return k;
}

/// One separable pass along `axis`, src -> dst, samples outside the grid = `outside`.
void blurAxis(const float* src, float* dst, const Dims& d, int axis, const std::vector<float>& k, float outside) {
  const int r = static_cast<int>(k.size() / 2);
  const int64_t n = d[axis];
  const int64_t stride = axis == 0 ? 1 : (axis == 1 ? d.x : d.x * d.y);
  // Lines along `axis`, enumerated by the other two coordinates; parallel over z (or y for z).
  const int64_t outer = axis == 2 ? d.y : d.z;
  parallelFor(outer, [&](int64_t o0, int64_t o1) {
    std::vector<float> line(static_cast<size_t>(n + 2 * r));
    for (int64_t o = o0; o < o1; ++o) {
      const int64_t inner = axis == 0 ? d.y : d.x;
      for (int64_t t = 0; t < inner; ++t) {
        int64_t base;
        if (axis == 0) base = o * d.x * d.y + t * d.x;
        else if (axis == 1) base = o * d.x * d.y + t;
        else base = o * d.x + t;
        for (int i = 0; i < r; ++i) line[i] = line[n + r + i] = outside;
        for (int64_t s = 0; s < n; ++s) line[s + r] = src[base + s * stride];
        for (int64_t s = 0; s < n; ++s) {
          float acc = 0;
          const float* l = line.data() + s;
          for (size_t q = 0; q < k.size(); ++q) acc += k[q] * l[q];
          dst[base + s * stride] = acc;
        }
      }
    }
  });
}

}  // namespace

void gaussianBlurMm(VolumeF32& v, double sigmaMm, float outside, Progress& progress) {
  if (!(sigmaMm > 0)) return;
  VolumeF32 tmp(v.geometry(), 0.0f, v.background());
  const Vec3 sp = v.geometry().spacing;
  progress.begin("gaussian blur", 3);
  blurAxis(v.data(), tmp.data(), v.dims(), 0, gaussianKernel(sigmaMm / sp.x), outside);
  progress.advance();
  blurAxis(tmp.data(), v.data(), v.dims(), 1, gaussianKernel(sigmaMm / sp.y), outside);
  progress.advance();
  blurAxis(v.data(), tmp.data(), v.dims(), 2, gaussianKernel(sigmaMm / sp.z), outside);
  progress.end();
  v = std::move(tmp);
}

}  // namespace vellum
