// Shared pieces of the illustration renderer: style packing, gradient volumes, block
// visibility, texture volumes, and the per-sample model (the CPU reference of the shader's).
#include "illustration_renderer_common.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

#include "solid_texture.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/render/render_settings.hpp"

namespace vellum::illustration::detail {

uint16_t floatToHalf(float f) {
  const uint32_t x = std::bit_cast<uint32_t>(f);
  const uint32_t sign = (x >> 16) & 0x8000u;
  const uint32_t absx = x & 0x7fffffffu;
  if (absx >= 0x7f800000u) return uint16_t(sign | 0x7c00u | (absx > 0x7f800000u ? 0x200u : 0u));
  if (absx >= 0x477ff000u) return uint16_t(sign | 0x7c00u);  // overflow -> inf
  if (absx < 0x38800000u) {                                   // subnormal half
    const float a = std::bit_cast<float>(absx);
    return uint16_t(sign | uint32_t(std::nearbyint(a * 16777216.f)));  // 2^24
  }
  uint32_t mant = absx & 0x7fffffu;
  uint32_t exp = (absx >> 23) - 127 + 15;
  uint32_t h = (exp << 10) | (mant >> 13);
  const uint32_t rest = mant & 0x1fffu;
  if (rest > 0x1000u || (rest == 0x1000u && (h & 1u))) ++h;  // round to nearest even
  return uint16_t(sign | h);
}

float halfToFloat(uint16_t h) {
  const uint32_t sign = uint32_t(h & 0x8000u) << 16;
  const uint32_t exp = (h >> 10) & 0x1fu, mant = h & 0x3ffu;
  if (exp == 0) {
    const float v = float(mant) * (1.f / 16777216.f);
    return sign ? -v : v;
  }
  if (exp == 31) return std::bit_cast<float>(sign | 0x7f800000u | (mant << 13));
  return std::bit_cast<float>(sign | ((exp - 15 + 127) << 23) | (mant << 13));
}

std::array<float, 4> Volume4::sampleLinear(float x, float y, float z) const {
  auto axis = [](float v, int64_t n, int64_t& i0, int64_t& i1, float& t) {
    v = std::clamp(v, 0.f, float(n - 1));
    const float f = std::floor(v);
    i0 = std::min<int64_t>(int64_t(f), n - 1);
    i1 = std::min<int64_t>(i0 + 1, n - 1);
    t = v - f;
  };
  int64_t x0, x1, y0, y1, z0, z1;
  float tx, ty, tz;
  axis(x, dims.x, x0, x1, tx);
  axis(y, dims.y, y0, y1, ty);
  axis(z, dims.z, z0, z1, tz);
  std::array<float, 4> out{};
  for (int c = 0; c < 8; ++c) {
    const float w = ((c & 1) ? tx : 1 - tx) * ((c & 2) ? ty : 1 - ty) * ((c & 4) ? tz : 1 - tz);
    const float* v = at((c & 1) ? x1 : x0, (c & 2) ? y1 : y0, (c & 4) ? z1 : z0);
    for (int ch = 0; ch < 4; ++ch) out[ch] += w * v[ch];
  }
  return out;
}

namespace {

/// GLSL's smoothstep, so the CPU reference matches the shader.
float smoothstep(float e0, float e1, float x) {
  const float t = std::clamp((x - e0) / (e1 - e0), 0.f, 1.f);
  return t * t * (3.f - 2.f * t);
}

/// Index-space gradient -> physical: D * (g / spacing).
Vec3 toPhysical(const Geometry& g, const Vec3& idxGrad) {
  return g.direction * div(idxGrad, g.spacing);
}

void storeVoxel(Volume4& v, size_t idx, const Vec3& grad, double w) {
  const float vals[4] = {float(grad.x), float(grad.y), float(grad.z), float(w)};
  for (int c = 0; c < 4; ++c) {
    v.half[idx * 4 + c] = floatToHalf(vals[c]);
    v.value[idx * 4 + c] = halfToFloat(v.half[idx * 4 + c]);
  }
}

Volume4 allocate(const Dims& d) {
  Volume4 v;
  v.dims = d;
  v.half.resize(size_t(d.voxelCount()) * 4);
  v.value.resize(size_t(d.voxelCount()) * 4);
  return v;
}

}  // namespace

Volume4 computeDistanceGradient(const VolumeF32& dist, const VolumeU16& labels) {
  const Dims d = dist.dims();
  Volume4 out = allocate(d);
  const Geometry& g = dist.geometry();
  // Pass 1: label-aware differences (index space). Pass 2 averages them over the voxel's
  // same-label 3x3x3 neighbourhood: the one-sided differences along staircased interfaces
  // are noisy, and silhouette terms magnify normal noise into scratches.
  std::vector<float> raw(size_t(d.voxelCount()) * 3);
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) {
          const uint16_t l = labels(i, j, k);
          const float c = dist(i, j, k);
          const int64_t p[3] = {i, j, k};
          Vec3 grad;
          for (int a = 0; a < 3; ++a) {
            int64_t lo[3] = {i, j, k}, hi[3] = {i, j, k};
            lo[a] = p[a] - 1;
            hi[a] = p[a] + 1;
            const bool okLo = lo[a] >= 0 && labels(lo[0], lo[1], lo[2]) == l;
            const bool okHi = hi[a] < d[a] && labels(hi[0], hi[1], hi[2]) == l;
            double v = 0;
            if (okLo && okHi) v = 0.5 * (dist(hi[0], hi[1], hi[2]) - dist(lo[0], lo[1], lo[2]));
            else if (okHi) v = dist(hi[0], hi[1], hi[2]) - c;
            else if (okLo) v = c - dist(lo[0], lo[1], lo[2]);
            else if (lo[a] >= 0 && hi[a] < d[a])  // thin: both neighbours differ
              v = 0.5 * (dist(hi[0], hi[1], hi[2]) - dist(lo[0], lo[1], lo[2]));
            (a == 0 ? grad.x : a == 1 ? grad.y : grad.z) = v;
          }
          const size_t idx = dist.linearIndex(i, j, k);
          raw[idx * 3] = float(grad.x);
          raw[idx * 3 + 1] = float(grad.y);
          raw[idx * 3 + 2] = float(grad.z);
        }
  });
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) {
          const uint16_t l = labels(i, j, k);
          Vec3 sum;
          for (int64_t c = std::max<int64_t>(k - 1, 0); c <= std::min(k + 1, d.z - 1); ++c)
            for (int64_t b = std::max<int64_t>(j - 1, 0); b <= std::min(j + 1, d.y - 1); ++b)
              for (int64_t a = std::max<int64_t>(i - 1, 0); a <= std::min(i + 1, d.x - 1); ++a) {
                if (labels(a, b, c) != l) continue;
                const float* r = raw.data() + dist.linearIndex(a, b, c) * 3;
                // Centre-weighted (2 at the voxel itself) so thin parts keep their own normal.
                const double w = (a == i && b == j && c == k) ? 2.0 : 1.0;
                sum = sum + Vec3{r[0], r[1], r[2]} * w;
              }
          const size_t idx = dist.linearIndex(i, j, k);
          const double rawLen = std::sqrt(double(raw[idx * 3]) * raw[idx * 3] + double(raw[idx * 3 + 1]) * raw[idx * 3 + 1] +
                                          double(raw[idx * 3 + 2]) * raw[idx * 3 + 2]);
          const double len = norm(sum);
          // Direction from the average, magnitude from the voxel (|grad d| ~ 1 for a distance).
          const Vec3 grad = len > 1e-12 ? sum * (rawLen / len) : Vec3{};
          storeVoxel(out, idx, toPhysical(g, grad), dist(i, j, k));
        }
  });
  return out;
}

