// Procedural solid textures; CPU twin: solidTextureAt() in solid_texture.cpp (same hash and
// formulas, so both agree to float rounding). Kinds: the TEXTURE_* constants of the style layout.
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
  if (kind == TEXTURE_NOISE) return fbm(q);
  if (kind == TEXTURE_MARBLE) return 0.5 + 0.5 * sin((q.x + 2.5 * fbm(0.5 * q)) * PI);
  if (kind == TEXTURE_WOOD) {
    float r = sqrt(q.x * q.x + q.y * q.y) + 0.6 * fbm(0.3 * q);
    return pow(0.5 + 0.5 * sin(2.0 * PI * r), 3.0);
  }
  if (kind == TEXTURE_STRIPES) return smoothstep(-0.25, 0.25, sin(2.0 * PI * q.z));
  if (kind == TEXTURE_STIPPLE) {
    vec3 c = floor(q);
    ivec3 i = ivec3(c);
    if (hash3(i.x + 7, i.y + 13, i.z + 29) > 0.7) return 0.0;
    vec3 dd = q - (c + 0.3 + 0.4 * vec3(hash3(i.x, i.y, i.z), hash3(i.y, i.z, i.x), hash3(i.z, i.x, i.y)));
    return 1.0 - smoothstep(0.16, 0.24, length(dd));
  }
  return 0.0;
}
