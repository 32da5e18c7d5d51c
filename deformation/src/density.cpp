#include "vellum/deformation/density.hpp"

#include <algorithm>
#include <cmath>
#include <variant>

#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/deformation/deform_params.hpp"

namespace vellum::deformation {

const params::EnumTable<PhiRule>& phiRules() {
  static const params::EnumTable<PhiRule> t{"phi rule", {"min", "mean", "none"}};
  return t;
}
const params::EnumTable<RayMode>& rayModes() {
  static const params::EnumTable<RayMode> t{"ray mode", {"linear", "conic"}};
  return t;
}
const params::EnumTable<MipReduction>& mipReductions() {
  static const params::EnumTable<MipReduction> t{"mip reduction", {"mean", "max"}};
  return t;
}

namespace {

// Next pyramid level: every axis halved (rounded up), mean or max of the (up to 8) children.
VolumeF32 downsample(const VolumeF32& fine, MipReduction reduction) {
  const Dims fd = fine.dims();
  Geometry g = fine.geometry();
  g.dims = {(fd.x + 1) / 2, (fd.y + 1) / 2, (fd.z + 1) / 2};
  g.origin = fine.geometry().indexToPhysical({0.5, 0.5, 0.5});
  g.spacing = g.spacing * 2.0;
  VolumeF32 coarse(g, 0.f, fine.background());
  const bool useMax = reduction == MipReduction::Max;
  parallelFor(g.dims.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < g.dims.y; ++j)
        for (int64_t i = 0; i < g.dims.x; ++i) {
          float acc = useMax ? -1e30f : 0.f;
          int n = 0;
          for (int64_t c = 2 * k; c < std::min(2 * k + 2, fd.z); ++c)
            for (int64_t b = 2 * j; b < std::min(2 * j + 2, fd.y); ++b)
              for (int64_t a = 2 * i; a < std::min(2 * i + 2, fd.x); ++a) {
                const float v = fine(a, b, c);
                acc = useMax ? std::max(acc, v) : acc + v;
                ++n;
              }
          coarse(i, j, k) = useMax ? acc : acc / static_cast<float>(n);
        }
  });
  return coarse;
}

// Trilinear sample of a density level at index (x,y,z): float fast path inside, the volume's
// own background-aware sampler at the borders.
inline double sampleFast(const VolumeF32& v, const Vec3& p) {
  const Dims& d = v.dims();
  const float x = static_cast<float>(p.x), y = static_cast<float>(p.y), z = static_cast<float>(p.z);
  const float fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
  const int64_t i = static_cast<int64_t>(fx), j = static_cast<int64_t>(fy), k = static_cast<int64_t>(fz);
  if (i < 0 || j < 0 || k < 0 || i + 1 >= d.x || j + 1 >= d.y || k + 1 >= d.z) return v.sampleLinear(p);
  const float tx = x - fx, ty = y - fy, tz = z - fz;
  const int64_t sy = d.x, sz = d.x * d.y;
  const float* q = v.data() + (k * d.y + j) * d.x + i;
  const float c00 = q[0] + tx * (q[1] - q[0]), c10 = q[sy] + tx * (q[sy + 1] - q[sy]);
  const float c01 = q[sz] + tx * (q[sz + 1] - q[sz]), c11 = q[sz + sy] + tx * (q[sz + sy + 1] - q[sz + sy]);
  const float c0 = c00 + ty * (c10 - c00), c1 = c01 + ty * (c11 - c01);
  return c0 + tz * (c1 - c0);
}

}  // namespace

DensityVolume::DensityVolume(const AnyVolume& source, const DensityParams& params)
    : params_(params) {
  params::validate(densityParamsTable(), params);
  if (!(params.windowHighHu > params.windowLowHu)) throw Error("density window is empty");
  const Geometry& g = geometryOf(source);
  const double lo = params.windowLowHu, scale = 1.0 / (params.windowHighHu - lo);
  const float floor = static_cast<float>(params.phiMin);
  auto normalise = [&](double v) {
    return std::max(floor, static_cast<float>(std::clamp((v - lo) * scale, 0.0, 1.0)));
  };
  VolumeF32 level0(g, 0.f, normalise(backgroundOf(source)));
  std::visit(
      [&](const auto& vol) {
        const auto* src = vol.data();
        float* dst = level0.data();
        parallelFor(static_cast<int64_t>(vol.size()), [&](int64_t a, int64_t b) {
          for (int64_t t = a; t < b; ++t) dst[t] = normalise(static_cast<double>(src[t]));
        }, 1 << 16);
      },
      source);
  double sum = 0;
  for (float v : level0.voxels()) sum += v;
  globalMean_ = std::max(params.phiMin, sum / static_cast<double>(std::max<size_t>(level0.size(), 1)));
  levels_.push_back(std::move(level0));
  if (params.rays == RayMode::Conic)
    while (levels_.back().dims().x > 2 || levels_.back().dims().y > 2 ||
           levels_.back().dims().z > 2)
      levels_.push_back(downsample(levels_.back(), params.reduction));
  if (params.rays == RayMode::Conic) {
    // Step schedule along any ray, up to the volume's diagonal (+ margin for points outside).
    const Geometry& gg = levels_[0].geometry();
    const double minSp = gg.minSpacing();
    const double maxLen = 4.0 * norm(gg.extent()) + 4 * minSp;
    const int maxLevel = levelCount() - 1;
    for (double s = 0; s < maxLen;) {
      const double h = std::max(minSp, params.coneSlope * s);
      const double mid = s + 0.5 * h;
      const double width = std::max(1.0, params.coneSlope * mid / minSp);
      coneSteps_.push_back({s, h, mid, std::min(maxLevel, static_cast<int>(std::floor(std::log2(width))))});
      s += h;
    }
  }
  const Geometry& g0 = levels_[0].geometry();
  indexToMm_ = g0.direction * Mat3::fromColumns({g0.spacing.x, 0, 0}, {0, g0.spacing.y, 0},
                                                {0, 0, g0.spacing.z});
}

