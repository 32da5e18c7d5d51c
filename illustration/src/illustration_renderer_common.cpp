// Shared pieces of the illustration renderer: style packing, gradient volumes, block
// visibility, texture volumes, and the per-sample model (the CPU reference of the shader's).
#include "illustration_renderer_common.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

#include "solid_texture.hpp"
#include "vellum/core/box_corners.hpp"
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

namespace {
/// The 8 corners and weights of a trilinear lookup at index coordinates (x, y, z), clamped
/// to the grid as GL_CLAMP_TO_EDGE does; float arithmetic, as the shaders'.
struct Trilinear {
  int64_t x0, x1, y0, y1, z0, z1;
  float tx, ty, tz;
  Trilinear(float x, float y, float z, const Dims& d) {
    axis(x, d.x, x0, x1, tx);
    axis(y, d.y, y0, y1, ty);
    axis(z, d.z, z0, z1, tz);
  }
  static void axis(float v, int64_t n, int64_t& i0, int64_t& i1, float& t) {
    v = std::clamp(v, 0.f, float(n - 1));
    const float f = std::floor(v);
    i0 = std::min<int64_t>(int64_t(f), n - 1);
    i1 = std::min<int64_t>(i0 + 1, n - 1);
    t = v - f;
  }
  float weight(int c) const { return ((c & 1) ? tx : 1 - tx) * ((c & 2) ? ty : 1 - ty) * ((c & 4) ? tz : 1 - tz); }
  int64_t i(int c) const { return (c & 1) ? x1 : x0; }
  int64_t j(int c) const { return (c & 2) ? y1 : y0; }
  int64_t k(int c) const { return (c & 4) ? z1 : z0; }
};
}  // namespace