Volume4 computeCtGradient(const AnyVolume& ctAny) {
  const VolumeF32 ct = toFloat32(ctAny);
  const Dims d = ct.dims();
  Volume4 out = allocate(d);
  const Geometry& g = ct.geometry();
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) {
          const Vec3 grad{0.5 * (ct.valueOr(i + 1, j, k) - ct.valueOr(i - 1, j, k)),
                          0.5 * (ct.valueOr(i, j + 1, k) - ct.valueOr(i, j - 1, k)),
                          0.5 * (ct.valueOr(i, j, k + 1) - ct.valueOr(i, j, k - 1))};
          storeVoxel(out, ct.linearIndex(i, j, k), toPhysical(g, grad), ct(i, j, k));
        }
  });
  return out;
}

BlockLabels computeBlockLabels(const VolumeU16& labels, const VolumeF32& distance) {
  const Dims d = labels.dims();
  BlockLabels b;
  b.blocks = {(d.x + kBlock - 1) / kBlock, (d.y + kBlock - 1) / kBlock, (d.z + kBlock - 1) / kBlock};
  b.masks.assign(size_t(b.blocks.voxelCount()), {0, 0, 0, 0});
  b.minAbsDistance.assign(size_t(b.blocks.voxelCount()), std::numeric_limits<float>::infinity());
  parallelFor(b.blocks.z, [&](int64_t bz0, int64_t bz1) {
    for (int64_t bz = bz0; bz < bz1; ++bz)
      for (int64_t by = 0; by < b.blocks.y; ++by)
        for (int64_t bx = 0; bx < b.blocks.x; ++bx) {
          const size_t bi = size_t((bz * b.blocks.y + by) * b.blocks.x + bx);
          auto& m = b.masks[bi];
          float& minD = b.minAbsDistance[bi];
          // The block dilated by one voxel: a sample in it can see those voxels.
          for (int64_t k = std::max<int64_t>(bz * kBlock - 1, 0); k < std::min(bz * kBlock + kBlock + 1, d.z); ++k)
            for (int64_t j = std::max<int64_t>(by * kBlock - 1, 0); j < std::min(by * kBlock + kBlock + 1, d.y); ++j)
              for (int64_t i = std::max<int64_t>(bx * kBlock - 1, 0); i < std::min(bx * kBlock + kBlock + 1, d.x); ++i) {
                const int l = std::min<int>(labels(i, j, k), kMaxLabels - 1);
                m[size_t(l >> 6)] |= uint64_t(1) << (l & 63);
                minD = std::min(minD, std::abs(distance(i, j, k)));
              }
        }
  });
  return b;
}

