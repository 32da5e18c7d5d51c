#include "vellum/deformation/synthesis.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <type_traits>
#include <variant>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include "vellum/core/error.hpp"
#include "vellum/core/index_frame.hpp"
#include "vellum/core/simd_clones.hpp"
#include "vellum/core/memory_budget.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum::deformation {
namespace {

// Upsampling taps along one axis: output voxel o reads nodes idx[t] with weights w[t].
template <int Taps>
struct AxisTaps {
  std::vector<std::array<int32_t, Taps>> idx;
  std::vector<std::array<float, Taps>> w;
};

// The kernel's taps (linearTap, gaussianTap) are core's (core/backward_map.hpp): the same for
// the voxels of synthesize() / upsampleMap() and the arbitrary positions of MapSampler.

// The taps of every voxel 0 <= o < outLen along an axis, from a per-position tap function.
template <int Taps, class TapFn>
AxisTaps<Taps> axisTaps(int64_t outLen, int64_t nodes, int s, TapFn tap) {
  AxisTaps<Taps> t;
  t.idx.resize(static_cast<size_t>(outLen));
  t.w.resize(static_cast<size_t>(outLen));
  for (int64_t o = 0; o < outLen; ++o)
    tap(static_cast<double>(o), nodes, s, t.idx[static_cast<size_t>(o)], t.w[static_cast<size_t>(o)]);
  return t;
}

AxisTaps<2> linearTaps(int64_t outLen, int64_t nodes, int s) { return axisTaps<2>(outLen, nodes, s, linearTap); }

AxisTaps<4> gaussianTaps(int64_t outLen, int64_t nodes, int s) { return axisTaps<4>(outLen, nodes, s, gaussianTap); }

template <class T>
inline float fetch(const Volume<T>& v, const T* data, int64_t dx, int64_t dy, int64_t dz,
                   float x, float y, float z, float bg) {
  const float fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
  const int64_t i = static_cast<int64_t>(fx), j = static_cast<int64_t>(fy), k = static_cast<int64_t>(fz);
  const float tx = x - fx, ty = y - fy, tz = z - fz;
  if (i >= 0 && j >= 0 && k >= 0 && i + 1 < dx && j + 1 < dy && k + 1 < dz) {
    const int64_t sy = dx, sz = dx * dy;
    const T* p = data + (k * dy + j) * dx + i;
    const float c00 = p[0] + tx * (float(p[1]) - float(p[0]));
    const float c10 = p[sy] + tx * (float(p[sy + 1]) - float(p[sy]));
    const float c01 = p[sz] + tx * (float(p[sz + 1]) - float(p[sz]));
    const float c11 = p[sz + sy] + tx * (float(p[sz + sy + 1]) - float(p[sz + sy]));
    const float c0 = c00 + ty * (c10 - c00), c1 = c01 + ty * (c11 - c01);
    return c0 + tz * (c1 - c0);
  }
  if (i < -1 || j < -1 || k < -1 || i >= dx || j >= dy || k >= dz) return bg;
  return static_cast<float>(v.sampleLinear({x, y, z}));
}

template <class T>
inline T toVoxel(float v) {
  if constexpr (std::is_floating_point_v<T>) {
    return static_cast<T>(v);
  } else {
    constexpr float lo = static_cast<float>(std::numeric_limits<T>::lowest());
    constexpr float hi = static_cast<float>(std::numeric_limits<T>::max());
    return static_cast<T>(std::floor(std::clamp(v, lo, hi) + 0.5f));
  }
}

// Trilinear x step without tables: voxels c*s .. c*s+s-1 lie on the segment from node c to c+1.
VELLUM_SIMD_CLONES void upsampleXLinear(const float* row, int64_t nodes, int s, int64_t n, float* ox,
                                        float* oy, float* oz) {
  const float invS = 1.0f / static_cast<float>(s);
  for (int64_t c = 0, i = 0; i < n; ++c) {
    const float* a = row + 3 * c;
    const float* b = row + 3 * std::min(c + 1, nodes - 1);
    const float d0 = b[0] - a[0], d1 = b[1] - a[1], d2 = b[2] - a[2];
    for (int p = 0; p < s && i < n; ++p, ++i) {
      const float f = static_cast<float>(p) * invS;
      ox[i] = a[0] + f * d0; oy[i] = a[1] + f * d1; oz[i] = a[2] + f * d2;
    }
  }
}

VELLUM_SIMD_CLONES void upsampleX4(const float* row, const int32_t* const* idx, const float* const* w,
                                   int64_t n, float* ox, float* oy, float* oz) {
#pragma omp simd
  for (int64_t i = 0; i < n; ++i) {
    float x = 0, y = 0, z = 0;
    for (int q = 0; q < 4; ++q) {
      const float* p = row + idx[q][i];
      x += w[q][i] * p[0]; y += w[q][i] * p[1]; z += w[q][i] * p[2];
    }
    ox[i] = x; oy[i] = y; oz[i] = z;
  }
}

VELLUM_SIMD_CLONES void axpy(float* dst, const float* src, float w, int64_t n) {
#pragma omp simd
  for (int64_t t = 0; t < n; ++t) dst[t] += w * src[t];
}

// The rigid snap (or nothing) in the frame of the upsampled coordinates, mm = L u + o (mm for
// upsampleMap, source index for synthesize), at the voxel indices of output geometry g.
std::optional<SnapFrame> prepareSnap(const ControlVolume& cv, const Geometry& g, const Mat3& L, const Vec3& o) {
  if (!cv.rigidSnap || !cv.rigidSnap->classes) return std::nullopt;
  return snapFrame(*cv.rigidSnap, g, L, o);
}

// An affine change of frame applied to each z-blended plane of nodes (u' = A u + b, A
// row-major): the z, y and x weights each sum to 1, so transforming the blended plane equals
// transforming every node first, without a converted copy of the whole node map.
struct PlaneAffine {
  float a[9], b[3];
};

VELLUM_SIMD_CLONES void applyAffine(const PlaneAffine& m, float* xyz, int64_t nodes) {
  const float* a = m.a;
  for (int64_t t = 0; t < nodes; ++t) {
    float* p = xyz + 3 * t;
    const float x = p[0], y = p[1], z = p[2];
    p[0] = a[0] * x + a[1] * y + a[2] * z + m.b[0];
    p[1] = a[3] * x + a[4] * y + a[5] * z + m.b[1];
    p[2] = a[6] * x + a[7] * y + a[8] * z + m.b[2];
  }
}

// Upsamples the node map `map3` (3 floats per node) to every output voxel, one row at a time:
// rowFn(k, j, ux, uy, uz) receives the coordinates of output row (j, k) as three arrays.
// Separable: node planes are blended in z, then rows in y, then voxels in x.
template <int Taps, class RowFn>
void upsampleRows(const std::vector<float>& map3, const Dims& nd, const Dims& od, int scale,
                  const AxisTaps<Taps>& tx, const AxisTaps<Taps>& ty, const AxisTaps<Taps>& tz,
                  const PlaneAffine* toFrame, const SnapFrame* snap, Progress& progress,
                  const char* stage, RowFn&& rowFn) {
  const int64_t planeNodes = nd.x * nd.y;
  // x taps as structure of arrays, node indices premultiplied by 3 (xyz interleaved rows).
  std::vector<int32_t> xi[Taps];
  std::vector<float> xw[Taps];
  for (int q = 0; q < Taps; ++q)
    for (int64_t i = 0; i < od.x; ++i) {
      xi[q].push_back(3 * tx.idx[static_cast<size_t>(i)][q]);
      xw[q].push_back(tx.w[static_cast<size_t>(i)][q]);
    }
  const int32_t* xiP[Taps];
  const float* xwP[Taps];
  for (int q = 0; q < Taps; ++q) { xiP[q] = xi[q].data(); xwP[q] = xw[q].data(); }
  progress.begin(stage, static_cast<uint64_t>(od.z));
  parallelFor(od.z, [&](int64_t k0, int64_t k1) {
    std::vector<float> plane(static_cast<size_t>(planeNodes) * 3), row(static_cast<size_t>(nd.x) * 3),
        ox(static_cast<size_t>(od.x)), oy(ox.size()), oz(ox.size());
    for (int64_t k = k0; k < k1; ++k) {
      const auto& zi = tz.idx[static_cast<size_t>(k)];
      const auto& zw = tz.w[static_cast<size_t>(k)];
      std::fill(plane.begin(), plane.end(), 0.f);
      for (int q = 0; q < Taps; ++q)
        if (zw[q] != 0.f)
          axpy(plane.data(), map3.data() + static_cast<size_t>(zi[q] * planeNodes) * 3, zw[q], planeNodes * 3);
      if (toFrame) applyAffine(*toFrame, plane.data(), planeNodes);
      for (int64_t j = 0; j < od.y; ++j) {
        const auto& yi = ty.idx[static_cast<size_t>(j)];
        const auto& yw = ty.w[static_cast<size_t>(j)];
        std::fill(row.begin(), row.end(), 0.f);
        for (int q = 0; q < Taps; ++q)
          if (yw[q] != 0.f) axpy(row.data(), plane.data() + static_cast<size_t>(yi[q] * nd.x) * 3, yw[q], nd.x * 3);
        if constexpr (Taps == 2)
          upsampleXLinear(row.data(), nd.x, scale, od.x, ox.data(), oy.data(), oz.data());
        else
          upsampleX4(row.data(), xiP, xwP, od.x, ox.data(), oy.data(), oz.data());
        if (snap) snap->applyRow(j, k, od.x, ox.data(), oy.data(), oz.data());
        rowFn(k, j, ox.data(), oy.data(), oz.data());
      }
      progress.advance();
    }
  });
  progress.end();
}

#ifdef VELLUM_HAVE_AVX2_PATH
// g = p[i] | p[i+1] << 16 (two int16 voxels): p[i] + t (p[i+1] - p[i]).
__attribute__((target("avx2,fma"))) inline __m256 lerpPair(__m256i g, __m256 t) {
  const __m256 a = _mm256_cvtepi32_ps(_mm256_srai_epi32(_mm256_slli_epi32(g, 16), 16));
  const __m256 b = _mm256_cvtepi32_ps(_mm256_srai_epi32(g, 16));
  return _mm256_fmadd_ps(t, _mm256_sub_ps(b, a), a);
}

// int16 trilinear fetch of 8 voxels at a time (AVX2 gathers: one 32-bit gather reads a voxel
// and its +x neighbour). Lanes whose cell leaves the grid take the scalar path (background).
__attribute__((target("avx2,fma"))) void fetchRowI16Avx2(const VolumeI16& src, const float* ux,
                                                        const float* uy, const float* uz, int64_t n,
                                                        int16_t* out) {
  const Dims d = src.dims();
  const int16_t* data = src.data();
  const float bg = static_cast<float>(src.background());
  const __m256i lastX = _mm256_set1_epi32(static_cast<int>(d.x - 1)),
                lastY = _mm256_set1_epi32(static_cast<int>(d.y - 1)),
                lastZ = _mm256_set1_epi32(static_cast<int>(d.z - 1)), minus1 = _mm256_set1_epi32(-1);
  const __m256i sx = _mm256_set1_epi32(static_cast<int>(d.x)), sxy = _mm256_set1_epi32(static_cast<int>(d.x * d.y));
  const __m256 half = _mm256_set1_ps(0.5f), lo = _mm256_set1_ps(-32768.f), hi = _mm256_set1_ps(32767.f);
  const auto rounded = [](float v) { return static_cast<int16_t>(std::floor(std::clamp(v, -32768.f, 32767.f) + 0.5f)); };
  const int16_t background = rounded(bg);
  // Lanes whose cell leaves the grid: background at once when it lies a voxel or more beyond
  // the outer centres on some axis (what sampleLinear returns there; NaN included), else the
  // scalar sample with its background-weighted border.
  const float ex = static_cast<float>(d.x), ey = static_cast<float>(d.y), ez = static_cast<float>(d.z);
  const auto scalarAt = [&](int64_t t) -> int16_t {
    const float x = ux[t], y = uy[t], z = uz[t];
    if (!(x >= -1.f && y >= -1.f && z >= -1.f && x < ex && y < ey && z < ez)) return background;
    return rounded(static_cast<float>(src.sampleLinear({x, y, z})));
  };
  int64_t i = 0;
  for (; i + 8 <= n; i += 8) {
    const __m256 x = _mm256_loadu_ps(ux + i), y = _mm256_loadu_ps(uy + i), z = _mm256_loadu_ps(uz + i);
    const __m256 fx = _mm256_floor_ps(x), fy = _mm256_floor_ps(y), fz = _mm256_floor_ps(z);
    const __m256i ix = _mm256_cvttps_epi32(fx), iy = _mm256_cvttps_epi32(fy), iz = _mm256_cvttps_epi32(fz);
    const __m256i in = _mm256_and_si256(
        _mm256_and_si256(_mm256_and_si256(_mm256_cmpgt_epi32(ix, minus1), _mm256_cmpgt_epi32(lastX, ix)),
                         _mm256_and_si256(_mm256_cmpgt_epi32(iy, minus1), _mm256_cmpgt_epi32(lastY, iy))),
        _mm256_and_si256(_mm256_cmpgt_epi32(iz, minus1), _mm256_cmpgt_epi32(lastZ, iz)));
    const int mask = _mm256_movemask_ps(_mm256_castsi256_ps(in));
    if (mask == 0) {
      for (int l = 0; l < 8; ++l) out[i + l] = scalarAt(i + l);
      continue;
    }
    __m256i base = _mm256_add_epi32(_mm256_add_epi32(_mm256_mullo_epi32(iz, sxy), _mm256_mullo_epi32(iy, sx)), ix);
    base = _mm256_and_si256(base, in);  // lanes outside read voxel 0 (discarded)
    const int* p = reinterpret_cast<const int*>(data);
    const __m256i g00 = _mm256_i32gather_epi32(p, base, 2);
    const __m256i g10 = _mm256_i32gather_epi32(p, _mm256_add_epi32(base, sx), 2);
    const __m256i g01 = _mm256_i32gather_epi32(p, _mm256_add_epi32(base, sxy), 2);
    const __m256i g11 = _mm256_i32gather_epi32(p, _mm256_add_epi32(base, _mm256_add_epi32(sx, sxy)), 2);
    const __m256 tx = _mm256_sub_ps(x, fx), ty = _mm256_sub_ps(y, fy), tz = _mm256_sub_ps(z, fz);
    const __m256 c00 = lerpPair(g00, tx), c10 = lerpPair(g10, tx), c01 = lerpPair(g01, tx), c11 = lerpPair(g11, tx);
    const __m256 c0 = _mm256_fmadd_ps(ty, _mm256_sub_ps(c10, c00), c00);
    const __m256 c1 = _mm256_fmadd_ps(ty, _mm256_sub_ps(c11, c01), c01);
    __m256 v = _mm256_fmadd_ps(tz, _mm256_sub_ps(c1, c0), c0);
    v = _mm256_floor_ps(_mm256_add_ps(_mm256_min_ps(_mm256_max_ps(v, lo), hi), half));
    __m256i r = _mm256_cvttps_epi32(v);
    r = _mm256_permute4x64_epi64(_mm256_packs_epi32(r, r), 0xD8);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out + i), _mm256_castsi256_si128(r));
    if (mask != 0xFF)
      for (int l = 0; l < 8; ++l)
        if (!(mask & (1 << l))) out[i + l] = scalarAt(i + l);
  }
  for (; i < n; ++i) out[i] = scalarAt(i);
}

