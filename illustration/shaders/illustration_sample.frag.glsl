// Illustration ray caster, part 1: uniforms and the per-sample style model styled() (its CPU
// reference: styledSample() in illustration_renderer_common.cpp); then modules/render's
// ray_common.glsl and illustration_main.frag.glsl. illustrationFragmentSource() prepends
// #version, the variant's #defines (EIGHT/NEAREST, NSLOTS, NGROUPS, USE_CT, USE_TEXTURE, USE_TEXVOL), the
// constants, the style layout (STYLE_* accessors and enum constants, style_layout.hpp) and
// solid_texture.glsl.
layout(location = 0) out vec4 fragColor;

uniform vec2 uViewport;
uniform vec3 uEye, uRight, uUp, uForward;
uniform vec2 uHalf;
uniform float uPersp;
uniform mat3 uPhysToBox, uBoxToPhys;
uniform vec3 uBoxOrigin, uBoxDims;
uniform float uStep, uJitter;
uniform vec4 uBackground;
uniform vec3 uLight, uCentre;
uniform float uRadius, uCoverageH;
uniform vec2 uPixMm;           // pixel size in mm at ray parameter t: x + y * t
uniform sampler3D uFields;     // per-segment distances, RGBA16_SNORM, groups of 4 stacked in z
uniform vec4 uSlots[SLOT_CAP];  // (id, shell id, shell mm, 0) in paint order
uniform mat3 uGradToPhys;      // index-space gradient -> physical
uniform vec4 uGradLo[NGROUPS], uGradHi[NGROUPS];  // where each slot's gradient matters
uniform vec4 uSkipOut[NGROUPS], uSkipIn[NGROUPS];  // adaptive step: skipBands()
uniform float uSkipOn;
uniform vec3 uHatchAxis[3];     // hatching planes' normals (physical), SampleFrame::hatchAxis
uniform float uHatchPixMm;
uniform float uCreaseProbeMm;  // SampleFrame::creaseProbeMm
uniform sampler2D uStyle;      // STYLE_ROW_TEXELS x 256: read with the STYLE_* macros
uniform sampler3D uOccupancy;
uniform ivec3 uBlocks;
#ifdef USE_CT
uniform sampler3D uCt;         // grad CT (physical, HU/mm), CT
uniform sampler1D uTf;
uniform float uTfLo, uTfHi;
#endif
#ifdef USE_TEXVOL
uniform sampler3D uTexVol;
uniform vec3 uTexDims;
#endif

struct Row { vec4 t[STYLE_ROW_TEXELS]; };
Row loadRow(int label) {
  Row r;
  for (int i = 0; i < STYLE_ROW_TEXELS; ++i) r.t[i] = texelFetch(uStyle, ivec2(i, label), 0);
  return r;
}

vec3 normOrZero(vec3 v, out float len) {
  len = length(v);
  return len > 1e-6 ? v / len : vec3(0.0);
}

// The solid texture value depends on the row and the sample position only: computed once
// per sample and row (not per voxel corner).
float texValue(Row r, vec3 pMm) {
  float tv = 0.0;
#if defined(USE_TEXTURE) || defined(USE_TEXVOL)
  int kind = STYLE_TEXTURE(r);
  if (STYLE_LAMBDA_TEXTURE(r) > 0.0 && kind != TEXTURE_NONE) {
    float s = 1.0 / STYLE_TEXTURE_SCALE_MM(r);
#ifdef USE_TEXVOL
    if (kind == TEXTURE_VOLUME) tv = textureLod(uTexVol, (pMm * s) / uTexDims, 0.0).r;  // non-uniform flow: no implicit LOD
#endif
#ifdef USE_TEXTURE
    if (kind != TEXTURE_VOLUME) tv = solidTexture(kind, pMm * s);
#endif
  }
#endif
  return tv;
}

