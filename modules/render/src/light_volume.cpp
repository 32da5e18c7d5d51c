// The light volume: shadow sweep and ambient openness (light_volume.hpp).
#include "light_volume.hpp"

#include <algorithm>
#include <cmath>

#include "vellum/core/downsample.hpp"
#include "vellum/core/gaussian_blur.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/core/region.hpp"

namespace vellum::render::detail {
namespace {

constexpr int kCellsPerAxis = 192;  ///< target cells along the largest axis

uint8_t toByte(double v) { return static_cast<uint8_t>(std::lround(std::clamp(v, 0.0, 1.0) * 255.0)); }

/// Index-space step per mm along a physical direction.
Vec3 indexPerMm(const Geometry& g, const Vec3& dir) { return g.physicalToIndex(g.origin + dir) - g.physicalToIndex(g.origin); }

/// Value voxels per light cell along each axis: cells a multiple of the value grid's factor,
/// about kCellsPerAxis along the source's largest axis.
int64_t valuesPerCell(const LightSource& src) {
  const Dims sd = src.source.dims;
  const int64_t largest = std::max({sd.x, sd.y, sd.z});
  const int64_t perCell = int64_t(src.factor) * kCellsPerAxis;
  return std::max<int64_t>(1, (largest + perCell - 1) / perCell);
}

}  // namespace

Vec3 keyLightDirection(const Frame& f, const Lighting& l) {
  const double az = l.azimuthDeg * M_PI / 180, el = l.elevationDeg * M_PI / 180;
  const Vec3 towardsEye = f.forward * -1.0;
  const Vec3 d = (towardsEye * std::cos(az) + f.right * std::sin(az)) * std::cos(el) + f.up * std::sin(el);
  return d * (1.0 / norm(d));
}

Vec3 LightVolume::cellOf(const Vec3& p) const {
  const double s = 1.0 / factor;
  return {(p.x + 0.5) * (boxToSource.x * s) - 0.5, (p.y + 0.5) * (boxToSource.y * s) - 0.5,
          (p.z + 0.5) * (boxToSource.z * s) - 0.5};
}

std::array<float, 2> LightVolume::sample(const Vec3& u) const {
  return sampleClamped<2>(rg, dims, cellOf(u), 1.0 / 255.0);
}

namespace {
/// The light source of `volume` (on `g`): block means (core's downsampleMean, in the volume's
/// type: only the values are used, by index), 2^3 blocks above kCellsPerAxis cells on an axis.
template <class V>
LightSource lightSourceOf(const V& volume, const Geometry& g) {
  LightSource out;
  out.source = g;
  const Dims d = g.dims;
  out.factor = std::max({d.x, d.y, d.z}) > kCellsPerAxis ? 2 : 1;
  out.values = downsampleMean(volume, out.factor);
  return out;
}
}  // namespace

LightSource makeLightSource(const AnyVolume& volume) { return lightSourceOf(volume, geometryOf(volume)); }

// core/downsample.hpp's overload: the CT the caller holds, without a copy into an AnyVolume.
LightSource makeLightSource(const VolumeI16& volume) { return lightSourceOf(volume, volume.geometry()); }

LightSource deformedLightSource(const LightSource& src, const PreparedMap& map, const BackwardMap& m) {
  const Geometry& box = m.grid;
  // One value per cell of the undeformed light volume's size (computeLightVolume's cells; the
  // geometric mean: the output axes need not be the source's): the same shadow resolution at an
  // eighth of the map lookups of the value grid's spacing above 384 voxels (rebuilt per map).
  const int64_t perValue = valuesPerCell(src);
  const Vec3 cellMm = src.source.spacing * double(perValue * src.factor);
  double mm = std::cbrt(cellMm.x * cellMm.y * cellMm.z);
  const Vec3 extent{box.spacing.x * double(box.dims.x), box.spacing.y * double(box.dims.y),
                    box.spacing.z * double(box.dims.z)};
  mm = std::max(mm, std::max({extent.x, extent.y, extent.z}) / kDeformedValuesPerAxis);
  LightSource out;
  out.factor = 1;
  out.source = box;
  Dims& n = out.source.dims;
  n = {std::max<int64_t>(1, int64_t(std::ceil(extent.x / mm - 1e-6))),
       std::max<int64_t>(1, int64_t(std::ceil(extent.y / mm - 1e-6))),
       std::max<int64_t>(1, int64_t(std::ceil(extent.z / mm - 1e-6)))};
  // The same voxel box as the map's: w = (p + 0.5) * r - 0.5 with r = n / nodes per axis.
  const Vec3 r{double(n.x) / double(box.dims.x), double(n.y) / double(box.dims.y), double(n.z) / double(box.dims.z)};
  out.boxToSource = r;
  out.source.spacing = {box.spacing.x / r.x, box.spacing.y / r.y, box.spacing.z / r.z};
  out.source.origin = box.indexToPhysical({0.5 / r.x - 0.5, 0.5 / r.y - 0.5, 0.5 / r.z - 0.5});
  const double bg = std::visit([](const auto& v) { return v.background(); }, src.values);
  VolumeF32 values(out.source, 0.f, bg);
  const bool density = !m.attributes.empty();
  if (density) out.densityScale.assign(static_cast<size_t>(n.voxelCount()), 1.f);
  const double f = src.factor;
  std::visit([&](const auto& srcValues) {
  parallelFor(n.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < n.y; ++j)
        for (int64_t i = 0; i < n.x; ++i) {
          const Vec3 p{(double(i) + 0.5) / r.x - 0.5, (double(j) + 0.5) / r.y - 0.5, (double(k) + 0.5) / r.z - 0.5};
          const double inside = map.outputWeight(p);
          double v = bg;
          if (inside > 0) {
            const Vec3 u = map.at(p);  // source index -> the value grid's index
            v = srcValues.sampleLinear({(u.x + 0.5) / f - 0.5, (u.y + 0.5) / f - 0.5, (u.z + 0.5) / f - 0.5});
            if (inside < 1.0) v = bg + inside * (v - bg);
          }
          values(i, j, k) = float(v);
          if (density)
            out.densityScale[static_cast<size_t>((k * n.y + j) * n.x + i)] =
                std::max(sampleClamped<4>(m.attributes, box.dims, p)[3], 0.f);
        }
  });
  }, src.values);
  out.values = std::move(values);
  return out;
}

