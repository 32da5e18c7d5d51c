// The cinematic path tracer: shared set-up (lights, majorants, the final tone map and denoise)
// and the CPU reference, the GLSL of shaders/path_trace_main.frag.glsl step for step.
#include "path_tracer.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>

#include <opencv2/imgproc.hpp>

#include "label_colour.hpp"
#include "light_volume.hpp"
#include "map_sampling.hpp"
#include "normal_volume.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/render/path_tracer.hpp"
#include "vellum/render/volume_renderer.hpp"

namespace vellum::render::detail {

namespace {

float sigmaOfAlpha(float alpha, double stepMm) {
  return float(-std::log1p(-std::min(alpha, kMaxPathAlpha)) / stepMm);
}
}  // namespace

RenderSettings denoiseGuideSettings(const RenderSettings& s) {
  RenderSettings g = s;
  g.quality = Quality::Standard;
  g.lighting.shadows = g.lighting.occlusion = 0;  // the plain shaded picture: edges, not light
  g.lighting.toneMap = false;
  g.labelBlend = 0;
  return g;
}

RenderSettings tracedSettings(const RenderSettings& s) {
  RenderSettings t = s;
  t.width = std::max(1, int(std::lround(s.width * s.cinematic.traceScale)));
  t.height = std::max(1, int(std::lround(s.height * s.cinematic.traceScale)));
  return t;
}

PathLights makePathLights(const Frame& f, const RenderSettings& s) {
  PathLights l;
  static_cast<SceneLights&>(l) = makeSceneLights(f, s);
  l.pickKey = l.keyE / (l.keyE + l.fillE);
  l.bounces = s.cinematic.bounces;
  l.surfaceOffsetMm = kSurfaceOffsetVoxels * f.stepMm / s.stepVoxels;
  return l;
}

std::vector<float> blockMajorants(const BlockRanges& ranges, const TfTable& tf, double stepMm) {
  // Sparse table of maxima would be faster; the blocks are few (32^3 for 256^3 voxels).
  std::vector<float> sigma(kTfTableSize);
  for (int i = 0; i < kTfTableSize; ++i) sigma[size_t(i)] = sigmaOfAlpha(tf.rgba[4 * size_t(i) + 3], stepMm);
  auto entry = [&](double v) { return std::clamp((v - tf.lo) / (tf.hi - tf.lo), 0.0, 1.0) * (kTfTableSize - 1); };
  std::vector<float> out(ranges.minValue.size());
  parallelFor(int64_t(out.size()), [&](int64_t b0, int64_t b1) {
    for (int64_t b = b0; b < b1; ++b) {
      // Entries the lookup can interpolate between, one of margin for rounding (as blockOccupancy).
      const int i0 = std::max(0, int(std::floor(entry(ranges.minValue[size_t(b)]))) - 1);
      const int i1 = std::min(kTfTableSize - 1, int(std::floor(entry(ranges.maxValue[size_t(b)]))) + 2);
      out[size_t(b)] = *std::max_element(sigma.begin() + i0, sigma.begin() + i1 + 1);
    }
  });
  return out;
}

std::vector<float> cellMajorants(const MapCells& cells, const std::vector<float>& block, const Dims& blocks, float scale) {
  std::vector<float> out(cells.box.size());
  parallelFor(int64_t(out.size()), [&](int64_t n0, int64_t n1) {
    for (int64_t n = n0; n < n1; ++n) {
      const auto& b = cells.box[size_t(n)];
      float m = 0;
      for (int z = b[2]; z <= b[5]; ++z)
        for (int y = b[1]; y <= b[4]; ++y)
          for (int x = b[0]; x <= b[3]; ++x) m = std::max(m, block[size_t((z * blocks.y + y) * blocks.x + x)]);
      out[size_t(n)] = m * scale;
    }
  });
  return out;
}

namespace {
/// The guided filter (He, Sun & Tang 2010) of each channel of `noisy` under the grey level of
/// `guide`: per window, the path-traced colour as a linear function of the ray-cast picture's
/// brightness. Edges and surface detail come from the guide (noise-free), light and shadow from
/// the path tracer. Box filters only (OpenCV imgproc).
cv::Mat guidedDenoise(const cv::Mat& noisy, const RgbaImage& guide, double strength) {
  cv::Mat I(noisy.rows, noisy.cols, CV_32F);
  for (int y = 0; y < I.rows; ++y)
    for (int x = 0; x < I.cols; ++x) {
      const uint8_t* g = guide.at(x, y);
      const float a = g[3] / 255.f;  // straight colour over black: what the eye sees of it
      I.at<float>(y, x) = a * (0.2126f * g[0] + 0.7152f * g[1] + 0.0722f * g[2]) / 255.f;
    }
  const int r = 1 + int(std::lround(5 * strength));
  const cv::Size win(2 * r + 1, 2 * r + 1);
  const double eps = 1e-4 + 2e-3 * strength;
  auto box = [&](const cv::Mat& m) {
    cv::Mat out;
    cv::boxFilter(m, out, CV_32F, win, cv::Point(-1, -1), true, cv::BORDER_REFLECT);
    return out;
  };
  const cv::Mat meanI = box(I), varI = box(I.mul(I)) - meanI.mul(meanI);
  std::vector<cv::Mat> ch;
  cv::split(noisy, ch);
  for (cv::Mat& p : ch) {
    const cv::Mat meanP = box(p), cov = box(I.mul(p)) - meanI.mul(meanP);
    const cv::Mat a = cov / (varI + eps), b = meanP - a.mul(meanI);
    p = box(a).mul(I) + box(b);
  }
  cv::Mat out;
  cv::merge(ch, out);
  return out;
}
}  // namespace

RgbaImage finishPathTraced(const PathSums& traced, const RenderSettings& s, const RgbaImage* guide) {
  PathSums upsampled;
  if (traced.width != s.width || traced.height != s.height) {
    // Traced at a fraction of the size (tracedSettings): the sums bilinearly upsampled; the
    // guided denoise below puts the full-size edges back.
    const cv::Mat small(traced.height, traced.width, CV_32FC4, const_cast<float*>(traced.rgba.data()));
    cv::Mat big;
    cv::resize(small, big, cv::Size(s.width, s.height), 0, 0, cv::INTER_LINEAR);
    upsampled = {s.width, s.height, traced.samples, std::vector<float>(big.ptr<float>(), big.ptr<float>() + big.total() * 4)};
  }
  const PathSums& sums = upsampled.width ? upsampled : traced;
  const int w = sums.width, h = sums.height;
  const float inv = 1.f / float(std::max(sums.samples, 1));
  const float exposure = float(std::exp2(s.lighting.exposure));
  const std::array<float, 4>& bg = s.background;
  cv::Mat colour(h, w, CV_32FC3);
  std::vector<float> alpha(size_t(w) * size_t(h));
  parallelFor(h, [&](int64_t y0, int64_t y1) {
    for (int64_t y = y0; y < y1; ++y)
      for (int x = 0; x < w; ++x) {
        const size_t i = size_t(y) * size_t(w) + size_t(x);
        const float* px = sums.rgba.data() + 4 * i;
        const float a = std::clamp(px[3] * inv, 0.f, 1.f);
        const float outA = a + (1 - a) * bg[3];
        auto* out = colour.ptr<cv::Vec3f>(int(y)) + x;
        for (int c = 0; c < 3; ++c) {
          // Radiance of the covered part (straight), tone mapped, then over the background.
          const float straight = a > 0 ? px[c] * inv / a : 0.f;
          const float tm = toneMap(straight * exposure);
          const float o = a * tm + (1 - a) * bg[size_t(c)] * bg[3];
          (*out)[c] = outA > 0 ? std::min(o / outA, 1.f) : 0.f;
        }
        alpha[i] = outA;
      }
  });
  if (s.cinematic.denoise > 0 && guide) colour = guidedDenoise(colour, *guide, s.cinematic.denoise);
  RgbaImage image(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const auto& c = colour.at<cv::Vec3f>(y, x);
      uint8_t* px = image.at(x, y);
      const float a = alpha[size_t(y) * size_t(w) + size_t(x)];
      for (int k = 0; k < 3; ++k) px[k] = a > 0 ? uint8_t(std::lround(std::clamp(c[k], 0.f, 1.f) * 255)) : 0;
      px[3] = uint8_t(std::lround(std::clamp(a, 0.f, 1.f) * 255));
    }
  return image;
}

namespace {

/// An orthonormal basis around unit n (Duff et al. 2017), as basis() in the shader.
void basis(const Vec3& n, Vec3& b1, Vec3& b2) {
  const double sign = n.z >= 0 ? 1.0 : -1.0;
  const double a = -1.0 / (sign + n.z), b = n.x * n.y * a;
  b1 = {1 + sign * n.x * n.x * a, sign * b, -sign * n.x};
  b2 = {b, sign + n.y * n.y * a, -n.y};
}

double hgPhase(double cosTheta) {
  const double g = kPhaseG, den = 1 + g * g - 2 * g * cosTheta;
  return (1 - g * g) / (4 * std::numbers::pi * den * std::sqrt(den));
}

/// A direction about `axis` (propagation) from the Henyey-Greenstein phase function.
Vec3 sampleHg(const Vec3& axis, float xi1, float xi2) {
  const double g = kPhaseG;
  const double sq = (1 - g * g) / (1 + g - 2 * g * xi1);
  const double cosT = std::clamp((1 + g * g - sq * sq) / (2 * g), -1.0, 1.0);
  const double sinT = std::sqrt(std::max(0.0, 1 - cosT * cosT)), phi = 2 * std::numbers::pi * xi2;
  Vec3 b1, b2;
  basis(axis, b1, b2);
  return b1 * (sinT * std::cos(phi)) + b2 * (sinT * std::sin(phi)) + axis * cosT;
}

/// A direction in the cone of cos half-angle cosMax about `axis`, uniform in solid angle.
Vec3 sampleCone(const Vec3& axis, double cosMax, float xi1, float xi2) {
  const double cosT = 1 - xi1 * (1 - cosMax), sinT = std::sqrt(std::max(0.0, 1 - cosT * cosT));
  const double phi = 2 * std::numbers::pi * xi2;
  Vec3 b1, b2;
  basis(axis, b1, b2);
  return b1 * (sinT * std::cos(phi)) + b2 * (sinT * std::sin(phi)) + axis * cosT;
}

Vec3 sampleCosine(const Vec3& n, float xi1, float xi2) {
  const double r = std::sqrt(double(xi1)), phi = 2 * std::numbers::pi * xi2;
  Vec3 b1, b2;
  basis(n, b1, b2);
  return b1 * (r * std::cos(phi)) + b2 * (r * std::sin(phi)) + n * std::sqrt(std::max(0.0, 1.0 - xi1));
}

template <class V>
struct CpuTracer {
  CpuTracer(const Volume<V>& v, const RenderSettings& settings, const Frame& frame) : vol(v), s(settings), f(frame) {}
  const Volume<V>& vol;
  const RenderSettings& s;
  Frame f;
  TfTable tf;
  GradientNormals normals;
  const BackwardMap* map = nullptr;
  PreparedMap prepared;
  const LabelTint* tint = nullptr;  ///< label colours tint the albedo (labelBlend > 0)
  std::optional<LightVolume> light;  ///< cinematic.volumeShadows: shadows and sky occlusion from it
  PathLights lights;
  std::vector<float> majorant;
  Dims blocks;
  double blockSize = kBlockSize;