vec4 styled(Row r, int label, vec4 g4, vec4 ct4, float tv, float depth, vec3 view, vec3 H) {
  float glen;
  vec3 n = normOrZero(g4.xyz, glen);
  float d = g4.w;
#ifdef DIAG_NORMALS
  // Diagnosis (VELLUM_GL_DIAG=normals): the gradient as an opaque colour.
  if (any(isnan(g4)) || any(isinf(g4))) return vec4(1.0, 0.0, 1.0, 1.0);
  if (!(glen > 0.0)) return vec4(0.0, 0.0, 0.0, 1.0);
  if (!(glen > 1e-6)) return vec4(0.0, 1.0, 0.0, 1.0);
  return vec4(0.5 + 0.5 * n, 1.0);
#endif
  // Opacity modulation first: where it is 0 (e.g. boundary k_c = 0 away from surfaces) the
  // sample is transparent whatever its colour, so nothing else is computed.
  float b;
#ifdef USE_CT
  if (STYLE_BOUNDARY_MEASURE(r) == BOUNDARY_MEASURE_CT)
    b = clamp(length(ct4.xyz) / STYLE_CT_GRADIENT_SCALE(r), 0.0, 1.0);
  else
#endif
  b = clamp(1.0 - abs(d) / STYLE_BOUNDARY_WIDTH_MM(r), 0.0, 1.0);
  // Deep inside a segment the distance gradient only shows the medial axis (creases where the
  // nearest boundary point jumps): normal-based terms fade to neutral from 2 to 4 boundary
  // widths inside, so translucent segments show their surface shading, not an X of creases.
  float sw = 1.0 - smoothstep(2.0 * STYLE_BOUNDARY_WIDTH_MM(r), 4.0 * STYLE_BOUNDARY_WIDTH_MM(r), abs(d));
#ifdef DIAG_TERMS
  // Diagnosis (VELLUM_GL_DIAG=terms): red = the normal terms' weight sw, green = |gradient|
  // (1 at unit length), blue = |d| over 4 boundary widths.
  return vec4(sw, clamp(glen, 0.0, 1.0), clamp(abs(d) / (4.0 * STYLE_BOUNDARY_WIDTH_MM(r)), 0.0, 1.0), 1.0);
#endif
  float ndv = glen > 1e-6 ? mix(1.0, abs(dot(n, view)), sw) : 1.0;
  float mb = STYLE_BOUNDARY_KC(r), ms = STYLE_SILHOUETTE_KC(r);
  if (STYLE_BOUNDARY_KS(r) > 0.0) mb += STYLE_BOUNDARY_KS(r) * pow(b, STYLE_BOUNDARY_KE(r));
  if (STYLE_SILHOUETTE_KS(r) > 0.0) ms += STYLE_SILHOUETTE_KS(r) * pow(max(1.0 - ndv, 0.0), STYLE_SILHOUETTE_KE(r));
  float m = mb * ms;
  if (!(m > 0.0)) return vec4(0.0);
  float ndl = sw * dot(n, uLight);
  vec3 col = STYLE_COLOUR(r);
  float k = (1.0 + ndl) * 0.5;
  vec3 tone = clamp(k * (STYLE_TONE_WARM(r) + STYLE_TONE_BETA(r) * col) +
                        (1.0 - k) * (STYLE_TONE_COOL(r) + STYLE_TONE_ALPHA(r) * col), 0.0, 1.0);
  // Tone key: divide by the value at the key's n.l, so that lit mid-tones show the colour.
  float key = STYLE_TONE_KEY(r);
  if (key > 0.0) {
    float kk = (1.0 + key) * 0.5;
    vec3 at = clamp(kk * (STYLE_TONE_WARM(r) + STYLE_TONE_BETA(r) * col) +
                        (1.0 - kk) * (STYLE_TONE_COOL(r) + STYLE_TONE_ALPHA(r) * col), 0.0, 1.0);
    tone = clamp(tone * col / max(at, vec3(1e-3)), 0.0, 1.0);
  }
  vec3 cc = col + STYLE_TONE_AMOUNT(r) * (tone - col);
  float start = STYLE_DEPTH_START(r), end = STYLE_DEPTH_END(r);
  float dimW = STYLE_DEPTH_STRENGTH(r) * clamp((depth - start) / max(end - start, 1e-4), 0.0, 1.0);
  cc = cc + dimW * (STYLE_DEPTH_COLOUR(r) - cc);
  float lit = (STYLE_AMBIENT(r) + STYLE_DIFFUSE(r) * max(ndl, 0.0)) /
              (key > 0.0 ? max(STYLE_AMBIENT(r) + STYLE_DIFFUSE(r) * key, 1e-3) : 1.0);
  float aSeg = STYLE_OPACITY(r);

  vec3 c1 = vec3(0.0);
  float a1 = 0.0;
  if (STYLE_LAMBDA_ILLUM(r) > 0.0) {
#ifdef USE_CT
  if (STYLE_ILLUM(r) == ILLUM_CT) {
    float x = clamp((ct4.w - uTfLo) / (uTfHi - uTfLo), 0.0, 1.0) * float(TF_SIZE - 1);
    int i = min(int(x), TF_SIZE - 2);
    vec4 tf = mix(texelFetch(uTf, i, 0), texelFetch(uTf, i + 1, 0), x - float(i));
    float cl;
    vec3 cn = normOrZero(ct4.xyz, cl);
    float cdl = abs(dot(cn, uLight));
    float spec = cl > 1e-6 ? STYLE_SPECULAR(r) * pow(abs(dot(cn, H)), STYLE_SHININESS(r)) : 0.0;
    c1 = min(tf.rgb * (STYLE_AMBIENT(r) + STYLE_DIFFUSE(r) * cdl) + spec, vec3(1.0));
    a1 = tf.a;
  } else
#endif
  {
    float spec = glen > 1e-6 ? sw * STYLE_SPECULAR(r) * pow(max(dot(n, H), 0.0), STYLE_SHININESS(r)) : 0.0;
    c1 = min(col * lit + spec, vec3(1.0));
    a1 = aSeg;
  }
  }

  vec3 c3 = vec3(0.0);
#if defined(USE_TEXTURE) || defined(USE_TEXVOL)
  if (STYLE_LAMBDA_TEXTURE(r) > 0.0 && STYLE_TEXTURE(r) != TEXTURE_NONE) {
    vec3 t1 = STYLE_TEXTURE_COLOUR1(r), t2 = STYLE_TEXTURE_COLOUR2(r);
    c3 = min((t1 + tv * (t2 - t1)) * lit, vec3(1.0));
  }
#endif

  float l1 = STYLE_LAMBDA_ILLUM(r), l2 = STYLE_LAMBDA_COLOURING(r), l3 = STYLE_LAMBDA_TEXTURE(r);
  vec3 rgb = l1 * a1 * c1 + l2 * aSeg * cc + l3 * aSeg * c3;
  float a = l1 * a1 + l2 * aSeg + l3 * aSeg;
  if (!(a > 0.0)) return vec4(0.0);
  float am = min(a * m, 1.0);
  return vec4(rgb * (am / a), am);
}

