// The scene lights and the tone map, shared by the ray caster (TONE_MAP) and the path tracer:
// twin of lights.hpp / lights.cpp (same names, same constants), held to it by the RenderGl
// tests that compare GL with the CPU reference.
uniform vec3 uKeyDir, uFillDir, uSkyUp;   // physical, towards the lights; the view's up
uniform float uKeyCos, uKeyE, uFillE, uSky;

const float PI = 3.14159265;

float hgPhase(float cosT) {
  float g = PHASE_G, den = 1.0 + g * g - 2.0 * g * cosT;
  return (1.0 - g * g) / (4.0 * PI * den * sqrt(den));
}
float skyRadiance(vec3 w) { return uSky * (0.75 + 0.25 * dot(w, uSkyUp)); }
vec3 srgbToLinear(vec3 c) { return pow(clamp(c, 0.0, 1.0), vec3(2.2)); }

// ACES filmic (Narkowicz's fit, input pre-scaled by 0.6), then sRGB.
vec3 toneMap(vec3 x) {
  x *= 0.6;
  vec3 a = clamp(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
  return mix(1.055 * pow(a, vec3(1.0 / 2.4)) - 0.055, 12.92 * a, lessThanEqual(a, vec3(0.0031308)));
}

// Lambert + normalised Blinn-Phong under the key (transmittance T), the fill and the sky
// (openness A), blended by the gradient strength w with an isotropic-ish medium (HG phase).
vec3 sceneRadiance(vec3 albedo, vec3 n, float w, vec3 v, float T, float A) {
  float len = length(n);
  n = len > 1e-4 ? n / len : v;
  if (dot(n, v) < 0.0) n = -n;
  float key = max(dot(n, uKeyDir), 0.0), fill = max(dot(n, uFillDir), 0.0);
  float surf = uKeyE / PI * key * T + uFillE / PI * fill + uSky * (0.75 + 0.25 * dot(n, uSkyUp)) * A;
  vec3 h = normalize(uKeyDir + v);
  float spec = SPECULAR * (SHININESS + 8.0) / (8.0 * PI) * pow(max(dot(n, h), 0.0), SHININESS) * key * uKeyE * T;
  float medium = uKeyE * hgPhase(dot(-v, uKeyDir)) * T + uFillE * hgPhase(dot(-v, uFillDir)) + uSky * A;
  return (1.0 - w) * albedo * medium + w * (albedo * surf + spec);
}