bool haveAvx2() {
  static const bool ok = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return ok;
}
#endif

template <class RowFn>
void upsampleAny(const std::vector<float>& map3, const Dims& nd, const Dims& od, int s,
                 Upsampling up, const PlaneAffine* toFrame, const SnapFrame* snap, Progress& progress,
                 const char* stage, RowFn&& rowFn) {
  if (up == Upsampling::Trilinear)
    upsampleRows(map3, nd, od, s, linearTaps(od.x, nd.x, s), linearTaps(od.y, nd.y, s),
                 linearTaps(od.z, nd.z, s), toFrame, snap, progress, stage, rowFn);
  else
    upsampleRows(map3, nd, od, s, gaussianTaps(od.x, nd.x, s), gaussianTaps(od.y, nd.y, s),
                 gaussianTaps(od.z, nd.z, s), toFrame, snap, progress, stage, rowFn);
}

/// The map's u at every output voxel of `output`, one row at a time as upsampleAny(): through
/// the twist kernel when the map has one (each voxel turned by its interpolated weights), else
/// the nodes upsampled by `up`.
template <class RowFn>
void upsampleControl(const ControlVolume& cv, const Geometry& output, Upsampling up, const PlaneAffine* toFrame,
                     const SnapFrame* snap, Progress& progress, const char* stage, RowFn&& rowFn) {
  if (!cv.twist || cv.twist->stages().empty()) {  // no stage: the nodes' positions are the map
    upsampleAny(cv.sourceMm, cv.grid.dims, output.dims, cv.scale, up, toFrame, snap, progress, stage, rowFn);
    return;
  }
  const TwistKernel& twist = *cv.twist;
  const Geometry::ToIndex toNode = cv.grid.physicalToIndexMap();
  const Dims od = output.dims, nd = cv.grid.dims;
  const int s = cv.scale;
  // The first stage reads w at the voxel itself, node index (i, j, k) / s: per row its weights
  // blended over the row's y and z once (as upsampleRows() blends positions), then along x;
  // later stages read w where the earlier ones left the point (TwistKernel::sourceMm()).
  const AxisTaps<2> ty = linearTaps(od.y, nd.y, s), tz = linearTaps(od.z, nd.z, s);
  const Vec3 stepX = output.indexToPhysical({1, 0, 0}) - output.indexToPhysical({0, 0, 0});
  const float* w0 = twist.weights.data();  // stage 0 at offset 0
  const int64_t stride = static_cast<int64_t>(twist.stride());
  progress.begin(stage, static_cast<uint64_t>(od.z));
  parallelFor(od.z, [&](int64_t k0, int64_t k1) {
    std::vector<float> ux(static_cast<size_t>(od.x)), uy(ux.size()), uz(ux.size());
    std::vector<double> line(static_cast<size_t>(nd.x));
    for (int64_t k = k0; k < k1; ++k) {
      progress.checkCancelled();
      const auto& zi = tz.idx[static_cast<size_t>(k)];
      const auto& zw = tz.w[static_cast<size_t>(k)];
      for (int64_t j = 0; j < od.y; ++j) {
        const auto& yi = ty.idx[static_cast<size_t>(j)];
        const auto& yw = ty.w[static_cast<size_t>(j)];
        for (int64_t n = 0; n < nd.x; ++n) {
          double acc = 0;
          for (int c = 0; c < 2; ++c)
            for (int b = 0; b < 2; ++b)
              acc += double(zw[c]) * double(yw[b]) * double(w0[((int64_t(zi[c]) * nd.y + yi[b]) * nd.x + n) * stride]);
          line[static_cast<size_t>(n)] = acc;
        }
        const Vec3 rowStart = output.indexToPhysical({0, double(j), double(k)});
        for (int64_t i = 0; i < od.x; ++i) {
          const int64_t n0 = std::min(i / s, nd.x - 1), n1 = std::min(n0 + 1, nd.x - 1);
          const double f = double(i - n0 * s) / s;
          Vec3 u = twist.turn(0, rowStart + stepX * double(i), line[size_t(n0)] + f * (line[size_t(n1)] - line[size_t(n0)]));
          for (size_t st = 1; st < twist.stages().size(); ++st) u = twist.turn(st, u, twist.weightAt(st, toNode(u), nd));
          float p[3] = {float(u.x), float(u.y), float(u.z)};
          if (toFrame) applyAffine(*toFrame, p, 1);
          ux[size_t(i)] = p[0], uy[size_t(i)] = p[1], uz[size_t(i)] = p[2];
        }
        if (snap) snap->applyRow(j, k, od.x, ux.data(), uy.data(), uz.data());
        rowFn(k, j, ux.data(), uy.data(), uz.data());
      }
      progress.advance();
    }
  });
  progress.end();
}