// Ink (CPU reference: inkVertex(), inkLine() and inkHatch() in illustration_renderer_common.cpp).
float inkVertex(float a, float b, float c) {
  float curv = a - 2.0 * b + c;
  return curv > 1e-7 ? clamp(0.5 * (a - c) / curv, -1.0, 1.0) : 0.0;
}
float inkLine(float a, float b, float c, float widthPx, float pixMm) {
  float m = b + 0.25 * (c - a) * inkVertex(a, b, c);
  return clamp((0.5 * widthPx * pixMm - abs(m)) / pixMm + 0.5, 0.0, 1.0);
}
// Silhouettes of features under two voxels round fade (inkFeatureFade() on the CPU).
float inkFeatureFade(float dm, float m, float dp, float voxelMm) {
  float curv = dm - 2.0 * m + dp;
  if (!(curv > 0.0)) return 1.0;
  float radiusMm = voxelMm * voxelMm / curv;
  return clamp(radiusMm / voxelMm - 1.0, 0.0, 1.0);
}
float inkHatch(float ndl, vec3 pMm, vec3 n, float spacingPx, float widthPx) {
  float ink = 0.0;
  for (int layer = 0; layer < 3; ++layer) {
    float th = layer == 0 ? 0.6 : layer == 1 ? 0.25 : -0.2;
    float w = widthPx * clamp((th - ndl) / 0.25, 0.0, 1.0);
    if (!(w > 0.0)) break;
    vec3 a = uHatchAxis[layer];
    float u = dot(pMm, a) / uHatchPixMm;
    float c = abs(dot(n, a));
    float fade = clamp((sqrt(max(1.0 - c * c, 0.0)) - 0.25) / 0.3, 0.0, 1.0);
    float f = u / spacingPx - floor(u / spacingPx);
    float dist = abs(f - 0.5) * spacingPx;
    float cov = clamp(0.5 * w - dist + 0.5, 0.0, 1.0) * min(w, 1.0) * fade;
    ink = ink + cov - ink * cov;
  }
  return ink;
}
// Premultiplied ink put in front of what was composited after `at` (acc = at over X).
vec4 inkUnder(vec4 acc, vec4 at, vec4 ink) {
  float r = 1.0 - at.a;
  vec4 x = r > 1e-6 ? (acc - at) / r : vec4(0.0);
  return at + r * (ink + (1.0 - ink.a) * x);
}