double DensityVolume::rho(const Vec3& aIdx, const Vec3& bIdx) const {
  const Vec3 d = bIdx - aIdx;
  const double lenMm = norm(indexToMm_ * d);
  const Geometry& g = levels_[0].geometry();
  const double minSp = g.minSpacing();
  constexpr double kRhoFloorMm = 1e-3;
  if (!(lenMm > 1e-9)) {
    if (params_.lengthNormalisedRho)  // the limit of integral / (phi * length) at a point
      return std::max(static_cast<double>(levels_[0].sampleLinear(aIdx)) /
                          (params_.phi == PhiRule::Min ? std::max(static_cast<double>(levels_[0].sampleLinear(aIdx)), params_.phiMin)
                           : params_.phi == PhiRule::Mean ? globalMean_ : 1.0), 1e-6);
    return kRhoFloorMm;
  }
  double integral = 0, minI = 1e30;
  if (params_.rays == RayMode::Linear) {
    const int n = std::max(1, static_cast<int>(std::ceil(lenMm / (params_.linearStepVoxels * minSp))));
    const double dt = 1.0 / n;
    const VolumeF32& l0 = levels_[0];
    for (int s = 0; s < n; ++s) {
      const double v = sampleFast(l0, aIdx + d * ((s + 0.5) * dt));
      integral += v;
      minI = std::min(minI, v);
    }
    integral *= lenMm * dt;
  } else {
    // Cone with its apex at a: step and mip footprint grow with the distance from a. The
    // step schedule depends on the distance only, so it is shared by every ray (coneSteps_);
    // only the last, truncated step is computed here.
    const double invLen = 1.0 / lenMm;
    const Vec3 dn = d * invLen;  // index-space direction per mm
    bool done = false;
    double reached = 0;
    for (const ConeStep& st : coneSteps_) {
      double h = st.h, mid = st.mid;
      int level = st.level;
      const bool last = st.s + st.h >= lenMm;
      if (last) {
        h = lenMm - st.s;
        mid = st.s + 0.5 * h;
        const double width = std::max(1.0, params_.coneSlope * mid / minSp);
        level = std::min(levelCount() - 1, static_cast<int>(std::floor(std::log2(width))));
      }
      const Vec3 fine = aIdx + dn * mid;
      const double f = 1.0 / static_cast<double>(1 << level);
      const Vec3 idx{(fine.x + 0.5) * f - 0.5, (fine.y + 0.5) * f - 0.5, (fine.z + 0.5) * f - 0.5};
      const double v = sampleFast(levels_[static_cast<size_t>(level)], idx);
      integral += v * h;
      minI = std::min(minI, v);
      reached = st.s + h;
      if (last) { done = true; break; }
    }
    // Rays longer than the precomputed schedule (far outside the volume): keep stepping.
    for (double s = reached; !done && s < lenMm;) {
      const double h = std::min(std::max(minSp, params_.coneSlope * s), lenMm - s);
      const double mid = s + 0.5 * h;
      const Vec3 idx = aIdx + dn * mid;
      const double v = sampleFast(levels_.back(), {(idx.x + 0.5) / double(1 << (levelCount() - 1)) - 0.5,
                                                   (idx.y + 0.5) / double(1 << (levelCount() - 1)) - 0.5,
                                                   (idx.z + 0.5) / double(1 << (levelCount() - 1)) - 0.5});
      integral += v * h;
      minI = std::min(minI, v);
      s += h;
    }
  }
  double phi = 1.0;
  switch (params_.phi) {
    case PhiRule::Min: phi = std::max(minI, params_.phiMin); break;
    case PhiRule::Mean: phi = globalMean_; break;
    case PhiRule::None: phi = 1.0; break;
  }
  if (params_.lengthNormalisedRho) return std::max(integral / (phi * lenMm), 1e-6);
  return std::max(integral / phi, kRhoFloorMm);
}

}  // namespace vellum::deformation