  struct Point {
    Vec3 u;
    double inside = 1;
    int snapped = -1;
  };
  Point locate(const Vec3& p) const {
    Point q{p, 1.0, -1};
    if (map) {
      q.inside = prepared.outputWeight(p);
      q.u = q.inside > 0 ? prepared.at(p, &q.snapped) : Vec3{PreparedMap::kOutside, PreparedMap::kOutside, PreparedMap::kOutside};
    }
    return q;
  }
  double value(const Point& q) const {
    double v = vol.sampleLinear(q.u);
    if (q.inside < 1.0) v = vol.background() + q.inside * (v - vol.background());
    return v;
  }
  float densityScale(const Vec3& p) const {
    if (!map || map->attributes.empty()) return 1.f;
    return std::max(sampleClamped<4>(map->attributes, map->grid.dims, p)[3], 0.f);
  }
  float sigma(const Vec3& p) const {
    const Point q = locate(p);
    return sigmaOfAlpha(tf.lookup(value(q))[3], f.stepMm) * densityScale(p);
  }

  /// The block of p and the t at which the ray o + t d leaves it (as the shader's skipping).
  float blockAt(const Vec3& o, const Vec3& d, double t, double& tExit) const {
    const Vec3 p = o + d * t;
    double lo[3], hi[3];
    int64_t b[3];
    const int64_t n[3] = {blocks.x, blocks.y, blocks.z};
    const double dims[3] = {double(f.box.dims.x), double(f.box.dims.y), double(f.box.dims.z)};
    for (int a = 0; a < 3; ++a) {
      b[a] = std::clamp<int64_t>(int64_t(std::floor(p[a] / blockSize)), 0, n[a] - 1);
      lo[a] = b[a] == 0 ? -2.0 : double(b[a]) * blockSize;
      hi[a] = b[a] == n[a] - 1 ? dims[a] + 2.0 : double(b[a] + 1) * blockSize;
    }
    tExit = 1e30;
    for (int a = 0; a < 3; ++a)
      if (d[a] != 0) tExit = std::min(tExit, ((d[a] > 0 ? hi[a] : lo[a]) - o[a]) / d[a]);
    return majorant[size_t((b[2] * n[1] + b[1]) * n[0] + b[0])];
  }

