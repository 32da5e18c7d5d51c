// The shared lights and tone map (lights.hpp); GLSL twin: shaders/lights.glsl.
#include "lights.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "light_volume.hpp"

namespace vellum::render::detail {

SceneLights makeSceneLights(const Frame& f, const RenderSettings& s) {
  const Cinematic& c = s.cinematic;
  SceneLights l;
  l.key = keyLightDirection(f, s.lighting);
  Lighting fill = s.lighting;  // the key's azimuth mirrored to the other side of the view, low
  fill.azimuthDeg = -s.lighting.azimuthDeg;
  fill.elevationDeg = kFillElevationDeg;
  l.fill = keyLightDirection(f, fill);
  l.up = f.up;
  l.keyCos = float(std::cos(c.lightSizeDeg * std::numbers::pi / 180));
  l.keyE = kKeyIrradiance;
  l.fillE = float(kKeyIrradiance * c.fillLight);
  l.sky = float(c.skyLight);
  l.exposure = float(std::exp2(s.lighting.exposure));
  return l;
}

float toneMap(float x) {
  x *= 0.6f;
  const float a = std::clamp(x * (2.51f * x + 0.03f) / (x * (2.43f * x + 0.59f) + 0.14f), 0.f, 1.f);
  return a <= 0.0031308f ? 12.92f * a : 1.055f * std::pow(a, 1.f / 2.4f) - 0.055f;
}

float srgbToLinear(float c) { return std::pow(std::clamp(c, 0.f, 1.f), 2.2f); }

namespace {
float hg(double cosT) {
  const double g = kPhaseG, den = 1 + g * g - 2 * g * cosT;
  return float((1 - g * g) / (4 * std::numbers::pi * den * std::sqrt(den)));
}
}  // namespace

std::array<float, 3> sceneRadiance(const SceneLights& l, const std::array<float, 3>& albedo, Vec3 n, float w,
                                   const Vec3& v, float T, float A) {
  const double len = norm(n);
  n = len > 1e-4 ? n * (1 / len) : v;
  if (dot(n, v) < 0) n = n * -1.0;
  const double inv = 1 / std::numbers::pi;
  const double key = std::max(dot(n, l.key), 0.0), fill = std::max(dot(n, l.fill), 0.0);
  const double surf = l.keyE * inv * key * T + l.fillE * inv * fill + l.sky * (0.75 + 0.25 * dot(n, l.up)) * A;
  const Vec3 hv = l.key + v;
  const Vec3 h = hv * (1 / std::max(norm(hv), 1e-9));
  const double spec = kSpecular * (kShininess + 8) / (8 * std::numbers::pi) * std::pow(std::max(dot(n, h), 0.0), double(kShininess)) *
                      key * l.keyE * T;
  const Vec3 prop = v * -1.0;  // the eye ray's propagation direction
  const double medium = l.keyE * hg(dot(prop, l.key)) * T + l.fillE * hg(dot(prop, l.fill)) + l.sky * A;
  std::array<float, 3> out{};
  for (int k = 0; k < 3; ++k)
    out[size_t(k)] = float((1 - w) * albedo[size_t(k)] * medium + w * (albedo[size_t(k)] * surf + spec));
  return out;
}

}  // namespace vellum::render::detail
