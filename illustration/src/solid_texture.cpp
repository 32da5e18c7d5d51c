// Value-noise based solid textures: the CPU reference of ../shaders/solid_texture.glsl, held to
// it by IllustrationGl.EveryProceduralTextureMatchesCpu.
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

float solidTextureAt(SolidTexture kind, float x, float y, float z) {
  switch (kind) {
    case SolidTexture::Noise:
      return fbm(x, y, z);
    case SolidTexture::Marble:  // marble: veins along x, bent by turbulence
      return 0.5f + 0.5f * std::sin((x + 2.5f * fbm(0.5f * x, 0.5f * y, 0.5f * z)) * kPi);
    case SolidTexture::Wood: {  // wood: rings about the z axis, perturbed
      const float r = std::sqrt(x * x + y * y) + 0.6f * fbm(0.3f * x, 0.3f * y, 0.3f * z);
      return std::pow(0.5f + 0.5f * std::sin(2.f * kPi * r), 3.f);
    }
    case SolidTexture::Stripes:  // stripes across z, soft edges against aliasing
      return smoothstep(-0.25f, 0.25f, std::sin(2.f * kPi * z));
    case SolidTexture::Stipple: {  // stipple: one jittered dot in 70% of the unit cells
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

}  // namespace vellum::illustration::detail