void computeBlockCtRange(BlockLabels& b, const AnyVolume& ctAny) {
  const VolumeF32 ct = toFloat32(ctAny);
  const Dims d = ct.dims();
  b.ctMin.assign(b.masks.size(), std::numeric_limits<float>::infinity());
  b.ctMax.assign(b.masks.size(), -std::numeric_limits<float>::infinity());
  parallelFor(b.blocks.z, [&](int64_t bz0, int64_t bz1) {
    for (int64_t bz = bz0; bz < bz1; ++bz)
      for (int64_t by = 0; by < b.blocks.y; ++by)
        for (int64_t bx = 0; bx < b.blocks.x; ++bx) {
          const size_t bi = size_t((bz * b.blocks.y + by) * b.blocks.x + bx);
          float lo = b.ctMin[bi], hi = b.ctMax[bi];
          for (int64_t k = std::max<int64_t>(bz * kBlock - 1, 0); k < std::min(bz * kBlock + kBlock + 1, d.z); ++k)
            for (int64_t j = std::max<int64_t>(by * kBlock - 1, 0); j < std::min(by * kBlock + kBlock + 1, d.y); ++j)
              for (int64_t i = std::max<int64_t>(bx * kBlock - 1, 0); i < std::min(bx * kBlock + kBlock + 1, d.x); ++i) {
                lo = std::min(lo, ct(i, j, k));
                hi = std::max(hi, ct(i, j, k));
              }
          b.ctMin[bi] = lo;
          b.ctMax[bi] = hi;
        }
  });
}