/// Whether the AVX2 gather may fill a grid of `od`'s rows (int32 voxel offsets).
bool gatherFits(const Dims& od) {
#ifdef VELLUM_HAVE_AVX2_PATH
  return haveAvx2() && od.voxelCount() < (int64_t{1} << 31) - 4 * od.x * od.y;
#else
  (void)od;
  return false;
#endif
}

/// One output row `o` (`n` voxels) from its source index coordinates: the AVX2 gather for int16
/// when `gather`, else trilinear fetches (outside the source: its background).
template <class T>
void fetchRow(const Volume<T>& src, const float* ux, const float* uy, const float* uz, int64_t n, T* o,
              [[maybe_unused]] bool gather) {
#ifdef VELLUM_HAVE_AVX2_PATH
  if constexpr (std::is_same_v<T, int16_t>)
    if (gather) {
      fetchRowI16Avx2(src, ux, uy, uz, n, o);
      return;
    }
#endif
  const Dims d = src.geometry().dims;
  const float bg = static_cast<float>(src.background());
  for (int64_t i = 0; i < n; ++i) o[i] = toVoxel<T>(fetch(src, src.data(), d.x, d.y, d.z, ux[i], uy[i], uz[i], bg));
}

void checkGrid(const Geometry& g, const ControlVolume& cv) {
  const Geometry expect = controlGrid(g, cv.scale);
  if (!(expect.dims == cv.grid.dims) || !expect.approxEqual(cv.grid) ||
      cv.sourceMm.size() != static_cast<size_t>(cv.grid.dims.voxelCount()) * 3)
    throw Error("the control volume was not built for this volume's geometry");
}

}  // namespace

