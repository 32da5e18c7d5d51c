// Speed images for the level-set snake.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "vellum/core/gaussian_blur.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/segmentation/snake.hpp"

namespace vellum::segmentation {

const params::EnumTable<SpeedType>& speedTypes() {
  static const params::EnumTable<SpeedType> t{"speed type", {"threshold", "edge"}, {{"region", SpeedType::Threshold}}};
  return t;
}

VolumeF32 gaussianBlur(const VolumeI16& ct, double sigmaMm, Progress& progress) {
  VolumeF32 a(ct.geometry(), 0.0f, ct.background());
  const int16_t* s = ct.data();
  float* pa = a.data();
  for (size_t i = 0; i < ct.size(); ++i) pa[i] = s[i];
  gaussianBlurMm(a, sigmaMm, static_cast<float>(ct.background()), progress);  // core's blur
  return a;
}

SpeedImage thresholdSpeed(const VolumeI16& ct, const ThresholdSpeedParams& p, Progress& progress) {
  if (!(p.upper > p.lower)) throw Error("threshold speed: upper must exceed lower");
  if (!(p.smoothnessHu > 0)) throw Error("threshold speed: smoothness must be > 0 HU");
  SpeedImage out{VolumeF32(ct.geometry(), 0.0f, -1.0), SpeedType::Threshold};
  const int16_t* s = ct.data();
  float* o = out.values.data();
  // A lookup table over the int16 range: tanh once per value, not per voxel.
  std::vector<float> lut(65536);
  for (int v = -32768; v <= 32767; ++v)
    lut[v + 32768] = static_cast<float>(std::tanh(std::min(v - p.lower, p.upper - v) / p.smoothnessHu));
  progress.begin("threshold speed", 1);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, ct.size(), 1 << 16),
                    [&](const tbb::blocked_range<size_t>& r) {
                      for (size_t i = r.begin(); i < r.end(); ++i) o[i] = lut[s[i] + 32768];
                    });
  progress.end();
  return out;
}

SpeedImage edgeSpeed(const VolumeI16& ct, const EdgeSpeedParams& p, Progress& progress) {
  if (!(p.kappaHuPerMm > 0) || !(p.exponent > 0)) throw Error("edge speed: kappa and exponent must be > 0");
  const VolumeF32 blurred = gaussianBlur(ct, p.sigmaMm, progress);
  SpeedImage out{VolumeF32(ct.geometry(), 0.0f, 1.0), SpeedType::Edge};
  const Dims d = ct.dims();
  const Vec3 sp = ct.geometry().spacing;
  const float* b = blurred.data();
  float* o = out.values.data();
  const int64_t sy = d.x, sz = d.x * d.y;
  progress.begin("edge speed", static_cast<uint64_t>(d.z));
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k) {
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) {
          const int64_t p0 = k * sz + j * sy + i;
          // Per axis the larger of the forward and backward differences (not the central one):
          // a wall one voxel thick (thin cortex) then still shows its full edge strength, where a
          // central difference across it would read zero and let the contour walk through.
          auto diff = [&](int64_t c, int64_t n, int64_t stride, double h) {
            const double v = b[p0];
            const double back = c > 0 ? std::abs(v - b[p0 - stride]) : 0.0;
            const double fwd = c + 1 < n ? std::abs(b[p0 + stride] - v) : 0.0;
            return std::max(back, fwd) / h;
          };
          const double gx = diff(i, d.x, 1, sp.x), gy = diff(j, d.y, sy, sp.y), gz = diff(k, d.z, sz, sp.z);
          const double gm = std::sqrt(gx * gx + gy * gy + gz * gz) / p.kappaHuPerMm;
          o[p0] = static_cast<float>(1.0 / (1.0 + std::pow(gm, p.exponent)));
        }
      progress.advance();
    }
  });
  progress.end();
  return out;
}

}  // namespace vellum::segmentation