std::vector<uint8_t> blockOccupancy(const BlockLabels& b, const StyleTable& t) {
  std::array<uint64_t, 4> vis{0, 0, 0, 0}, band{0, 0, 0, 0}, ctOnly{0, 0, 0, 0};
  std::array<float, kMaxLabels> bandWidth{};
  const bool haveCtRange = !b.ctMin.empty();
  for (int l = 0; l < kMaxLabels; ++l) {
    if (!t.visible[size_t(l)]) continue;
    const StyleRow r = t.row(l);
    const bool ctAlpha = r[slot::LambdaIllum] > 0.f && r[slot::Illum] == IllumMode::Ct;
    // Boundary-only rows: k_c = 0 on the distance measure, and no CT-alpha term.
    const bool bandOnly =
        r[slot::BoundaryMeasure] == BoundaryMeasure::Distance && r[slot::BoundaryKc] <= 0.f && !ctAlpha;
    const bool onlyCt = haveCtRange && ctAlpha && r[slot::LambdaColouring] <= 0.f && r[slot::LambdaTexture] <= 0.f;
    auto& set = onlyCt ? ctOnly : bandOnly ? band : vis;
    set[size_t(l >> 6)] |= uint64_t(1) << (l & 63);
    bandWidth[size_t(l)] = r[slot::BoundaryWidthMm];
  }
  // Prefix count of TF entries with opacity: "any opacity in [i0, i1]" in O(1).
  std::vector<int> opaque(kTfSize + 1, 0);
  for (int i = 0; i < kTfSize; ++i) opaque[size_t(i + 1)] = opaque[size_t(i)] + (t.tf[size_t(4 * i + 3)] > 0.f ? 1 : 0);
  auto tfIndex = [&](float v) {
    return std::clamp((v - t.tfLo) / (t.tfHi - t.tfLo), 0.f, 1.f) * float(kTfSize - 1);
  };
  std::vector<uint8_t> occ(b.masks.size());
  for (size_t i = 0; i < occ.size(); ++i) {
    const auto& m = b.masks[i];
    bool on = (m[0] & vis[0]) | (m[1] & vis[1]) | (m[2] & vis[2]) | (m[3] & vis[3]);
    for (int w = 0; w < 4 && !on; ++w)
      for (uint64_t bits = m[size_t(w)] & band[size_t(w)]; bits && !on; bits &= bits - 1)
        on = b.minAbsDistance[i] < bandWidth[size_t(w * 64 + std::countr_zero(bits))];
    if (!on && ((m[0] & ctOnly[0]) | (m[1] & ctOnly[1]) | (m[2] & ctOnly[2]) | (m[3] & ctOnly[3]))) {
      // Samples interpolate between TF entries: cover the neighbours of the range's ends.
      const int i0 = std::max(int(std::floor(tfIndex(b.ctMin[i]))) - 1, 0);
      const int i1 = std::min(int(std::ceil(tfIndex(b.ctMax[i]))) + 1, kTfSize - 1);
      on = opaque[size_t(i1 + 1)] - opaque[size_t(i0)] > 0;
    }
    occ[i] = on ? 255 : 0;
  }
  return occ;
}

TextureVolume loadTextureVolume(const std::string& path) {
  const VolumeF32 v = toFloat32(io::loadVolume(path).volume);
  const auto [lo, hi] = v.valueRange();
  TextureVolume t;
  t.dims = v.dims();
  t.value.resize(v.size());
  const float span = hi > lo ? float(hi - lo) : 1.f;
  for (size_t i = 0; i < v.size(); ++i) t.value[i] = (v.voxels()[i] - float(lo)) / span;
  return t;
}

float TextureVolume::sampleRepeat(float x, float y, float z) const {
  auto wrap = [](int64_t i, int64_t n) { return ((i % n) + n) % n; };
  const float fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
  const int64_t ix = int64_t(fx), iy = int64_t(fy), iz = int64_t(fz);
  const float tx = x - fx, ty = y - fy, tz = z - fz;
  float out = 0;
  for (int c = 0; c < 8; ++c) {
    const float w = ((c & 1) ? tx : 1 - tx) * ((c & 2) ? ty : 1 - ty) * ((c & 4) ? tz : 1 - tz);
    const int64_t i = wrap(ix + (c & 1), dims.x), j = wrap(iy + ((c >> 1) & 1), dims.y),
                  k = wrap(iz + ((c >> 2) & 1), dims.z);
    out += w * value[size_t((k * dims.y + j) * dims.x + i)];
  }
  return out;
}

