#include "normal_volume.hpp"

#include <algorithm>
#include <cmath>

#include "vellum/core/parallel.hpp"

namespace vellum::render::detail {
namespace {

int8_t encodeSnorm(double v) {
  return static_cast<int8_t>(std::lround(std::clamp(v, -1.0, 1.0) * 127.0));
}

template <class T>
NormalVolume computeTyped(const Volume<T>& vol) {
  const Geometry& g = vol.geometry();
  const Dims d = g.dims;
  NormalVolume out;
  out.dims = d;
  checkMemoryBudget(d, 4, "normal (RGBA8)");
  out.texels.assign(static_cast<size_t>(d.voxelCount()) * 4, 0);

  Mat3 dirInv;
  if (!g.direction.inverse(dirInv)) throw Error("render: singular direction matrix");
  const Mat3 toPhysical = dirInv.transposed();  // gradients transform by the inverse transpose
  const auto [vmin, vmax] = vol.valueRange();
  const double span = std::max({vmax, vol.background()}) - std::min({vmin, vol.background()});
  const double minSpacing = std::min({g.spacing.x, g.spacing.y, g.spacing.z});
  const double magScale = minSpacing / (std::max(span, 1e-6) * kGradScaleFraction);
  const double hx = 0.5 / g.spacing.x, hy = 0.5 / g.spacing.y, hz = 0.5 / g.spacing.z;

  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j) {
        const bool innerJK = j > 0 && j + 1 < d.y && k > 0 && k + 1 < d.z;
        for (int64_t i = 0; i < d.x; ++i) {
          Vec3 grad;
          if (innerJK && i > 0 && i + 1 < d.x) {
            const T* p = vol.data() + vol.linearIndex(i, j, k);
            const int64_t sy = d.x, sz = d.x * d.y;
            grad = {(double(p[1]) - double(p[-1])) * hx, (double(p[sy]) - double(p[-sy])) * hy,
                    (double(p[sz]) - double(p[-sz])) * hz};
          } else {
            grad = {(vol.valueOr(i + 1, j, k) - vol.valueOr(i - 1, j, k)) * hx,
                    (vol.valueOr(i, j + 1, k) - vol.valueOr(i, j - 1, k)) * hy,
                    (vol.valueOr(i, j, k + 1) - vol.valueOr(i, j, k - 1)) * hz};
          }
          const Vec3 gp = toPhysical * grad;
          const double mag = norm(gp);
          int8_t* t = out.texels.data() + vol.linearIndex(i, j, k) * 4;
          if (mag > 0) {
            t[0] = encodeSnorm(gp.x / mag);
            t[1] = encodeSnorm(gp.y / mag);
            t[2] = encodeSnorm(gp.z / mag);
            t[3] = encodeSnorm(mag * magScale);
          }
        }
      }
  });
  return out;
}

}  // namespace

NormalVolume computeNormalVolume(const AnyVolume& volume) {
  return std::visit([](const auto& v) { return computeTyped(v); }, volume);
}

std::array<float, 4> NormalVolume::sample(double x, double y, double z) const {
  const double fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
  const auto i0 = static_cast<int64_t>(fx), j0 = static_cast<int64_t>(fy),
             k0 = static_cast<int64_t>(fz);
  const float tx = static_cast<float>(x - fx), ty = static_cast<float>(y - fy),
              tz = static_cast<float>(z - fz);
  std::array<float, 4> out{};
  if (i0 < -1 || j0 < -1 || k0 < -1 || i0 >= dims.x || j0 >= dims.y || k0 >= dims.z) return out;
  for (int c = 0; c < 8; ++c) {
    const int64_t i = i0 + (c & 1), j = j0 + ((c >> 1) & 1), k = k0 + ((c >> 2) & 1);
    if (i < 0 || j < 0 || k < 0 || i >= dims.x || j >= dims.y || k >= dims.z) continue;
    const float w = ((c & 1) ? tx : 1 - tx) * (((c >> 1) & 1) ? ty : 1 - ty) *
                    (((c >> 2) & 1) ? tz : 1 - tz);
    const int8_t* t = texels.data() + static_cast<size_t>((k * dims.y + j) * dims.x + i) * 4;
    for (int ch = 0; ch < 4; ++ch) out[ch] += w * std::max(t[ch] / 127.f, -1.f);
  }
  return out;
}

}  // namespace vellum::render::detail