  /// Where the ray from p (box index) along d leaves the box.
  double boxExit(const Vec3& p, const Vec3& d) const {
    double t = 1e30;
    const double dims[3] = {double(f.box.dims.x), double(f.box.dims.y), double(f.box.dims.z)};
    for (int a = 0; a < 3; ++a)
      if (d[a] != 0) t = std::min(t, ((d[a] > 0 ? dims[a] - 0.5 : -0.5) - p[a]) / d[a]);
    return std::max(t, 0.0);
  }

  /// The majorant walk delta and ratio tracking share: tentative collisions in (t, t1) at the
  /// block majorants' rate; `collide(t, m)` is called at each and returns true to stop there.
  /// Returns whether it stopped (false: the walk reached t1 or its step limit).
  template <class Collide>
  bool trackMajorants(const Vec3& o, const Vec3& d, double t, double t1, PathRng& rng, Collide&& collide) const {
    for (int it = 0; it < kMaxTrackingSteps && t < t1; ++it) {
      double tExit;
      const float m = blockAt(o, d, t, tExit);
      const double tEnd = std::min(tExit, t1);
      if (!(m > 0)) {
        t = std::max(tEnd, t) + kBlockNudgeMm;
        continue;
      }
      t += -std::log(1.0 - rng.next()) / m;
      if (t >= tEnd) {
        t = tEnd + kBlockNudgeMm;
        continue;
      }
      if (collide(t, m)) return true;
    }
    return false;
  }