namespace {

/// One segment's row; depths in mm become fractions of the bounding sphere's diameter.
void packRow(const SegmentStyle& r, bool visible, double diameter, float* p) {
  put(p, slot::Colour, r.colour);
  put(p, slot::Opacity, r.opacity);
  put(p, slot::LambdaIllum, r.lambdaIllum);
  put(p, slot::LambdaColouring, r.lambdaColouring);
  put(p, slot::LambdaTexture, r.lambdaTexture);
  put(p, slot::Visible, visible);
  put(p, slot::ToneWarm, r.warm);
  put(p, slot::ToneBeta, r.toneBeta);
  put(p, slot::ToneCool, r.cool);
  put(p, slot::ToneAlpha, r.toneAlpha);
  put(p, slot::DepthColour, r.dimColour);
  put(p, slot::DepthStrength, r.dimStrength);
  const bool mm = r.dimUnits == DepthUnits::Mm;
  put(p, slot::DepthStart, mm ? float(r.dimStart / diameter) : r.dimStart);
  put(p, slot::DepthEnd, mm ? float(r.dimEnd / diameter) : r.dimEnd);
  put(p, slot::ToneAmount, r.toneAmount);
  put(p, slot::Texture, r.texture);
  put(p, slot::TextureColour1, r.textureColour1);
  put(p, slot::TextureScaleMm, r.textureScaleMm);
  put(p, slot::TextureColour2, r.textureColour2);
  put(p, slot::BoundaryMeasure, r.boundaryMeasure);
  put(p, slot::BoundaryKc, r.boundaryKc);
  put(p, slot::BoundaryKs, r.boundaryKs);
  put(p, slot::BoundaryKe, r.boundaryKe);
  put(p, slot::BoundaryWidthMm, r.boundaryWidthMm);
  put(p, slot::SilhouetteKc, r.silhouetteKc);
  put(p, slot::SilhouetteKs, r.silhouetteKs);
  put(p, slot::SilhouetteKe, r.silhouetteKe);
  put(p, slot::CtGradientScale, r.ctGradientScale);
  put(p, slot::Ambient, r.ambient);
  put(p, slot::Diffuse, r.diffuse);
  put(p, slot::Specular, r.specular);
  put(p, slot::Shininess, r.shininess);
  put(p, slot::Illum, r.illum);
}

}  // namespace

StyleTable packStyle(const Style& style, const std::vector<Label>& table, int maxId, const Geometry& g) {
  if (maxId >= kMaxLabels)
    throw Error("illustrate: segment ids must be <= 255 (found " + std::to_string(maxId) + ")");
  const std::vector<SegmentStyle> rows = resolveRows(style, table, kMaxLabels - 1);
  // Depths in mm become fractions of the bounding sphere's diameter (what the shader uses).
  const Dims& d = g.dims;
  const Vec3 centre = g.indexToPhysical({(d.x - 1) * 0.5, (d.y - 1) * 0.5, (d.z - 1) * 0.5});
  double radius = 0;
  for (int c = 0; c < 8; ++c) {
    const Vec3 corner{(c & 1) ? d.x - 0.5 : -0.5, (c & 2) ? d.y - 0.5 : -0.5, (c & 4) ? d.z - 0.5 : -0.5};
    radius = std::max(radius, norm(g.indexToPhysical(corner) - centre));
  }
  const double diameter = std::max(2 * radius, 1e-6);
  StyleTable t;
  t.rows = kMaxLabels;
  t.texels.assign(size_t(t.rows) * kRowTexels * 4, 0.f);
  for (int l = 0; l < t.rows; ++l) {
    const SegmentStyle& r = rows[size_t(l)];
    const bool vis = r.visible && (r.lambdaIllum + r.lambdaColouring + r.lambdaTexture) > 0 &&
                     (r.opacity > 0 || (r.illum == IllumMode::Ct && r.lambdaIllum > 0));
    packRow(r, vis, diameter, t.texels.data() + size_t(l) * kRowTexels * 4);
    t.visible[size_t(l)] = vis;
    if (!vis || l > maxId) continue;  // features of rows no voxel uses do not matter
    if ((r.illum == IllumMode::Ct && r.lambdaIllum > 0) || r.boundaryMeasure == BoundaryMeasure::Ct)
      t.usesCt = true;
    if (r.lambdaTexture > 0 && r.texture != SolidTexture::None) {
      if (r.texture == SolidTexture::Volume) t.usesTextureVolume = true;
      else t.usesTexture = true;
    }
  }
  const double ln = std::sqrt(double(style.light[0]) * style.light[0] + double(style.light[1]) * style.light[1] +
                              double(style.light[2]) * style.light[2]);
  t.light = {float(style.light[0] / ln), float(style.light[1] / ln), float(style.light[2] / ln)};
  // CT transfer function (colour, alpha per mm) from the render module's presets.
  const render::TransferFunction tf = render::TransferFunction::forPreset(render::parsePreset(style.ctPreset));
  t.tfLo = float(tf.points.front().value);
  t.tfHi = float(tf.points.back().value);
  if (!(t.tfHi > t.tfLo)) t.tfHi = t.tfLo + 1;
  t.tf.resize(4 * kTfSize);
  for (int i = 0; i < kTfSize; ++i) {
    const auto c = tf.evaluate(t.tfLo + (t.tfHi - t.tfLo) * double(i) / (kTfSize - 1));
    for (int k = 0; k < 4; ++k) t.tf[size_t(4 * i + k)] = std::clamp(c[size_t(k)], 0.f, 1.f);
  }
  return t;
}