AnyVolume synthesize(const AnyVolume& source, const ControlVolume& cv, Upsampling upsampling,
                     Progress& progress) {
  const Geometry& g = geometryOf(source);
  checkGrid(g, cv);
  // The map goes to source index coordinates plane by plane (PlaneAffine), so the per-voxel
  // work is interpolation + fetch.
  const Mat3 toMm = indexToMm(g);
  Mat3 inv;
  if (!toMm.inverse(inv)) throw Error("synthesize: singular geometry");
  const Vec3 shift = inv * g.origin;
  PlaneAffine toIndex{};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) toIndex.a[3 * r + c] = static_cast<float>(inv(r, c));
    toIndex.b[r] = static_cast<float>(-shift[r]);
  }
  const auto snap = prepareSnap(cv, g, toMm, g.origin);
  return std::visit(
      [&](const auto& src) -> AnyVolume {
        using T = typename std::decay_t<decltype(src)>::value_type;
        Volume<T> out(g, T{}, src.background());
        const Dims od = g.dims;
        const bool gather = gatherFits(od);
        upsampleControl(cv, g, upsampling, &toIndex, snap ? &*snap : nullptr, progress, "synthesis",
                    [&](int64_t k, int64_t j, const float* ux, const float* uy, const float* uz) {
                      fetchRow(src, ux, uy, uz, od.x, out.data() + (k * od.y + j) * od.x, gather);
                    });
        return out;
      },
      source);
}

