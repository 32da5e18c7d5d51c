// Value-noise based solid textures. Mirrored in kGlsl below; change both together.
#include "solid_texture.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace vellum::illustration::detail {
namespace {

float hash3(int x, int y, int z) {
  uint32_t h = static_cast<uint32_t>(x) * 73856093u ^ static_cast<uint32_t>(y) * 19349663u ^
               static_cast<uint32_t>(z) * 83492791u;
  h = (h ^ (h >> 13)) * 0x5bd1e995u;
  h ^= h >> 15;
  return static_cast<float>(h & 0xffffffu) * (1.f / 16777216.f);
}

float fade(float t) { return t * t * (3.f - 2.f * t); }

float valueNoise(float x, float y, float z) {
  const float fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
  const int ix = int(fx), iy = int(fy), iz = int(fz);
  const float tx = fade(x - fx), ty = fade(y - fy), tz = fade(z - fz);
  auto lerp = [](float a, float b, float t) { return a + t * (b - a); };
  const float c00 = lerp(hash3(ix, iy, iz), hash3(ix + 1, iy, iz), tx);
  const float c10 = lerp(hash3(ix, iy + 1, iz), hash3(ix + 1, iy + 1, iz), tx);
  const float c01 = lerp(hash3(ix, iy, iz + 1), hash3(ix + 1, iy, iz + 1), tx);
  const float c11 = lerp(hash3(ix, iy + 1, iz + 1), hash3(ix + 1, iy + 1, iz + 1), tx);
  return lerp(lerp(c00, c10, ty), lerp(c01, c11, ty), tz);
}

float fbm(float x, float y, float z) {
  return (0.5f * valueNoise(x, y, z) + 0.25f * valueNoise(2 * x, 2 * y, 2 * z) +
          0.125f * valueNoise(4 * x, 4 * y, 4 * z)) * (1.f / 0.875f);
}

float smoothstep(float e0, float e1, float x) {
  const float t = std::clamp((x - e0) / (e1 - e0), 0.f, 1.f);
  return t * t * (3.f - 2.f * t);
}

constexpr float kPi = 3.14159265f;

}  // namespace

float solidTextureAt(int kind, float x, float y, float z) {
  switch (kind) {
    case 1:
      return fbm(x, y, z);
    case 2:  // marble: veins along x, bent by turbulence
      return 0.5f + 0.5f * std::sin((x + 2.5f * fbm(0.5f * x, 0.5f * y, 0.5f * z)) * kPi);
    case 3: {  // wood: rings about the z axis, perturbed
      const float r = std::sqrt(x * x + y * y) + 0.6f * fbm(0.3f * x, 0.3f * y, 0.3f * z);
      return std::pow(0.5f + 0.5f * std::sin(2.f * kPi * r), 3.f);
    }
    case 4:  // stripes across z, soft edges against aliasing
      return smoothstep(-0.25f, 0.25f, std::sin(2.f * kPi * z));
    case 5: {  // stipple: one jittered dot in 70% of the unit cells
      const float cx = std::floor(x), cy = std::floor(y), cz = std::floor(z);
      const int ix = int(cx), iy = int(cy), iz = int(cz);
      if (hash3(ix + 7, iy + 13, iz + 29) > 0.7f) return 0.f;
      const float dx = x - (cx + 0.3f + 0.4f * hash3(ix, iy, iz));
      const float dy = y - (cy + 0.3f + 0.4f * hash3(iy, iz, ix));
      const float dz = z - (cz + 0.3f + 0.4f * hash3(iz, ix, iy));
      return 1.f - smoothstep(0.16f, 0.24f, std::sqrt(dx * dx + dy * dy + dz * dz));
    }
    default:
      return 0.f;
  }
}

std::string solidTextureGlsl() {
  return R"GLSL(
float hash3(int x, int y, int z) {
  uint h = uint(x) * 73856093u ^ uint(y) * 19349663u ^ uint(z) * 83492791u;
  h = (h ^ (h >> 13)) * 0x5bd1e995u;
  h ^= h >> 15;
  return float(h & 0xffffffu) * (1.0 / 16777216.0);
}
float fade1(float t) { return t * t * (3.0 - 2.0 * t); }
float valueNoise(vec3 p) {
  vec3 fl = floor(p);
  ivec3 i = ivec3(fl);
  vec3 t = vec3(fade1(p.x - fl.x), fade1(p.y - fl.y), fade1(p.z - fl.z));
  float c00 = mix(hash3(i.x, i.y, i.z), hash3(i.x + 1, i.y, i.z), t.x);
  float c10 = mix(hash3(i.x, i.y + 1, i.z), hash3(i.x + 1, i.y + 1, i.z), t.x);
  float c01 = mix(hash3(i.x, i.y, i.z + 1), hash3(i.x + 1, i.y, i.z + 1), t.x);
  float c11 = mix(hash3(i.x, i.y + 1, i.z + 1), hash3(i.x + 1, i.y + 1, i.z + 1), t.x);
  return mix(mix(c00, c10, t.y), mix(c01, c11, t.y), t.z);
}
float fbm(vec3 p) {
  return (0.5 * valueNoise(p) + 0.25 * valueNoise(2.0 * p) + 0.125 * valueNoise(4.0 * p)) * (1.0 / 0.875);
}
float solidTexture(int kind, vec3 q) {
  const float PI = 3.14159265;
  if (kind == 1) return fbm(q);
  if (kind == 2) return 0.5 + 0.5 * sin((q.x + 2.5 * fbm(0.5 * q)) * PI);
  if (kind == 3) {
    float r = sqrt(q.x * q.x + q.y * q.y) + 0.6 * fbm(0.3 * q);
    return pow(0.5 + 0.5 * sin(2.0 * PI * r), 3.0);
  }
  if (kind == 4) return smoothstep(-0.25, 0.25, sin(2.0 * PI * q.z));
  if (kind == 5) {
    vec3 c = floor(q);
    ivec3 i = ivec3(c);
    if (hash3(i.x + 7, i.y + 13, i.z + 29) > 0.7) return 0.0;
    vec3 dd = q - (c + 0.3 + 0.4 * vec3(hash3(i.x, i.y, i.z), hash3(i.y, i.z, i.x), hash3(i.z, i.x, i.y)));
    return 1.0 - smoothstep(0.16, 0.24, length(dd));
  }
  return 0.0;
}
)GLSL";
}

}  // namespace vellum::illustration::detail
