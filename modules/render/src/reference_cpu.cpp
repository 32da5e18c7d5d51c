// CPU reference ray caster: the shader of shader_source.cpp step for step, in C++.
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "label_colour.hpp"
#include "light_volume.hpp"
#include "lights.hpp"
#include "map_sampling.hpp"
#include "normal_volume.hpp"
#include "render_common.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/render/volume_renderer.hpp"

namespace vellum::render {

using namespace detail;

namespace {

struct Context {
  const RenderSettings& s;
  Frame frame;
  TfTable tf;
  GradientNormals normals;  ///< shading
  const BackwardMap* map = nullptr;
  PreparedMap prepared;  ///< the map in source index coordinates, with its snap
  const LabelTint* tint = nullptr;  ///< set when labels tint the samples
  const OpaqueLayer* opaque = nullptr;
  std::optional<LightVolume> light{};  ///< cinematic lighting (light_volume.hpp)
  Vec3 lightDir{};
  SceneLights scene{};  ///< lighting.toneMap: the path tracer's lights (lights.hpp)
};

std::array<float, 3> shade(const std::array<float, 3>& c, const std::array<float, 4>& n,
                           const Vec3& l) {
  const float len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  const float w = len > 1e-4f ? std::clamp((n[3] - kGradLow) / (kGradHigh - kGradLow), 0.f, 1.f) : 0.f;
  const float ndl = std::abs(float(n[0] * l.x + n[1] * l.y + n[2] * l.z)) / std::max(len, 1e-4f);
  const float spec = kSpecular * std::pow(ndl, kShininess);
  std::array<float, 3> out{};
  for (int k = 0; k < 3; ++k) {
    const float lit = std::min(c[k] * (kAmbient + kDiffuse * ndl) + spec, 1.f);
    out[k] = c[k] + w * (lit - c[k]);
  }
  return out;
}

/// Twin of shadeLit() in raycast.frag.glsl.
/// p: the box index (under a deformation the map's, whose output space the light volume lies in).
std::array<float, 3> shadeLit(const std::array<float, 3>& c, const std::array<float, 4>& n, const Vec3& v,
                              const Vec3& p, const Context& cx) {
  const auto lo = cx.light->sample(p + cx.light->towardsLight);
  const Lighting& l = cx.s.lighting;
  const float T = float(1 + l.shadows * (lo[0] - 1)), A = float(1 + l.occlusion * (lo[1] - 1));
  const float len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  const float w = len > 1e-4f ? std::clamp((n[3] - kGradLow) / (kGradHigh - kGradLow), 0.f, 1.f) : 0.f;
  Vec3 nn = len > 1e-4f ? Vec3{n[0] / len, n[1] / len, n[2] / len} : v;
  if (dot(nn, v) < 0) nn = nn * -1.0;
  const Vec3& L = cx.lightDir;
  const float key = float(std::max(dot(nn, L), 0.0)), head = float(std::max(dot(nn, v), 0.0));
  const Vec3 hv = L + v;
  const Vec3 h = hv * (1.0 / norm(hv));
  const float spec = kSpecular * std::pow(float(std::max(dot(nn, h), 0.0)), kShininess) * T;
  const float diffuse = kDiffuse * (kKeyLightShare * key * T + (1 - kKeyLightShare) * head);
  const float plain = kAmbient * A + kDiffuse * (kKeyLightShare * T + (1 - kKeyLightShare));
  const float exposure = float(std::exp2(l.exposure));
  std::array<float, 3> out{};
  for (int k = 0; k < 3; ++k) {
    const float lit = std::min((c[k] * (kAmbient * A + diffuse) + spec) * exposure, 1.f);
    const float flat = std::min(c[k] * plain * exposure, 1.f);
    out[k] = flat + w * (lit - flat);
  }
  return out;
}

template <class T>
void renderRows(const Volume<T>& vol, const Context& cx, RgbaImage& image, int y0, int y1) {
  const RenderSettings& s = cx.s;
  const Frame& f = cx.frame;
  const bool mip = s.preset == Preset::Mip;
  const bool hasAttributes = cx.map && !cx.map->attributes.empty();
  for (int y = y0; y < y1; ++y)
    for (int x = 0; x < s.width; ++x) {
      const Ray ray = pixelRay(f, x, y);
      Clip clip = clipRay(f, ray, s.jitter ? pixelJitter(x, y) : 0.0);
      // Opaque geometry ends the ray: samples at (k + jitter) step < its distance (the shader's rule).
      const double surfaceT = cx.opaque ? double(cx.opaque->distanceMm[size_t(y) * size_t(s.width) + size_t(x)])
                                        : std::numeric_limits<double>::infinity();
      const bool surface = std::isfinite(surfaceT);
      if (surface) clip.k1 = std::min(clip.k1, int64_t(std::ceil(surfaceT / f.stepMm - clip.jitter)) - 1);
      std::array<double, 4> acc{0, 0, 0, 0};
      double maxV = -std::numeric_limits<double>::infinity();
      bool hit = false;
      for (int64_t k = clip.k0; k <= clip.k1; ++k) {
        const Vec3 p = clip.o + clip.d * ((static_cast<double>(k) + clip.jitter) * f.stepMm);
        Vec3 u = p;
        double inside = 1.0;  // outside the output box the value fades to the background
        int snappedBody = -1;
        if (cx.map) {
          inside = cx.prepared.outputWeight(p);
          u = inside > 0 ? cx.prepared.at(p, &snappedBody)
                         : Vec3{PreparedMap::kOutside, PreparedMap::kOutside, PreparedMap::kOutside};
        }
        double v = vol.sampleLinear(u);
        if (inside < 1.0) v = vol.background() + inside * (v - vol.background());
        if (mip) {
          maxV = std::max(maxV, v);
          hit = true;
          continue;
        }
        std::array<float, 4> c = cx.tf.lookup(v);
        if (!(c[3] > 0)) continue;
        std::array<float, 3> rgb{c[0], c[1], c[2]};
        if (hasAttributes) {
          const auto a = sampleClamped<4>(cx.map->attributes, cx.map->grid.dims, p);
          rgb = labShift(rgb, a[0], a[1], a[2]);
          c[3] = 1.f - std::pow(std::max(1.f - c[3], 1e-6f), std::max(a[3], 0.f));
        }
        if (cx.tint) rgb = tintByLabels(rgb, u, vol, cx.tf, *cx.tint, float(s.labelBlend));
        if (s.shading) {
          std::array<float, 4> n = cx.normals.sample(vol, u);
          if (cx.map && s.turnDeformedNormals) n = cx.prepared.turnNormal(p, n, snappedBody);
          if (cx.light && s.lighting.toneMap) {  // linear radiance, tone mapped at the end (lights.hpp)
            const auto lo = cx.light->sample(p + cx.light->towardsLight);
            const float tKey = float(1 + s.lighting.shadows * (lo[0] - 1)), open = float(1 + s.lighting.occlusion * (lo[1] - 1));
            const float len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            const float w = len > 1e-4f ? std::clamp((n[3] - kGradLow) / (kGradHigh - kGradLow), 0.f, 1.f) : 0.f;
            rgb = sceneRadiance(cx.scene, {srgbToLinear(rgb[0]), srgbToLinear(rgb[1]), srgbToLinear(rgb[2])},
                                {n[0], n[1], n[2]}, w, ray.dir * -1.0, tKey, open);
          } else {
            rgb = cx.light ? shadeLit(rgb, n, ray.dir * -1.0, p, cx) : shade(rgb, n, -ray.dir);
          }
        }
        const double w = (1 - acc[3]) * c[3];
        for (int ch = 0; ch < 3; ++ch) acc[ch] += w * rgb[ch];
        acc[3] += w;
        if (acc[3] >= kEarlyTerminationAlpha) break;
      }
      if (cx.light && s.lighting.toneMap && acc[3] > 0)  // as finishPathTraced: straight radiance, exposed
        for (int ch = 0; ch < 3; ++ch) acc[ch] = double(toneMap(float(acc[ch] / acc[3]) * cx.scene.exposure)) * acc[3];
      if (mip && hit) {
        const double g = mipGrey(s, maxV);
        acc = {g, g, g, g};
      }
      std::array<double, 4> under{s.background[0], s.background[1], s.background[2], s.background[3]};
      if (surface) {
        const uint8_t* c = cx.opaque->colour.at(x, y);
        under = {c[0] / 255.0, c[1] / 255.0, c[2] / 255.0, 1.0};
      }
      const double bgA = under[3];
      std::array<double, 4> out{};
      for (int ch = 0; ch < 3; ++ch) out[ch] = acc[ch] + (1 - acc[3]) * under[ch] * bgA;
      out[3] = acc[3] + (1 - acc[3]) * bgA;
      uint8_t* px = image.at(x, y);
      for (int ch = 0; ch < 4; ++ch) {
        const double straight = ch == 3 ? out[3] : (out[3] > 0 ? std::min(out[ch] / out[3], 1.0) : 0.0);
        px[ch] = static_cast<uint8_t>(std::lround(std::clamp(straight, 0.0, 1.0) * 255.0));
      }
    }
}

}  // namespace

RgbaImage renderReferenceCpu(const AnyVolume& volume, const RenderSettings& settings,
                             const BackwardMap* map, const LabelTint* tint, const OpaqueLayer* opaque) {
  checkImageSize(settings.width, settings.height);
  const Geometry& g = geometryOf(volume);
  g.validate("render volume");
  Context cx{settings, makeFrame(g, map ? &map->grid : nullptr, settings), {}, {}, map, {}};
  if (map) cx.prepared = prepareMap(*map, g);
  if (settings.preset != Preset::Mip) {
    cx.tf = buildTfTable(settings, cx.frame.stepMm);
    if (settings.shading) cx.normals = gradientNormals(volume);
    if (settings.shading && settings.lighting.on()) {
      cx.lightDir = keyLightDirection(cx.frame, settings.lighting);
      cx.light = computeLightVolume(lightSourceFor(volume, map, cx.prepared), cx.tf, cx.frame.stepMm, cx.lightDir,
                                    settings.lighting, settings.lighting.toneMap ? settings.cinematic.lightSizeDeg : 0.0);
      cx.scene = makeSceneLights(cx.frame, settings);
    }
  }
  if (tint && settings.labelBlend > 0 && settings.preset != Preset::Mip) {
    if (!(tint->ids.dims() == g.dims)) throw Error("label tint: label map does not match the volume");
    cx.tint = tint;
  }
  if (opaque) {
    const size_t n = size_t(settings.width) * size_t(settings.height);
    if (opaque->colour.width != settings.width || opaque->colour.height != settings.height || opaque->distanceMm.size() != n)
      throw Error("opaque layer: colour and distances must be " + std::to_string(settings.width) + "x" +
                  std::to_string(settings.height));
    cx.opaque = opaque;
  }
  RgbaImage image(settings.width, settings.height);
  std::visit(
      [&](const auto& vol) {
        parallelFor(settings.height, [&](int64_t y0, int64_t y1) {
          renderRows(vol, cx, image, int(y0), int(y1));
        });
      },
      volume);
  return image;
}

}  // namespace vellum::render