AnyVolume synthesizeFromMap(const AnyVolume& source, const std::vector<float>& mapMm, Progress& progress) {
  const Geometry& g = geometryOf(source);
  const Dims od = g.dims;
  if (mapMm.size() != static_cast<size_t>(od.voxelCount()) * 3)
    throw Error("synthesizeFromMap: the map does not match the volume's grid");
  const Geometry::ToIndex toIndex = g.physicalToIndexMap();
  return std::visit(
      [&](const auto& src) -> AnyVolume {
        using T = typename std::decay_t<decltype(src)>::value_type;
        Volume<T> out(g, T{}, src.background());
        const bool gather = gatherFits(od);
        progress.begin("synthesis", static_cast<uint64_t>(od.z));
        // As synthesize(): source index coordinates per row, then fetchRow().
        parallelFor(od.z, [&](int64_t k0, int64_t k1) {
          std::vector<float> ux(static_cast<size_t>(od.x)), uy(ux.size()), uz(ux.size());
          for (int64_t k = k0; k < k1; ++k) {
            progress.checkCancelled();
            for (int64_t j = 0; j < od.y; ++j) {
              const float* m = mapMm.data() + static_cast<size_t>((k * od.y + j) * od.x) * 3;
              for (int64_t i = 0; i < od.x; ++i) {
                const Vec3 idx = toIndex({m[3 * i], m[3 * i + 1], m[3 * i + 2]});
                ux[static_cast<size_t>(i)] = static_cast<float>(idx.x);
                uy[static_cast<size_t>(i)] = static_cast<float>(idx.y);
                uz[static_cast<size_t>(i)] = static_cast<float>(idx.z);
              }
              fetchRow(src, ux.data(), uy.data(), uz.data(), od.x, out.data() + (k * od.y + j) * od.x, gather);
            }
            progress.advance();
          }
        });
        progress.end();
        return out;
      },
      source);
}