std::array<float, 4> Volume4::sampleLinear(float x, float y, float z) const {
  const Trilinear t(x, y, z, dims);
  std::array<float, 4> out{};
  for (int c = 0; c < 8; ++c) {
    const float w = t.weight(c);
    const float* v = at(t.i(c), t.j(c), t.k(c));
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

FieldVolume makeFieldVolume(const ShapeScene& scene, bool decode) {
  FieldVolume fv;
  fv.dims = scene.grid().dims;
  for (const auto& f : scene.fields) fv.slots.push_back({int(f.id), int(f.shellId), f.shellMm});
  fv.groups = int((fv.slots.size() + 3) / 4);
  if (!decode) return fv;
  const Dims d = fv.dims;
  const size_t n = size_t(d.voxelCount());
  fv.value.assign(n * 4 * size_t(fv.groups), 0.f);
  for (size_t s = 0; s < fv.slots.size(); ++s) {
    const int16_t* src = scene.fields[s].distance.data();
    float* dst = fv.value.data() + (s / 4) * n * 4 + s % 4;
    parallelFor(int64_t(n), [&](int64_t b, int64_t e) {
      for (int64_t v = b; v < e; ++v) dst[size_t(v) * 4] = decodeField(src[v]);
    }, 1 << 16);
  }
  // Unused channels of the last group: far outside (as the GL upload's padding).
  for (size_t s = fv.slots.size(); s < size_t(fv.groups) * 4; ++s) {
    float* dst = fv.value.data() + (s / 4) * n * 4 + s % 4;
    for (size_t v = 0; v < n; ++v) dst[v * 4] = kFieldScaleMm;
  }
  return fv;
}

void packFieldSlab(const ShapeScene& scene, int group, int64_t z0, int64_t z1, std::vector<int16_t>& out) {
  const Dims d = scene.grid().dims;
  const size_t slice = size_t(d.x * d.y);
  out.resize(slice * size_t(z1 - z0) * 4);
  for (int c = 0; c < 4; ++c) {
    const size_t s = size_t(group) * 4 + size_t(c);
    const int16_t* src = s < scene.fields.size() ? scene.fields[s].distance.data() + slice * size_t(z0) : nullptr;
    parallelFor(int64_t(slice) * (z1 - z0), [&](int64_t b, int64_t e) {
      for (int64_t v = b; v < e; ++v) out[size_t(v) * 4 + size_t(c)] = src ? src[v] : int16_t(32767);
    }, 1 << 16);
  }
}

void paintItems(const StyleTable& t, const std::vector<PaintSlot>& slots, std::vector<int>& items,
                std::vector<int>& inkSlots) {
  items.clear();
  inkSlots.clear();
  const int n = int(slots.size());
  auto shows = [&](int id) { return id >= 0 && id < kMaxLabels && t.row(id)[slot::Visible]; };
  for (int i = 0; i < 2 * n; ++i) {
    const PaintSlot& sl = slots[size_t(n - 1 - i / 2)];
    const bool first = (i & 1) == 0;
    if (!first && sl.shellId <= 0) continue;
    if (shows(first && sl.shellId > 0 ? sl.shellId : sl.id)) items.push_back(i);
  }
  if (shows(0)) items.push_back(2 * n);
  for (int s = 0; s < n; ++s) {
    const int iid = slots[size_t(s)].shellId > 0 ? slots[size_t(s)].shellId : slots[size_t(s)].id;
    if (iid < kMaxLabels && t.row(iid)[slot::Ink]) inkSlots.push_back(s);
  }
}

float creaseInk(const FieldVolume& f, int slot, Vec3f q, Vec3f rightIdx, Vec3f upIdx, const std::array<float, 9>& m,
                float widthPx, float angleDeg, float pixMm, float probeMm) {
  auto normal = [&](Vec3f p) {
    const float gx = 0.5f * (f.at(p.x + 1.f, p.y, p.z, slot) - f.at(p.x - 1.f, p.y, p.z, slot));
    const float gy = 0.5f * (f.at(p.x, p.y + 1.f, p.z, slot) - f.at(p.x, p.y - 1.f, p.z, slot));
    const float gz = 0.5f * (f.at(p.x, p.y, p.z + 1.f, slot) - f.at(p.x, p.y, p.z - 1.f, slot));
    const Vec3f g{m[0] * gx + m[1] * gy + m[2] * gz, m[3] * gx + m[4] * gy + m[5] * gz, m[6] * gx + m[7] * gy + m[8] * gz};
    const float len = std::sqrt(dot(g, g));
    return len > 1e-6f ? g * (1.f / len) : Vec3f{0, 0, 0};
  };
  // The turn is measured across +-R mm (CT rounds an edge over two or three voxels: a probe of
  // a pixel or two saw only part of it); the line is placed where the turn is, within +-h of
  // q (h: half the width plus half a pixel), so its width stays constant in pixels.
  // The inner probes at least a voxel apart (a third of the outer probe, kCreaseProbeVoxels):
  // at a quarter of a millimetre a pixel, +-h samples the trilinear field's kinks and the
  // voxel noise of rough real bone, whose tiny bumps turned "concentrated" and drew knots of ink.
  const float h = std::max((0.5f * widthPx + 0.5f) * pixMm, probeMm * float(1.0 / kCreaseProbeVoxels)),
              R = std::max(h, probeMm);
  constexpr float kRad = 3.14159265358979f / 180.f;
  const float c0 = std::cos(angleDeg * kRad), c1 = std::cos(std::min(angleDeg + 15.f, 180.f) * kRad);
  float ink = 0.f;
  for (int i = 0; i < 4; ++i) {
    const Vec3f a = i == 0 ? rightIdx : i == 1 ? upIdx : i == 2 ? (rightIdx + upIdx) * 0.70710678f : (rightIdx - upIdx) * 0.70710678f;
    ink = std::max(ink, creaseProfile(normal(q - a * R), normal(q - a * h), normal(q + a * h), normal(q + a * R), R, h,
                                      c0, c1, widthPx, pixMm));
  }
  return ink;
}

float creaseProfile(Vec3f nm, Vec3f nh, Vec3f ph, Vec3f np, float R, float h, float c0, float c1, float widthPx,
                    float pixMm) {
  if (!(dot(nm, nm) > 0.5f && dot(np, np) > 0.5f && dot(nh, nh) > 0.5f && dot(ph, ph) > 0.5f)) return 0.f;
  // Strength: the turn between the normals at -R and +R (crease_angle_deg: none, +15: full).
  const float strength = std::clamp((c0 - dot(nm, np)) / std::max(c0 - c1, 1e-6f), 0.f, 1.f);
  if (!(strength > 0.f)) return 0.f;
  // s(x) = n(x).u, u the direction the normal turns to: it rises from s(-R) to s(+R) across
  // the crease, steepest at its centre.
  const Vec3f dn = np - nm;
  const float dl = std::sqrt(dot(dn, dn));
  if (!(dl > 1e-6f)) return 0.f;
  const Vec3f u = dn * (1.f / dl);
  const float sm = dot(nm, u), sp = dot(np, u), sl = dot(nh, u), sr = dot(ph, u);
  const float rate = (sr - sl) / (2.f * h), mean = (sp - sm) / (2.f * R);  // per mm
  if (!(rate > 0.f && mean > 0.f)) return 0.f;
  // A crease concentrates the turn (full ink from twice the mean rate within the line); a
  // rounded part turning evenly gets none, however far it turns in all.
  const float concentrated = std::clamp((rate / mean - 1.25f) / 0.75f, 0.f, 1.f);
  // The centre (s halfway between the sides) between -h and +h, interpolated; a widthPx line
  // around it, antialiased over a pixel as inkLine (none when the centre lies beyond +-h).
  const float x = -h + 2.f * h * (0.5f * (sm + sp) - sl) / (sr - sl);
  const float cover = std::clamp((0.5f * widthPx * pixMm - std::abs(x)) / pixMm + 0.5f, 0.f, 1.f);
  return strength * concentrated * cover;
}

void gradientWindows(const StyleTable& t, const std::vector<PaintSlot>& slots, float coverageH,
                     std::vector<float>& lo, std::vector<float>& hi) {
  const size_t n = (slots.size() + 3) / 4 * 4;
  const float big = 1e30f;
  lo.assign(std::max<size_t>(n, 4), big);
  hi.assign(std::max<size_t>(n, 4), -big);
  for (size_t s = 0; s < slots.size(); ++s) {
    if (t.visible[0]) {
      lo[s] = -big;
      hi[s] = big;
      continue;
    }
    const PaintSlot& sl = slots[s];
    float reach = -1;  // 4 boundary widths of the slot's visible rows (deeper: sw = 0)
    for (int id : {sl.id, sl.shellId})
      if (id > 0 && id < kMaxLabels && t.visible[size_t(id)])
        reach = std::max(reach, t.shows[size_t(id)] ? 4.f * t.row(id)[slot::BoundaryWidthMm] : coverageH);
    if (reach < 0) continue;
    lo[s] = -(reach + (sl.shellId > 0 ? sl.shellMm + coverageH : 0.f));
    hi[s] = 0.5f * coverageH;
  }
}

void skipBands(const StyleTable& t, const std::vector<PaintSlot>& slots, float coverageH, float inkPassMm,
               float marginMm, std::vector<float>& out, std::vector<float>& in) {
  const size_t n = std::max<size_t>((slots.size() + 3) / 4 * 4, 4);
  // Far beyond any distance (the fields hold at most FIELD_SCALE mm), but finite: these are
  // shader uniforms, and GPU compilers may assume no infinities (fast math); the results are
  // the same as with +-infinity.
  const float far = 1e30f;
  // Padding channels hold far-outside distances: never the limit.
  out.assign(n, -far);
  in.assign(n, -far);
  if (t.visible[0]) {
    std::fill(out.begin(), out.begin() + long(slots.size()), far);
    std::fill(in.begin(), in.begin() + long(slots.size()), far);
    return;
  }
  std::vector<float> lo, hi;
  gradientWindows(t, slots, coverageH, lo, hi);
  for (size_t s = 0; s < slots.size(); ++s) {
    const PaintSlot& sl = slots[s];
    // Coverage ramps over |d| < h/2 for every slot (an invisible one still hides those under it).
    float o = 0.5f * coverageH, i = 0.5f * coverageH;
    const int inkId = sl.shellId > 0 ? sl.shellId : sl.id;
    if (inkId < kMaxLabels && t.visible[size_t(inkId)] && t.row(inkId)[slot::Ink]) {
      o = std::max(o, inkPassMm);
      i = std::max(i, inkPassMm);
    }
    if (lo[s] < 0.f) i = std::max(i, -lo[s]);  // normal terms, boundary band and shell fade by then
    for (int id : {sl.id, sl.shellId}) {
      if (id <= 0 || id >= kMaxLabels || !t.shows[size_t(id)]) continue;
      const StyleRow r = t.row(id);
      const bool ct = (r[slot::LambdaIllum] > 0.f && r[slot::Illum] == IllumMode::Ct) ||
                      r[slot::BoundaryMeasure] == BoundaryMeasure::Ct;
      const bool tex = r[slot::LambdaTexture] > 0.f && r[slot::Texture] != SolidTexture::None;
      if (ct || tex) i = far;  // never skipped inside
      else i = std::max(i, r[slot::BoundaryWidthMm] + (sl.shellId > 0 ? sl.shellMm + coverageH : 0.f));
    }
    out[s] = o + marginMm;
    in[s] = i + marginMm;
  }
}

void FieldVolume::sample(float x, float y, float z, bool central, const float* lo, const float* hi, float* d,
                         Vec3f* g) const {
  // As the shader: p clamped to the grid (clamp to edge), trilinear per group texel fetch.
  const size_t n = size_t(dims.voxelCount());
  auto fetch = [&](float px, float py, float pz, int grp) {
    auto axis = [](float v, int64_t m, int64_t& i0, int64_t& i1, float& t) {
      v = std::clamp(v, 0.f, float(m - 1));
      const float f = std::floor(v);
      i0 = std::min<int64_t>(int64_t(f), m - 1);
      i1 = std::min<int64_t>(i0 + 1, m - 1);
      t = v - f;
    };
    int64_t x0, x1, y0, y1, z0, z1;
    float tx, ty, tz;
    axis(px, dims.x, x0, x1, tx);
    axis(py, dims.y, y0, y1, ty);
    axis(pz, dims.z, z0, z1, tz);
    const float* base = value.data() + size_t(grp) * n * 4;
    std::array<float, 4> out{};
    for (int c = 0; c < 8; ++c) {
      const float w = ((c & 1) ? tx : 1 - tx) * ((c & 2) ? ty : 1 - ty) * ((c & 4) ? tz : 1 - tz);
      const float* v = base + size_t((((c & 4) ? z1 : z0) * dims.y + ((c & 2) ? y1 : y0)) * dims.x + ((c & 1) ? x1 : x0)) * 4;
      for (int ch = 0; ch < 4; ++ch) out[size_t(ch)] += w * v[ch];
    }
    return out;
  };
  for (int grp = 0; grp < groups; ++grp) {
    const auto c = fetch(x, y, z, grp);
    std::array<float, 4> gx{}, gy{}, gz{};
    bool need = false;
    for (int ch = 0; ch < 4; ++ch) need = need || (c[size_t(ch)] > lo[grp * 4 + ch] && c[size_t(ch)] < hi[grp * 4 + ch]);
    if (!need) {
    } else if (central) {
      const auto xp = fetch(x + 1, y, z, grp), xm = fetch(x - 1, y, z, grp);
      const auto yp = fetch(x, y + 1, z, grp), ym = fetch(x, y - 1, z, grp);
      const auto zp = fetch(x, y, z + 1, grp), zm = fetch(x, y, z - 1, grp);
      for (int ch = 0; ch < 4; ++ch) {
        gx[size_t(ch)] = 0.5f * (xp[size_t(ch)] - xm[size_t(ch)]);
        gy[size_t(ch)] = 0.5f * (yp[size_t(ch)] - ym[size_t(ch)]);
        gz[size_t(ch)] = 0.5f * (zp[size_t(ch)] - zm[size_t(ch)]);
      }
    } else {
      const auto xp = fetch(x + 1, y, z, grp), yp = fetch(x, y + 1, z, grp), zp = fetch(x, y, z + 1, grp);
      for (int ch = 0; ch < 4; ++ch) {
        gx[size_t(ch)] = xp[size_t(ch)] - c[size_t(ch)];
        gy[size_t(ch)] = yp[size_t(ch)] - c[size_t(ch)];
        gz[size_t(ch)] = zp[size_t(ch)] - c[size_t(ch)];
      }
    }
    for (int ch = 0; ch < 4; ++ch) {
      const size_t s = size_t(grp) * 4 + size_t(ch);
      if (s >= slots.size()) break;
      d[s] = c[size_t(ch)];
      g[s] = {gx[size_t(ch)], gy[size_t(ch)], gz[size_t(ch)]};
    }
  }
}

BlockFields computeBlockFields(const ShapeScene& scene) {
  const Dims d = scene.grid().dims;
  BlockFields b;
  b.blocks = {(d.x + kBlock - 1) / kBlock, (d.y + kBlock - 1) / kBlock, (d.z + kBlock - 1) / kBlock};
  b.slots = int(scene.fields.size());
  const size_t nb = size_t(b.blocks.voxelCount()), ns = size_t(b.slots);
  b.minD.assign(nb * ns, std::numeric_limits<float>::infinity());
  b.maxD.assign(nb * ns, -std::numeric_limits<float>::infinity());
  parallelFor(b.blocks.z, [&](int64_t bz0, int64_t bz1) {
    for (int64_t bz = bz0; bz < bz1; ++bz)
      for (int64_t by = 0; by < b.blocks.y; ++by)
        for (int64_t bx = 0; bx < b.blocks.x; ++bx) {
          const size_t bi = size_t((bz * b.blocks.y + by) * b.blocks.x + bx);
          for (size_t s = 0; s < ns; ++s) {
            const VolumeI16& f = scene.fields[s].distance;
            int lo = 32767, hi = -32767;
            // The block dilated by two voxels: trilinear samples and their +-1 voxel stencil.
            for (int64_t k = std::max<int64_t>(bz * kBlock - 2, 0); k < std::min(bz * kBlock + kBlock + 2, d.z); ++k)
              for (int64_t j = std::max<int64_t>(by * kBlock - 2, 0); j < std::min(by * kBlock + kBlock + 2, d.y); ++j)
                for (int64_t i = std::max<int64_t>(bx * kBlock - 2, 0); i < std::min(bx * kBlock + kBlock + 2, d.x); ++i) {
                  const int v = f(i, j, k);
                  lo = std::min(lo, v);
                  hi = std::max(hi, v);
                }
            b.minD[bi * ns + s] = decodeField(int16_t(lo));
            b.maxD[bi * ns + s] = decodeField(int16_t(hi));
          }
        }
  });
  return b;
}

void computeBlockCtRange(BlockFields& b, const AnyVolume& ctAny) {
  const VolumeF32 ct = toFloat32(ctAny);
  const Dims d = ct.dims();
  const size_t nb = size_t(b.blocks.voxelCount());
  b.ctMin.assign(nb, std::numeric_limits<float>::infinity());
  b.ctMax.assign(nb, -std::numeric_limits<float>::infinity());
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

std::vector<uint8_t> blockOccupancy(const BlockFields& b, const StyleTable& t, const std::vector<PaintSlot>& slots,
                                    float coverageH, float inkReachMm, float inkLineMm) {
  const bool haveCtRange = !b.ctMin.empty();
  // Prefix count of TF entries with opacity: "any opacity in [i0, i1]" in O(1).
  std::vector<int> opaque(kTfSize + 1, 0);
  for (int i = 0; i < kTfSize; ++i) opaque[size_t(i + 1)] = opaque[size_t(i)] + (t.tf[size_t(4 * i + 3)] > 0.f ? 1 : 0);
  auto tfIndex = [&](float v) {
    return std::clamp((v - t.tfLo) / (t.tfHi - t.tfLo), 0.f, 1.f) * float(kTfSize - 1);
  };
  auto tfOpaque = [&](size_t bi) {
    // Samples interpolate between TF entries: cover the neighbours of the range's ends.
    const int i0 = std::max(int(std::floor(tfIndex(b.ctMin[bi]))) - 1, 0);
    const int i1 = std::min(int(std::ceil(tfIndex(b.ctMax[bi]))) + 1, kTfSize - 1);
    return opaque[size_t(i1 + 1)] - opaque[size_t(i0)] > 0;
  };
  // Per row: may it have opacity over a distance range [lo, hi] of its own surface, and over
  // this block's CT range?
  auto rowMay = [&](int id, float lo, float hi, size_t bi) {
    if (id <= 0 || id >= kMaxLabels || !t.shows[size_t(id)]) return false;
    const StyleRow r = t.row(id);
    const bool ctAlpha = r[slot::LambdaIllum] > 0.f && r[slot::Illum] == IllumMode::Ct;
    const bool bandOnly = r[slot::BoundaryMeasure] == BoundaryMeasure::Distance && r[slot::BoundaryKc] <= 0.f && !ctAlpha;
    if (bandOnly) {
      const float w = r[slot::BoundaryWidthMm];
      if (!(lo < w && hi > -w)) return false;
    }
    const bool onlyCt = haveCtRange && ctAlpha && r[slot::LambdaColouring] <= 0.f && r[slot::LambdaTexture] <= 0.f;
    return !onlyCt || tfOpaque(bi);
  };
  const size_t ns = slots.size();
  const float half = 0.5f * coverageH;
  std::vector<uint8_t> occ(size_t(b.blocks.voxelCount()));
  for (size_t bi = 0; bi < occ.size(); ++bi) {
    bool on = false, covered = false;
    for (size_t s = 0; s < ns && !on; ++s) {
      const float lo = b.minD[bi * ns + s], hi = b.maxD[bi * ns + s];
      if (hi < -half) covered = true;
      const PaintSlot& sl = slots[s];
      // Ink: lines and hatching live within inkReachMm of the slot's outer surface (also
      // outside it, where a ray passes close by), whatever the coverage.
      const int inkId = sl.shellId > 0 ? sl.shellId : sl.id;
      // A constant field over the dilated block (the narrow band's clamp) beyond a line's
      // reach has no minimum to ink and no sign change to hatch: no ink there, however wide
      // inkReachMm is (at fine voxels it exceeds the band, and every block would march).
      const bool flat = lo == hi && std::abs(lo) > inkLineMm;
      if (inkId < kMaxLabels && t.visible[size_t(inkId)] && t.row(inkId)[slot::Ink] && lo < inkReachMm &&
          hi > -inkReachMm && !flat) {
        on = true;
        break;
      }
      if (!(lo < half)) continue;  // coverage 0 over the whole block
      if (sl.shellId > 0) {
        // Shell (no band test: its own distance folds at -t/2); core: d + t.
        const float t0 = sl.shellMm, big = std::numeric_limits<float>::max();
        on = rowMay(sl.shellId, -big, big, bi) ||
             (lo < -t0 + half && rowMay(sl.id, lo + t0, hi + t0, bi));
      } else {
        on = rowMay(sl.id, lo, hi, bi);
      }
    }
    if (!on && !covered && t.visible[0]) {
      const StyleRow r = t.row(0);
      const bool onlyCt = haveCtRange && r[slot::LambdaIllum] > 0.f && r[slot::Illum] == IllumMode::Ct &&
                          r[slot::LambdaColouring] <= 0.f && r[slot::LambdaTexture] <= 0.f;
      on = !onlyCt || tfOpaque(bi);
    }
    occ[bi] = on ? 255 : 0;
  }
  markHomogeneousBlocks(b, t, slots, coverageH, occ);
  return occ;
}

std::vector<uint8_t> occupancyTexels(const std::vector<uint8_t>& occ, const Dims& blocks) {
  // Chebyshev (L-inf) distance in blocks to the nearest non-empty block, separable: along x
  // (two sweeps), then y and z as min over j of max(|i - j|, previous), within a window.
  constexpr int cap = kEmptyRunCap;
  const int64_t nx = blocks.x, ny = blocks.y, nz = blocks.z;
  std::vector<int> dist(occ.size());
  parallelFor(ny * nz, [&](int64_t r0, int64_t r1) {
    for (int64_t r = r0; r < r1; ++r) {
      int* row = dist.data() + r * nx;
      const uint8_t* o = occ.data() + r * nx;
      int run = cap;
      for (int64_t x = 0; x < nx; ++x) row[x] = run = o[x] ? 0 : std::min(run + 1, cap);
      run = cap;
      for (int64_t x = nx - 1; x >= 0; --x) row[x] = std::min(row[x], run = o[x] ? 0 : std::min(run + 1, cap));
    }
  });
  auto pass = [&](int64_t n, int64_t stride, int64_t lines, auto lineStart) {
    parallelFor(lines, [&](int64_t l0, int64_t l1) {
      std::vector<int> in(size_t(n), cap);
      for (int64_t l = l0; l < l1; ++l) {
        int* base = dist.data() + lineStart(l);
        for (int64_t i = 0; i < n; ++i) in[size_t(i)] = base[i * stride];
        for (int64_t i = 0; i < n; ++i) {
          int best = in[size_t(i)];
          for (int64_t j = std::max<int64_t>(0, i - best + 1); j < std::min<int64_t>(n, i + best); ++j)
            best = std::min(best, std::max(int(std::abs(i - j)), in[size_t(j)]));
          base[i * stride] = best;
        }
      }
    });
  };
  pass(ny, nx, nx * nz, [&](int64_t l) { return (l / nx) * nx * ny + l % nx; });
  pass(nz, nx * ny, nx * ny, [&](int64_t l) { return l; });
  std::vector<uint8_t> tex(occ.size());
  for (size_t i = 0; i < occ.size(); ++i)
    tex[i] = occ[i] == 255 ? 255 : occ[i] ? 254 : uint8_t(std::clamp(dist[i], 1, cap));
  return tex;
}

void markHomogeneousBlocks(const BlockFields& b, const StyleTable& t, const std::vector<PaintSlot>& slots,
                           float coverageH, std::vector<uint8_t>& occ) {
  if (t.visible[0]) return;  // label 0 follows the nearest surface everywhere
  std::vector<float> out, in;
  skipBands(t, slots, coverageH, 0.f, 0.f, out, in);
  const size_t ns = slots.size();
  // Rows whose look varies with the CT or a texture inside a segment.
  std::vector<uint8_t> varies(ns, 0);
  for (size_t s = 0; s < ns; ++s)
    for (int id : {slots[s].id, slots[s].shellId}) {
      if (id <= 0 || id >= kMaxLabels || !t.shows[size_t(id)]) continue;
      const StyleRow r = t.row(id);
      if ((r[slot::LambdaIllum] > 0.f && r[slot::Illum] == IllumMode::Ct) ||
          r[slot::BoundaryMeasure] == BoundaryMeasure::Ct ||
          (r[slot::LambdaTexture] > 0.f && r[slot::Texture] != SolidTexture::None))
        varies[s] = 1;
    }
  for (size_t bi = 0; bi < occ.size(); ++bi) {
    if (occ[bi] == 0) continue;
    bool same = true;
    for (size_t s = 0; s < ns && same; ++s) {
      const float lo = b.minD[bi * ns + s], hi = b.maxD[bi * ns + s];
      const bool covers = lo < 0.5f * coverageH;
      if (covers && varies[s]) same = false;
      // A constant field (the narrow band's clamp: deep inside or far outside) has a constant
      // distance and a zero gradient, so the slot's part of every sample is the same; so
      // does a slot whose whole range is beyond its bands (skipBands). Ink too: no minimum
      // below the clamp, no sign change.
      else same = lo == hi || lo >= out[s] || hi <= -in[s];
    }
    if (same) occ[bi] = 128;
  }
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
  put(p, slot::ToneWarm, r.toneWarm);
  put(p, slot::ToneBeta, r.toneBeta);
  put(p, slot::ToneCool, r.toneCool);
  put(p, slot::ToneAlpha, r.toneAlpha);
  put(p, slot::DepthColour, r.depthColour);
  put(p, slot::DepthStrength, r.depthStrength);
  const bool mm = r.depthUnits == DepthUnits::Mm;
  put(p, slot::DepthStart, mm ? float(r.depthStart / diameter) : r.depthStart);
  put(p, slot::DepthEnd, mm ? float(r.depthEnd / diameter) : r.depthEnd);
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
  put(p, slot::ToneKey, r.toneKey);
  put(p, slot::LineWidthPx, r.lineWidthPx);
  put(p, slot::LineOpacity, r.lineOpacity);
  put(p, slot::LineColour, r.lineColour);
  put(p, slot::HatchSpacingPx, r.hatchSpacingPx);
  put(p, slot::HatchWidthPx, r.hatchWidthPx);
  put(p, slot::CreaseWidthPx, r.creaseWidthPx);
  put(p, slot::CreaseAngleDeg, r.creaseAngleDeg);
  put(p, slot::Ink, r.visible && r.lineOpacity > 0 && (r.lineWidthPx > 0 || r.hatchSpacingPx > 0 || r.creaseWidthPx > 0));
}

}  // namespace

StyleTable packStyle(const Style& style, const std::vector<Label>& table, int maxId, const Geometry& g) {
  if (maxId >= kMaxLabels)
    throw Error("illustrate: segment ids must be <= 255 (found " + std::to_string(maxId) + ")");
  const std::vector<SegmentStyle> rows = resolveRows(style, table, kMaxLabels - 1);
  // Depths in mm become fractions of the bounding sphere's diameter (what the shader uses).
  const Dims& d = g.dims;
  const Vec3 centre = g.indexToPhysical({(d.x - 1) * 0.5, (d.y - 1) * 0.5, (d.z - 1) * 0.5});
  const double radius = voxelBoxRadius(g, centre);
  const double diameter = std::max(2 * radius, 1e-6);
  StyleTable t;
  t.rows = kMaxLabels;
  t.texels.assign(size_t(t.rows) * kRowTexels * 4, 0.f);
  for (int l = 0; l < t.rows; ++l) {
    const SegmentStyle& r = rows[size_t(l)];
    const bool shows = r.visible && (r.lambdaIllum + r.lambdaColouring + r.lambdaTexture) > 0 &&
                       (r.opacity > 0 || (r.illum == IllumMode::Ct && r.lambdaIllum > 0));
    const bool ink = r.visible && r.lineOpacity > 0 && (r.lineWidthPx > 0 || r.hatchSpacingPx > 0 || r.creaseWidthPx > 0);
    const bool vis = shows || ink;
    packRow(r, vis, diameter, t.texels.data() + size_t(l) * kRowTexels * 4);
    t.visible[size_t(l)] = vis;
    t.shows[size_t(l)] = shows;
    if (!vis || l > maxId) continue;  // features of rows no voxel uses do not matter
    if (ink) {
      t.usesInk = true;
      t.maxLineWidthPx = std::max(t.maxLineWidthPx, r.lineWidthPx);
    }
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

float inkVertex(float a, float b, float c) {
  // Vertex of the parabola through (-1, a), (0, b), (1, c); b is the sampled minimum.
  const float curv = a - 2.f * b + c;
  return curv > 1e-7f ? std::clamp(0.5f * (a - c) / curv, -1.f, 1.f) : 0.f;
}

float inkLine(float a, float b, float c, float widthPx, float pixMm) {
  const float m = b + 0.25f * (c - a) * inkVertex(a, b, c);
  return std::clamp((0.5f * widthPx * pixMm - std::abs(m)) / pixMm + 0.5f, 0.f, 1.f);
}

float inkFeatureFade(float dm, float m, float dp, float voxelMm) {
  const float curv = dm - 2.f * m + dp;  // mm over a voxel squared
  if (!(curv > 0.f)) return 1.f;
  const float radiusMm = voxelMm * voxelMm / curv;  // of the circle through the three distances
  return std::clamp(radiusMm / voxelMm - 1.f, 0.f, 1.f);
}

float FieldVolume::at(float x, float y, float z, int slot) const {
  // As the shader's fieldAt(): clamp to the grid, trilinear, one channel.
  const Trilinear t(x, y, z, dims);
  const float* base = value.data() + size_t(slot / 4) * size_t(dims.voxelCount()) * 4 + size_t(slot % 4);
  float out = 0;
  for (int c = 0; c < 8; ++c) out += t.weight(c) * base[size_t((t.k(c) * dims.y + t.j(c)) * dims.x + t.i(c)) * 4];
  return out;
}

float inkHatch(float ndl, const float* u, const float* fade, float spacingPx, float widthPx) {
  float ink = 0.f;
  const float thresholds[3] = {0.6f, 0.25f, -0.2f};
  for (int layer = 0; layer < 3; ++layer) {
    const float w = widthPx * std::clamp((thresholds[layer] - ndl) / 0.25f, 0.f, 1.f);
    if (!(w > 0.f)) break;
    // Distance (px) from the sample to the nearest stroke plane's centre.
    const float f = u[layer] / spacingPx - std::floor(u[layer] / spacingPx);
    const float dist = std::abs(f - 0.5f) * spacingPx;
    const float cov = std::clamp(0.5f * w - dist + 0.5f, 0.f, 1.f) * std::min(w, 1.f) * fade[layer];
    ink = ink + cov - ink * cov;
  }
  return ink;
}

void hatchCoordinates(const SampleFrame& f, Vec3f pMm, Vec3f n, float* u, float* fade) {
  for (int l = 0; l < 3; ++l) {
    const Vec3f a = f.hatchAxis[l];
    u[l] = dot(pMm, a) / f.hatchPixMm;
    // Strokes are the surface's cuts by planes across the axis: where the surface lies
    // along those planes (n parallel to the axis) they would swell into blots, so they fade.
    const float c = std::abs(dot(n, a));
    const float sine = std::sqrt(std::max(1.f - c * c, 0.f));
    fade[l] = std::clamp((sine - 0.25f) / 0.3f, 0.f, 1.f);
  }
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
  // Tone key: divide by the value at the key's n.l, so that lit mid-tones show the colour.
  const float key = r[slot::ToneKey], kk = (1.f + key) * 0.5f;
  float cc[3];
  for (int c = 0; c < 3; ++c) {
    float tone = clamp01(k * (warm[c] + r[slot::ToneBeta] * col[c]) + (1.f - k) * (cool[c] + r[slot::ToneAlpha] * col[c]));
    if (key > 0.f) {
      const float at = clamp01(kk * (warm[c] + r[slot::ToneBeta] * col[c]) + (1.f - kk) * (cool[c] + r[slot::ToneAlpha] * col[c]));
      tone = clamp01(tone * col[c] / std::max(at, 1e-3f));
    }
    cc[c] = col[c] + r[slot::ToneAmount] * (tone - col[c]);
  }
  const float start = r[slot::DepthStart], end = r[slot::DepthEnd];
  const float dimW = r[slot::DepthStrength] * clamp01((depth - start) / std::max(end - start, 1e-4f));
  const float* dimColour = r[slot::DepthColour];
  for (int c = 0; c < 3; ++c) cc[c] = cc[c] + dimW * (dimColour[c] - cc[c]);

  const float ambient = r[slot::Ambient], diffuse = r[slot::Diffuse];
  const float specular = r[slot::Specular], shininess = r[slot::Shininess];
  const float lit = (ambient + diffuse * std::max(ndl, 0.f)) / (key > 0.f ? std::max(ambient + diffuse * key, 1e-3f) : 1.f);
  const float aSeg = r[slot::Opacity];

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

std::array<float, 4> shadeSample(const StyleTable& t, const std::vector<PaintSlot>& slots, const float* d,
                                 const Vec3f* gradPhys, const float* ct4, const TextureVolume* texVol, Vec3f pMm,
                                 float depth, Vec3f view, const SampleFrame& f) {
  std::array<float, 4> sum{0, 0, 0, 0};
  auto add = [&](int id, float w, Vec3f g, float dd) {
    if (!(w > 0.f) || !t.visible[size_t(id)]) return;
    const float g4[4] = {g.x, g.y, g.z, dd};
    const auto v = styledSample(t, id, g4, ct4, texVol, pMm, depth, view, f);
    for (int ch = 0; ch < 4; ++ch) sum[size_t(ch)] += w * v[size_t(ch)];
  };
  float rest = 1.f;
  for (int s = int(slots.size()) - 1; s >= 0; --s) {  // later slots paint over earlier ones
    if (!(rest > 0.f)) break;
    const float ds = d[s];
    const float c = clamp01(0.5f - ds / f.coverageH);
    if (!(c > 0.f)) continue;
    const float w = c * rest;
    rest *= 1.f - c;
    const PaintSlot& sl = slots[size_t(s)];
    const Vec3f g = gradPhys[s];
    if (sl.shellId > 0) {
      // The shell -t < d <= 0 and the core below it, split smoothly at d = -t; each with
      // its own surface (the shell's inner one faces inwards).
      const float sf = clamp01(0.5f + (ds + sl.shellMm) / f.coverageH);
      add(sl.shellId, w * sf, ds > -0.5f * sl.shellMm ? g : g * -1.f, std::max(ds, -sl.shellMm - ds));
      add(sl.id, w * (1.f - sf), g, ds + sl.shellMm);
    } else {
      add(sl.id, w, g, ds);
    }
  }
  if (rest > 0.f && t.visible[0]) {  // unclassified: the nearest surface's distance
    int best = -1;
    float bd = kFieldScaleMm;
    for (int s = 0; s < int(slots.size()); ++s)
      if (d[s] < bd) {
        bd = d[s];
        best = s;
      }
    add(0, rest, best >= 0 ? gradPhys[best] : Vec3f{}, bd);
  }
  return sum;
}

}  // namespace vellum::illustration::detail