  /// Delta (Woodcock) tracking against the block majorants: the first real collision in
  /// (t0, t1), or false.
  bool deltaTrack(const Vec3& o, const Vec3& d, double t, double t1, PathRng& rng, double& tHit) const {
    return trackMajorants(o, d, t, t1, rng, [&](double tc, float m) {
      if (!(rng.next() * m < sigma(o + d * tc))) return false;
      tHit = tc;
      return true;
    });
  }

  /// Ratio tracking: the transmittance from o along d to the box (0 below kMinTransmittance).
  float ratioTrack(const Vec3& o, const Vec3& d, PathRng& rng) const {
    float T = 1;
    const bool cut = trackMajorants(o, d, 0, boxExit(o, d), rng, [&](double tc, float m) {
      T *= std::max(0.f, 1.f - sigma(o + d * tc) / m);
      return T < kMinTransmittance;
    });
    return cut ? 0.f : T;
  }

  float skyRadiance(const Vec3& w) const { return detail::skyRadiance(lights, w); }

  /// One path through pixel (x, y): premultiplied radiance and coverage.
  std::array<float, 4> path(int x, int y, uint32_t sample) const {
    PathRng rng(x, y, sample, uint32_t(s.cinematic.seed));
    const float jx = rng.next(), jy = rng.next();
    const double sx = ((x + jx) / f.width * 2 - 1) * f.halfW, sy = (1 - (y + jy) / f.height * 2) * f.halfH;
    const Vec3 offset = f.right * sx + f.up * sy;
    Ray ray = f.perspective ? Ray{f.eye, normalized(f.forward + offset)} : Ray{f.eye + offset, f.forward};
    const Clip clip = clipRay(f, ray, 0.0);
    // clipRay gives the box entry/exit only through k0/k1; recompute them as the shader does.
    double tmin = 0, tmax = 1e30;
    for (int a = 0; a < 3; ++a) {
      double da = clip.d[a];
      if (std::abs(da) < 1e-12) da = da < 0 ? -1e-12 : 1e-12;
      const double t0 = (-0.5 - clip.o[a]) / da, t1 = (f.box.dims[a] - 0.5 - clip.o[a]) / da;
      tmin = std::max(tmin, std::min(t0, t1));
      tmax = std::min(tmax, std::max(t0, t1));
    }
    std::array<float, 4> out{0, 0, 0, 0};
    double tHit;
    if (tmax < tmin || !deltaTrack(clip.o, clip.d, tmin, tmax, rng, tHit)) return out;
    out[3] = 1;
    Vec3 p = clip.o + clip.d * tHit, dir = ray.dir;
    std::array<float, 3> beta{1, 1, 1};
    for (int bounce = 1; bounce <= lights.bounces; ++bounce) {
      const Point q = locate(p);
      const Vec3 pLight = p;  // the light volume lies in the box (deformed: output space)
      const std::array<float, 4> c = tf.lookup(value(q));
      std::array<float, 3> rgb{c[0], c[1], c[2]};
      if (map && !map->attributes.empty()) {
        const auto at = sampleClamped<4>(map->attributes, map->grid.dims, p);
        rgb = labShift(rgb, at[0], at[1], at[2]);
      }
      if (tint) rgb = tintByLabels(rgb, q.u, vol, tf, *tint, float(s.labelBlend));
      const std::array<float, 3> albedo{srgbToLinear(rgb[0]), srgbToLinear(rgb[1]), srgbToLinear(rgb[2])};
      std::array<float, 4> n = normals.sample(vol, q.u);
      if (map && s.turnDeformedNormals) n = prepared.turnNormal(p, n, q.snapped);
      const float len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
      const float grad = len > 1e-4f ? std::clamp((n[3] - kGradLow) / (kGradHigh - kGradLow), 0.f, 1.f) : 0.f;
      const Vec3 wo = dir * -1.0;
      // Surface-like (BRDF) or volume-like (phase function) scattering, by gradient strength.
      const bool surface = rng.next() < grad;
      Vec3 nn = len > 1e-4f ? Vec3{n[0] / len, n[1] / len, n[2] / len} : wo;
      if (dot(nn, wo) < 0) nn = nn * -1.0;
      if (surface) {
        // A surface event lies about one mean free path inside the material: the rays that leave
        // start above it (up to 3 mean free paths along the normal), or the surface would shadow
        // itself by about half (E[exp(-sigma x / cos)] for x ~ Exp(sigma)).
        const double off = std::min(3.0 / std::max(double(sigma(p)), 1e-6), double(lights.surfaceOffsetMm));
        p = p + f.physToBox * (nn * off);
      }

      // Next-event estimation: the key (a disc) or the fill light, chosen by irradiance.
      const float xiL = rng.next(), xi1 = rng.next(), xi2 = rng.next();
      const bool key = xiL < lights.pickKey;
      const Vec3 wl = key ? sampleCone(lights.key, lights.keyCos, xi1, xi2) : lights.fill;
      const float E = key ? lights.keyE / lights.pickKey : lights.fillE / (1 - lights.pickKey);
      float fr;  // times albedo: BRDF x cos, or phase
      float spec = 0;
      if (surface) {
        const double cosL = dot(nn, wl);
        fr = cosL > 0 ? float(cosL / std::numbers::pi) : 0.f;
        if (cosL > 0) {
          const Vec3 h = normalized(wl + wo);
          spec = float(kSpecular * (kShininess + 8) / (8 * std::numbers::pi) *
                       std::pow(std::max(dot(nn, h), 0.0), double(kShininess)) * cosL);
        }
      } else {
        fr = float(hgPhase(dot(dir, wl)));
      }
      if (fr > 0) {
        // Volume shadows: the light volume's transmittance for the key, the fill unshadowed.
        const float T = light ? (key ? light->sample(pLight + light->towardsLight)[0] : 1.f) : ratioTrack(p, f.physToBox * wl, rng);
        for (int k = 0; k < 3; ++k) out[size_t(k)] += beta[size_t(k)] * (albedo[size_t(k)] * fr + spec) * E * T;
      }
      // The next direction: cosine-weighted about the normal, or from the phase function.
      const float xi3 = rng.next(), xi4 = rng.next();
      dir = surface ? sampleCosine(nn, xi3, xi4) : sampleHg(dir, xi3, xi4);
      for (int k = 0; k < 3; ++k) beta[size_t(k)] *= albedo[size_t(k)];
      const Vec3 d = f.physToBox * dir;
      if (bounce == lights.bounces) {  // the last vertex: sky light through the volume
        const float T = light ? light->sample(pLight)[1] : ratioTrack(p, d, rng);  // volume: the openness
        const float L = skyRadiance(dir) * T;
        for (int k = 0; k < 3; ++k) out[size_t(k)] += beta[size_t(k)] * L;
        break;
      }
      if (!deltaTrack(p, d, 0.0, boxExit(p, d), rng, tHit)) {
        const float L = skyRadiance(dir);
        for (int k = 0; k < 3; ++k) out[size_t(k)] += beta[size_t(k)] * L;
        break;
      }
      p = p + d * tHit;
    }
    return out;
  }
};

}  // namespace
}  // namespace vellum::render::detail