std::vector<float> upsampleMap(const ControlVolume& cv, const Geometry& output, Upsampling upsampling,
                               Progress& progress) {
  checkGrid(output, cv);
  checkMemoryBudget(output.dims, 3 * sizeof(float), "full-resolution backward map");
  const Dims od = output.dims;
  std::vector<float> out;
  resizeHugePaged(out, static_cast<size_t>(od.voxelCount()) * 3);
  const auto snap = prepareSnap(cv, output, Mat3::identity(), Vec3{0, 0, 0});
  upsampleControl(cv, output, upsampling, nullptr, snap ? &*snap : nullptr, progress, "backward map",
              [&](int64_t k, int64_t j, const float* ux, const float* uy, const float* uz) {
                float* o = out.data() + static_cast<size_t>((k * od.y + j) * od.x) * 3;
                for (int64_t i = 0; i < od.x; ++i) {
                  o[3 * i] = ux[i]; o[3 * i + 1] = uy[i]; o[3 * i + 2] = uz[i];
                }
              });
  return out;
}

// Output index x along an axis of `dim` voxels, inside the voxel box: clamped onto the outer
// centres, and a voxel centre that comes back from mm as 3.9999999 made whole (the Gaussian
// kernel's 4-node window jumps at the nodes: it must read the voxel's own taps).
bool axisIndex(double x, int64_t dim, double& o) {
  if (!(x >= -0.5 && x <= double(dim) - 0.5)) return false;  // NaN too
  o = std::clamp(x, 0.0, double(dim - 1));
  if (std::abs(o - std::round(o)) < 1e-6) o = std::round(o);
  return true;
}