namespace {

float clamp01(float v) { return std::clamp(v, 0.f, 1.f); }
Vec3f normalizeOrZero(Vec3f v, float& len) {
  len = std::sqrt(dot(v, v));
  return len > 1e-6f ? v * (1.f / len) : Vec3f{};
}

}  // namespace

// CPU reference of styled() in illustration/shaders/illustration_sample.frag.glsl (same terms, same order).
std::array<float, 4> styledSample(const StyleTable& t, int label, const float* g4, const float* ct4,
                                  const TextureVolume* texVol, Vec3f pMm, float depth, Vec3f view,
                                  const SampleFrame& f) {
  const StyleRow r = t.row(label);
  if (!r[slot::Visible]) return {0, 0, 0, 0};
  const float l1 = r[slot::LambdaIllum], l2 = r[slot::LambdaColouring], l3 = r[slot::LambdaTexture];
  const float width = r[slot::BoundaryWidthMm];

  float glen;
  const Vec3f n = normalizeOrZero({g4[0], g4[1], g4[2]}, glen);
  const float d = g4[3];
  // Opacity modulation first (as the shader: m = 0 -> transparent, nothing else computed).
  float b;
  if (r[slot::BoundaryMeasure] == BoundaryMeasure::Ct && ct4)
    b = clamp01(std::sqrt(ct4[0] * ct4[0] + ct4[1] * ct4[1] + ct4[2] * ct4[2]) / r[slot::CtGradientScale]);
  else b = clamp01(1.f - std::abs(d) / width);
  // As the shader: normal-based terms fade to neutral from 2 to 4 boundary widths inside
  // (deeper, the distance gradient only shows the medial axis).
  const float sw = 1.f - smoothstep(2.f * width, 4.f * width, std::abs(d));
  const float ndv = glen > 1e-6f ? 1.f + sw * (std::abs(dot(n, view)) - 1.f) : 1.f;
  float mb = r[slot::BoundaryKc], ms = r[slot::SilhouetteKc];
  if (r[slot::BoundaryKs] > 0.f) mb += r[slot::BoundaryKs] * std::pow(b, r[slot::BoundaryKe]);
  if (r[slot::SilhouetteKs] > 0.f) ms += r[slot::SilhouetteKs] * std::pow(std::max(1.f - ndv, 0.f), r[slot::SilhouetteKe]);
  const float m = mb * ms;
  if (!(m > 0.f)) return {0, 0, 0, 0};
  const Vec3f L = f.light;
  float hl;
  const Vec3f H = normalizeOrZero(L + view, hl);
  const float ndl = sw * dot(n, L);
  const float* col = r[slot::Colour];

  // I_coloring: Gooch tone, then depth dimming.
  const float k = (1.f + ndl) * 0.5f;
  const float *warm = r[slot::ToneWarm], *cool = r[slot::ToneCool];
  float cc[3];
  for (int c = 0; c < 3; ++c) {
    const float tone = clamp01(k * (warm[c] + r[slot::ToneBeta] * col[c]) + (1.f - k) * (cool[c] + r[slot::ToneAlpha] * col[c]));
    cc[c] = col[c] + r[slot::ToneAmount] * (tone - col[c]);
  }
  const float start = r[slot::DepthStart], end = r[slot::DepthEnd];
  const float dimW = r[slot::DepthStrength] * clamp01((depth - start) / std::max(end - start, 1e-4f));
  const float* dimColour = r[slot::DepthColour];
  for (int c = 0; c < 3; ++c) cc[c] = cc[c] + dimW * (dimColour[c] - cc[c]);

  const float ambient = r[slot::Ambient], diffuse = r[slot::Diffuse];
  const float specular = r[slot::Specular], shininess = r[slot::Shininess];
  const float lit = ambient + diffuse * std::max(ndl, 0.f);
  const float coverage = label > 0 ? clamp01(0.5f - d / f.coverageH) : 1.f;
  const float aSeg = r[slot::Opacity] * coverage;

  // I_illum
  float c1[3] = {0, 0, 0}, a1 = 0;
  if (l1 <= 0.f) {
    // I_illum has no weight: not evaluated (as in the shader)
  } else if (r[slot::Illum] == IllumMode::Ct && ct4) {
    const float x = clamp01((ct4[3] - t.tfLo) / (t.tfHi - t.tfLo)) * float(kTfSize - 1);
    const int i = std::min(int(x), kTfSize - 2);
    const float fr = x - float(i);
    float tf[4];
    for (int c = 0; c < 4; ++c) tf[c] = t.tf[size_t(4 * i + c)] + fr * (t.tf[size_t(4 * i + 4 + c)] - t.tf[size_t(4 * i + c)]);
    float cl;
    const Vec3f cn = normalizeOrZero({ct4[0], ct4[1], ct4[2]}, cl);
    const float cdl = std::abs(dot(cn, L));
    const float spec = cl > 1e-6f ? specular * std::pow(std::abs(dot(cn, H)), shininess) : 0.f;
    for (int c = 0; c < 3; ++c) c1[c] = std::min(tf[c] * (ambient + diffuse * cdl) + spec, 1.f);
    a1 = tf[3];
  } else {
    const float spec = glen > 1e-6f ? sw * specular * std::pow(std::max(dot(n, H), 0.f), shininess) : 0.f;
    for (int c = 0; c < 3; ++c) c1[c] = std::min(col[c] * lit + spec, 1.f);
    a1 = aSeg;
  }

  // I_solidtex
  float c3[3] = {0, 0, 0};
  const SolidTexture kind = r[slot::Texture];
  if (l3 > 0.f && kind != SolidTexture::None) {
    const float s = 1.f / r[slot::TextureScaleMm];
    float tv = 0;
    if (kind == SolidTexture::Volume) {
      if (texVol) tv = texVol->sampleRepeat(pMm.x * s - 0.5f, pMm.y * s - 0.5f, pMm.z * s - 0.5f);
    } else {
      tv = solidTextureAt(kind, pMm.x * s, pMm.y * s, pMm.z * s);
    }
    const float *t1 = r[slot::TextureColour1], *t2 = r[slot::TextureColour2];
    for (int c = 0; c < 3; ++c) c3[c] = std::min((t1[c] + tv * (t2[c] - t1[c])) * lit, 1.f);
  }

  float rgb[3];
  for (int c = 0; c < 3; ++c) rgb[c] = l1 * a1 * c1[c] + l2 * aSeg * cc[c] + l3 * aSeg * c3[c];
  const float a = l1 * a1 + l2 * aSeg + l3 * aSeg;
  if (!(a > 0.f)) return {0, 0, 0, 0};

  const float am = std::min(a * m, 1.f);
  const float scale = am / a;
  return {rgb[0] * scale, rgb[1] * scale, rgb[2] * scale, am};
}

}  // namespace vellum::illustration::detail