namespace vellum::render {

using namespace detail;

PathSums detail::pathTraceCpu(const AnyVolume& volume, const RenderSettings& settings, const BackwardMap* map,
                              const LabelTint* tint) {
  checkImageSize(settings.width, settings.height);
  if (settings.preset == Preset::Mip) throw Error("cinematic quality needs a DVR preset (not mip)");
  const Geometry& g = geometryOf(volume);
  g.validate("render volume");
  PathSums sums;
  sums.width = settings.width;
  sums.height = settings.height;
  sums.samples = settings.cinematic.samples;
  sums.rgba.assign(size_t(sums.width) * size_t(sums.height) * 4, 0.f);
  std::visit(
      [&](const auto& vol) {
        using T = typename std::decay_t<decltype(vol)>::value_type;
        CpuTracer<T> tr(vol, settings, makeFrame(g, map ? &map->grid : nullptr, settings));
        tr.tf = buildTfTable(settings, tr.f.stepMm);
        tr.normals = gradientNormals(volume);
        tr.lights = makePathLights(tr.f, settings);
        if (map) tr.prepared = prepareMap(*map, g);
        if (settings.cinematic.volumeShadows)
          tr.light = computeLightVolume(lightSourceFor(volume, map, tr.prepared), tr.tf, tr.f.stepMm, tr.lights.key,
                                        settings.lighting, settings.cinematic.lightSizeDeg);
        if (tint && settings.labelBlend > 0) {
          if (!(tint->ids.dims() == g.dims)) throw Error("label tint: label map does not match the volume");
          tr.tint = tint;
        }
        if (map) {
          // One majorant for the whole map grid (delta tracking is unbiased for any bound; the
          // GL path bounds per map cell).
          tr.map = map;
          const BlockRanges ranges = computeBlockRanges(volume);
          const std::vector<float> block = blockMajorants(ranges, tr.tf, tr.f.stepMm);
          float scale = 1;
          for (size_t i = 3; i < map->attributes.size(); i += 4) scale = std::max(scale, map->attributes[i]);
          tr.majorant = {*std::max_element(block.begin(), block.end()) * scale};
          tr.blocks = {1, 1, 1};
          tr.blockSize = 1e9;
        } else {
          const BlockRanges ranges = computeBlockRanges(volume);
          tr.majorant = blockMajorants(ranges, tr.tf, tr.f.stepMm);
          tr.blocks = ranges.blocks;
        }
        parallelFor(settings.height, [&](int64_t y0, int64_t y1) {
          for (int64_t y = y0; y < y1; ++y)
            for (int x = 0; x < settings.width; ++x) {
              float* px = sums.rgba.data() + 4 * (size_t(y) * size_t(settings.width) + size_t(x));
              for (int smp = 0; smp < sums.samples; ++smp) {
                const auto r = tr.path(x, int(y), uint32_t(smp));
                for (int k = 0; k < 4; ++k) px[k] += r[size_t(k)];
              }
            }
        });
      },
      volume);
  return sums;
}

RgbaImage renderPathTracedCpu(const AnyVolume& volume, const RenderSettings& settings, const BackwardMap* map,
                              const LabelTint* tint) {
  RgbaImage guide;
  if (settings.cinematic.denoise > 0) guide = renderReferenceCpu(volume, denoiseGuideSettings(settings), map);
  return finishPathTraced(pathTraceCpu(volume, tracedSettings(settings), map, tint), settings, &guide);
}

}  // namespace vellum::render