struct MapSampler::Impl {
  std::vector<float> nodes;  // cv.sourceMm
  Dims nd, od;
  int scale = 1;
  Geometry output;
  Geometry::ToIndex toIndex;  // output.physicalToIndex without inverting the direction per call
  Upsampling upsampling = Upsampling::Trilinear;
  std::optional<SnapFrame> snap;  // in mm, as upsampleMap() applies it
  std::shared_ptr<const TwistKernel> twist;  // the map's kernel, when it has one
  Geometry::ToIndex toNode;                  // output mm -> node index (the twist kernel's)

  // The snap at output index o (where synthesis applies it).
  void snapAt(const Vec3& o, float u[3]) const {
    if (!snap || !snap->reaches(o)) return;
    const float v[3] = {static_cast<float>(o.x), static_cast<float>(o.y), static_cast<float>(o.z)};
    snap->apply(v, u);
  }

  // u at output index o (inside the voxel centres): the nodes interpolated, then the snap.
  Vec3 interpolate(const Vec3& o) const {
    const Vec3 v = twist ? twist->sourceMm(output.indexToPhysical(o), toNode, nd)
                         : interpolateNodes(nodes.data(), nd, upsampling, scale, o);
    float u[3] = {float(v.x), float(v.y), float(v.z)};
    snapAt(o, u);
    return {u[0], u[1], u[2]};
  }

  void point(const Vec3& mm, float* out, uint8_t* inside) const {
    const Vec3 x = toIndex(mm);
    Vec3 o;
    *inside = axisIndex(x.x, od.x, o.x) && axisIndex(x.y, od.y, o.y) && axisIndex(x.z, od.z, o.z);
    if (!*inside) return;
    const Vec3 u = interpolate(o);
    out[0] = float(u.x), out[1] = float(u.y), out[2] = float(u.z);
  }

  // A row along one output grid axis (`axis`; the other two index coordinates fixed): those
  // two axes are blended into one line of nodes once, then each position reads Taps of them.
  template <int Taps, class TapFn>
  void axisRow(int axis, const Vec3& x0, double step, int n, float* out, uint8_t* inside, TapFn&& tap) const {
    const int64_t dims[3] = {od.x, od.y, od.z}, nodeDims[3] = {nd.x, nd.y, nd.z};
    const int64_t stride[3] = {1, nd.x, nd.x * nd.y};
    const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
    Vec3 o = x0;
    if (!axisIndex(x0[a1], dims[a1], o[a1]) || !axisIndex(x0[a2], dims[a2], o[a2])) {
      std::fill(inside, inside + n, uint8_t{0});
      return;
    }
    std::array<int32_t, Taps> i1, i2;
    std::array<float, Taps> w1, w2;
    tap(o[a1], nodeDims[a1], i1, w1);
    tap(o[a2], nodeDims[a2], i2, w2);
    std::vector<float> line(static_cast<size_t>(nodeDims[axis]) * 3, 0.f);
    // The inner sum runs over the later axis (z before y before x), as in interpolate().
    const bool innerIsA2 = a2 > a1;
    for (int64_t m = 0; m < nodeDims[axis]; ++m) {
      float* l = line.data() + 3 * m;
      for (int b = 0; b < Taps; ++b) {
        const int32_t iOuter = innerIsA2 ? i1[b] : i2[b];
        const float wOuter = innerIsA2 ? w1[b] : w2[b];
        if (wOuter == 0.f) continue;
        float inner[3] = {0, 0, 0};
        for (int c = 0; c < Taps; ++c) {
          const int32_t iIn = innerIsA2 ? i2[c] : i1[c];
          const float wIn = innerIsA2 ? w2[c] : w1[c];
          if (wIn == 0.f) continue;
          const int64_t node = m * stride[axis] + int64_t(iOuter) * stride[innerIsA2 ? a1 : a2] + int64_t(iIn) * stride[innerIsA2 ? a2 : a1];
          for (int q = 0; q < 3; ++q) inner[q] += wIn * nodes[static_cast<size_t>(3 * node + q)];
        }
        for (int q = 0; q < 3; ++q) l[q] += wOuter * inner[q];
      }
    }
    for (int i = 0; i < n; ++i) {
      if (!(inside[i] = axisIndex(x0[axis] + step * i, dims[axis], o[axis]))) continue;
      std::array<int32_t, Taps> ia;
      std::array<float, Taps> wa;
      tap(o[axis], nodeDims[axis], ia, wa);
      float u[3] = {0, 0, 0};
      for (int a = 0; a < Taps; ++a)
        for (int q = 0; q < 3; ++q) u[q] += wa[a] * line[static_cast<size_t>(3 * ia[a] + q)];
      snapAt(o, u);
      std::copy_n(u, 3, out + 3 * i);
    }
  }