LightSource lightSourceFor(const AnyVolume& volume, const BackwardMap* map, const PreparedMap& prepared) {
  LightSource source = makeLightSource(volume);
  return map ? deformedLightSource(source, prepared, *map) : source;
}

LightVolume computeLightVolume(const LightSource& src, const TfTable& tf, double stepMm, const Vec3& lightDir,
                               const Lighting& lighting, double lightSizeDeg) {
  const Dims sd = src.source.dims;
  const int64_t perValue = valuesPerCell(src);
  LightVolume lv;
  lv.boxToSource = src.boxToSource;
  lv.factor = int(perValue) * src.factor;
  const int f = lv.factor;
  const int64_t fv = perValue;  // value voxels per cell
  const Dims vd = geometryOf(src.values).dims;
  lv.dims = {(sd.x + f - 1) / f, (sd.y + f - 1) / f, (sd.z + f - 1) / f};
  const Dims d = lv.dims;
  const size_t cells = static_cast<size_t>(d.x * d.y * d.z);
  const Vec3 cellMm = src.source.spacing * double(f);

  // Extinction per mm, averaged over each cell's value voxels.
  std::vector<float> sigma(cells, 0.f);
  std::visit([&](const auto& values) {
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) {
          double sum = 0;
          int count = 0;
          for (int64_t c = k * fv; c < std::min(vd.z, (k + 1) * fv); ++c)
            for (int64_t b = j * fv; b < std::min(vd.y, (j + 1) * fv); ++b)
              for (int64_t a = i * fv; a < std::min(vd.x, (i + 1) * fv); ++a, ++count) {
                const double alpha = std::min<double>(tf.lookup(values(a, b, c))[3], 0.9999);
                double s = -std::log1p(-alpha) / stepMm;
                if (!src.densityScale.empty()) s *= src.densityScale[static_cast<size_t>((c * vd.y + b) * vd.x + a)];
                sum += s;
              }
          sigma[static_cast<size_t>((k * d.y + j) * d.x + i)] = count ? float(sum / count) : 0.f;
        }
  });
  }, src.values);

  // Shadow: slices across the axis the light runs most along, from the light's side inwards.
  Geometry cellGrid = src.source;
  cellGrid.dims = d;
  cellGrid.spacing = cellMm;
  const Vec3 di = indexPerMm(cellGrid, lightDir);  // cells per mm towards the light
  const double comp[3] = {di.x, di.y, di.z};
  int a = 0;
  for (int t = 1; t < 3; ++t)
    if (std::abs(comp[t]) > std::abs(comp[a])) a = t;
  const int b = (a + 1) % 3, c = (a + 2) % 3;
  const double along = std::abs(comp[a]);
  const double ds = 1.0 / along;                                  // mm of light path per slice
  const double shiftB = comp[b] / along, shiftC = comp[c] / along;  // cells per slice towards the light
  const int sign = comp[a] > 0 ? 1 : -1;
  const int64_t n[3] = {d.x, d.y, d.z};
  const int64_t stride[3] = {1, d.x, d.x * d.y};
  std::vector<float> trans(cells, 1.f);
  auto at = [&](int64_t s, int64_t p, int64_t q) { return s * stride[a] + p * stride[b] + q * stride[c]; };
  const int64_t first = sign > 0 ? n[a] - 1 : 0;
  // A soft (disc) light: each slice takes the mean of five points of the previous one, the four
  // outer ones `spread` cells off. Repeated, that is a diffusion (widening as the square root of
  // the distance, where a disc's penumbra widens linearly); the spread is chosen so that the
  // penumbra matches the disc's kSoftMatchCells cells behind the occluder.
  constexpr double kSoftMatchCells = 16;
  const double cellAcross = std::sqrt(cellMm[b] * cellMm[c]);
  const double spread = lightSizeDeg > 0 ? std::tan(lightSizeDeg * M_PI / 180) * ds / cellAcross *
                                               std::sqrt(2.5 * kSoftMatchCells)
                                         : 0.0;
  const int taps = spread > 0 ? 5 : 1;
  const double tapB[5] = {0, spread, -spread, 0, 0}, tapC[5] = {0, 0, 0, spread, -spread};
  for (int64_t step = 1; step < n[a]; ++step) {
    const int64_t s = first - sign * step, prev = s + sign;
    parallelFor(n[c], [&](int64_t q0, int64_t q1) {
      for (int64_t q = q0; q < q1; ++q)
        for (int64_t p = 0; p < n[b]; ++p) {
          // Bilinear in the previous slice at the point one slice towards the light (with a
          // soft light: the mean of that point and four around it); outside the box the light
          // arrives unattenuated through air.
          double tPrev = 0, sPrev = 0;
          for (int tap = 0; tap < taps; ++tap) {
            const double pb = double(p) + shiftB + tapB[tap], pc = double(q) + shiftC + tapC[tap];
            const int64_t b0 = int64_t(std::floor(pb)), c0 = int64_t(std::floor(pc));
            const double tb = pb - double(b0), tc = pc - double(c0);
            for (int corner = 0; corner < 4; ++corner) {
              const int64_t bb = b0 + (corner & 1), cc = c0 + (corner >> 1);
              const double w = ((corner & 1) ? tb : 1 - tb) * ((corner >> 1) ? tc : 1 - tc) / taps;
              if (bb < 0 || cc < 0 || bb >= n[b] || cc >= n[c]) {
                tPrev += w;
                continue;
              }
              const size_t idx = static_cast<size_t>(at(prev, bb, cc));
              tPrev += w * trans[idx];
              sPrev += w * sigma[idx];
            }
          }
          const size_t here = static_cast<size_t>(at(s, p, q));
          trans[here] = float(tPrev * std::exp(-0.5 * (sigma[here] + sPrev) * ds));
        }
    });
  }

  // Openness: the local mean of each cell's opacity over its own length (core's blur), air outside.
  VolumeF32 occ(cellGrid, 0.f, 0.0);
  const double cellLen = std::cbrt(cellMm.x * cellMm.y * cellMm.z);
  for (size_t i = 0; i < cells; ++i) occ.data()[i] = float(1.0 - std::exp(-double(sigma[i]) * cellLen));
  gaussianBlurMm(occ, 0.5 * lighting.occlusionRadiusMm, 0.f);

  lv.rg.resize(2 * cells);
  for (size_t i = 0; i < cells; ++i) {
    lv.rg[2 * i] = toByte(trans[i]);
    lv.rg[2 * i + 1] = toByte(2.0 * (1.0 - occ.data()[i]));
  }
  // One cell towards the light, in source voxels.
  const Vec3 srcPerMm = indexPerMm(src.source, lightDir);
  const double srcAlong = std::max({std::abs(srcPerMm.x), std::abs(srcPerMm.y), std::abs(srcPerMm.z)});
  lv.towardsLight = srcPerMm * (double(f) / srcAlong);
  // In box index units (the source's own under no deformation: boxToSource = 1).
  lv.towardsLight = {lv.towardsLight.x / src.boxToSource.x, lv.towardsLight.y / src.boxToSource.y,
                     lv.towardsLight.z / src.boxToSource.z};
  return lv;
}

}  // namespace vellum::render::detail