  template <int Taps, class TapFn>
  void row(const Vec3& firstMm, const Vec3& stepMm, int n, float* out, uint8_t* inside, TapFn&& tap) const {
    const Vec3 x0 = toIndex(firstMm), dx = toIndex(firstMm + stepMm) - x0;
    int axis = -1, moving = 0;
    for (int a = 0; a < 3; ++a)
      if (std::abs(dx[a]) > 1e-12) axis = a, ++moving;
    if (moving == 1 && !twist) {
      axisRow<Taps>(axis, x0, dx[axis], n, out, inside, tap);
      return;
    }
    for (int i = 0; i < n; ++i) point(firstMm + stepMm * double(i), out + 3 * i, inside + i);
  }

  template <class Fn>
  void withKernel(Fn&& fn) const {
    const int s = scale;
    if (upsampling == Upsampling::Trilinear)
      fn(std::integral_constant<int, 2>{}, [s](double x, int64_t n, auto& idx, auto& w) { linearTap(x, n, s, idx, w); });
    else
      fn(std::integral_constant<int, 4>{}, [s](double x, int64_t n, auto& idx, auto& w) { gaussianTap(x, n, s, idx, w); });
  }
};

MapSampler::MapSampler(ControlVolume cv, const Geometry& output, Upsampling upsampling) {
  checkGrid(output, cv);
  auto impl = std::make_shared<Impl>();
  impl->nd = cv.grid.dims;
  impl->od = output.dims;
  impl->scale = cv.scale;
  impl->output = output;
  impl->toIndex = output.physicalToIndexMap();
  impl->upsampling = upsampling;
  impl->snap = prepareSnap(cv, output, Mat3::identity(), Vec3{0, 0, 0});
  impl->twist = cv.twist;
  impl->toNode = cv.grid.physicalToIndexMap();
  impl->nodes = std::move(cv.sourceMm);
  impl_ = std::move(impl);
}

std::optional<Vec3> MapSampler::sourceMm(const Vec3& outputMm) const {
  float u[3];
  uint8_t inside = 0;
  impl_->point(outputMm, u, &inside);
  if (!inside) return std::nullopt;
  return Vec3{u[0], u[1], u[2]};
}

void MapSampler::sourceMmRow(const Vec3& firstMm, const Vec3& stepMm, int n, float* out, uint8_t* inside) const {
  impl_->withKernel([&](auto taps, auto&& tap) { impl_->row<decltype(taps)::value>(firstMm, stepMm, n, out, inside, tap); });
}

const Geometry& MapSampler::output() const { return impl_->output; }
Upsampling MapSampler::upsampling() const { return impl_->upsampling; }

double psnr(const AnyVolume& reference, const AnyVolume& test) {
  if (!(geometryOf(reference).dims == geometryOf(test).dims))
    throw Error("psnr: volumes differ in size");
  const VolumeF32 a = toFloat32(reference), b = toFloat32(test);
  const auto [lo, hi] = a.valueRange();
  double se = 0;
  for (size_t t = 0; t < a.size(); ++t) {
    const double d = double(a.data()[t]) - double(b.data()[t]);
    se += d * d;
  }
  const double mse = se / static_cast<double>(std::max<size_t>(a.size(), 1));
  if (mse == 0) return std::numeric_limits<double>::infinity();
  const double peak = std::max(hi - lo, 1e-12);
  return 10.0 * std::log10(peak * peak / mse);
}

}  // namespace vellum::deformation
