#include "illustration_renderer_shader.hpp"

#include <sstream>

#include "illustration_renderer_common.hpp"
#include "shader_source.hpp"  // modules/render: the shared ray set-up GLSL
#include "solid_texture.hpp"

namespace vellum::illustration::detail {
namespace {

// Mirrors styledSample() (illustration_renderer_common.cpp) and the loop of
// illustration_renderer_cpu.cpp; change them together. Ray set-up as modules/render.
constexpr const char* kMain = R"GLSL(
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
uniform usampler3D uLabels;
uniform sampler3D uGrad;       // grad d (physical), d
uniform sampler2D uStyle;      // ROW_TEXELS x 256
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

struct Row { vec4 t[ROW_TEXELS]; };
Row loadRow(int label) {
  Row r;
  for (int i = 0; i < ROW_TEXELS; ++i) r.t[i] = texelFetch(uStyle, ivec2(i, label), 0);
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
  int kind = int(r.t[5].w + 0.5);
  if (r.t[1].z > 0.0 && kind > 0) {
    float s = 1.0 / r.t[6].w;
#ifdef USE_TEXVOL
    if (kind == 6) tv = texture(uTexVol, (pMm * s) / uTexDims).r;
#endif
#ifdef USE_TEXTURE
    if (kind != 6) tv = solidTexture(kind, pMm * s);
#endif
  }
#endif
  return tv;
}

vec4 styled(Row r, int label, vec4 g4, vec4 ct4, float tv, float depth, vec3 view, vec3 H) {
  float glen;
  vec3 n = normOrZero(g4.xyz, glen);
  float d = g4.w;
  // Opacity modulation first: where it is 0 (e.g. boundary k_c = 0 away from surfaces) the
  // sample is transparent whatever its colour, so nothing else is computed.
  float b;
#ifdef USE_CT
  if (r.t[7].w > 0.5) b = clamp(length(ct4.xyz) / r.t[9].w, 0.0, 1.0);
  else
#endif
  b = clamp(1.0 - abs(d) / r.t[8].w, 0.0, 1.0);
  // Deep inside a segment the distance gradient only shows the medial axis (creases where the
  // nearest boundary point jumps): normal-based terms fade to neutral from 2 to 4 boundary
  // widths inside, so translucent segments show their surface shading, not an X of creases.
  float sw = 1.0 - smoothstep(2.0 * r.t[8].w, 4.0 * r.t[8].w, abs(d));
  float ndv = glen > 1e-6 ? mix(1.0, abs(dot(n, view)), sw) : 1.0;
  float mb = r.t[8].x, ms = r.t[9].x;
  if (r.t[8].y > 0.0) mb += r.t[8].y * pow(b, r.t[8].z);
  if (r.t[9].y > 0.0) ms += r.t[9].y * pow(max(1.0 - ndv, 0.0), r.t[9].z);
  float m = mb * ms;
  if (!(m > 0.0)) return vec4(0.0);
  float ndl = sw * dot(n, uLight);
  vec3 col = r.t[0].rgb;
  float k = (1.0 + ndl) * 0.5;
  vec3 tone = clamp(k * (r.t[2].rgb + r.t[2].w * col) + (1.0 - k) * (r.t[3].rgb + r.t[3].w * col), 0.0, 1.0);
  vec3 cc = col + r.t[5].z * (tone - col);
  float dimW = r.t[4].w * clamp((depth - r.t[5].x) / max(r.t[5].y - r.t[5].x, 1e-4), 0.0, 1.0);
  cc = cc + dimW * (r.t[4].rgb - cc);
  float lit = r.t[10].x + r.t[10].y * max(ndl, 0.0);
  float coverage = label > 0 ? clamp(0.5 - d / uCoverageH, 0.0, 1.0) : 1.0;
  float aSeg = r.t[0].w * coverage;

  vec3 c1 = vec3(0.0);
  float a1 = 0.0;
  if (r.t[1].x > 0.0) {
#ifdef USE_CT
  if (r.t[11].x > 0.5) {
    float x = clamp((ct4.w - uTfLo) / (uTfHi - uTfLo), 0.0, 1.0) * float(TF_SIZE - 1);
    int i = min(int(x), TF_SIZE - 2);
    vec4 tf = mix(texelFetch(uTf, i, 0), texelFetch(uTf, i + 1, 0), x - float(i));
    float cl;
    vec3 cn = normOrZero(ct4.xyz, cl);
    float cdl = abs(dot(cn, uLight));
    float spec = cl > 1e-6 ? r.t[10].z * pow(abs(dot(cn, H)), r.t[10].w) : 0.0;
    c1 = min(tf.rgb * (r.t[10].x + r.t[10].y * cdl) + spec, vec3(1.0));
    a1 = tf.a;
  } else
#endif
  {
    float spec = glen > 1e-6 ? sw * r.t[10].z * pow(max(dot(n, H), 0.0), r.t[10].w) : 0.0;
    c1 = min(col * lit + spec, vec3(1.0));
    a1 = aSeg;
  }
  }

  vec3 c3 = vec3(0.0);
#if defined(USE_TEXTURE) || defined(USE_TEXVOL)
  if (r.t[1].z > 0.0 && r.t[5].w > 0.5) c3 = min((r.t[6].rgb + tv * (r.t[7].rgb - r.t[6].rgb)) * lit, vec3(1.0));
#endif

  vec3 rgb = r.t[1].x * a1 * c1 + r.t[1].y * aSeg * cc + r.t[1].z * aSeg * c3;
  float a = r.t[1].x * a1 + r.t[1].y * aSeg + r.t[1].z * aSeg;
  if (!(a > 0.0)) return vec4(0.0);
  float am = min(a * m, 1.0);
  return vec4(rgb * (am / a), am);
}

)GLSL";

constexpr const char* kMainBody = R"GLSL(
void main() {
  FragmentRay ray = fragmentRay();
  vec3 origin = ray.origin, dir = ray.dir, o = ray.o, d = ray.d, inv = ray.inv;
  float tmin = ray.tmin, tmax = ray.tmax;
  vec3 view = -dir;
  vec3 H = normalize(uLight + view);
  bool zeroVisible = texelFetch(uStyle, ivec2(1, 0), 0).w > 0.5;
  float depth0 = dot(origin - uCentre, uForward), depthRate = dot(dir, uForward);
  ivec3 dims = ivec3(uBoxDims);

  vec4 acc = vec4(0.0);
  float jitter = uJitter * pixelJitter(uint(gl_FragCoord.x), uint(uViewport.y - gl_FragCoord.y));
  if (tmax >= tmin) {
    int k0 = int(ceil(tmin / uStep - jitter));
    int k1 = min(int(floor(tmax / uStep - jitter)), k0 + MAX_STEPS);
    int cur = -1;
    bool visible = false;
    ivec3 lastBlock = ivec3(-1);
    bool blockOccupied = false;
    Row r;
    for (int k = k0; k <= k1; ++k) {
      vec3 p = o + ((float(k) + jitter) * uStep) * d;
      ivec3 b = clamp(ivec3(floor(p / float(BLOCK_SIZE))), ivec3(0), uBlocks - 1);
      if (b != lastBlock) {  // one occupancy fetch per block entered, not per sample
        lastBlock = b;
        blockOccupied = texelFetch(uOccupancy, b, 0).r >= 0.5;
      }
      if (!blockOccupied) {
        vec3 lo = mix(vec3(b * BLOCK_SIZE), vec3(-2.0), equal(b, ivec3(0)));
        vec3 hi = mix(vec3((b + 1) * BLOCK_SIZE), uBoxDims + 2.0, equal(b, uBlocks - 1));
        // Sides chosen with nonZero()'s sign (a +0 component counts as positive), and the
        // step index clamped before int conversion: axis-aligned rays give +-1e12 here.
        vec3 tb = (mix(lo, hi, greaterThanEqual(d, vec3(0.0))) - o) * inv;
        float tExit = min(min(tb.x, tb.y), tb.z);
        float kExit = clamp(ceil(tExit / uStep - jitter), float(k), float(k1) + 1.0);
        k = max(k, int(kExit) - 1);
        continue;
      }
      float t = (float(k) + jitter) * uStep;
      vec3 pMm = origin + t * dir;
      float depth = (depth0 + t * depthRate) / (2.0 * uRadius) + 0.5;
      vec4 ct4 = vec4(0.0);
#ifdef EIGHT
      vec3 fl = floor(p);
      ivec3 i0 = ivec3(fl);
      vec3 tt = p - fl;
      vec4 sum = vec4(0.0);
      int tvLab = -1;
      float tv = 0.0;
      int labs[8];
      bool anyZero = false;
      for (int c = 0; c < 8; ++c) {
        ivec3 v = i0 + ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
        bool inside = all(greaterThanEqual(v, ivec3(0))) && all(lessThan(v, dims));
        labs[c] = inside ? int(texelFetch(uLabels, v, 0).r) : -1;
        anyZero = anyZero || labs[c] == 0;
      }
      // Outer surfaces: unclassified corners just outside a segment (0 < d) take the style of
      // the heaviest visible segment corner, so that its coverage clamp(0.5 - d/h) follows the
      // smooth zero level of d instead of the voxel staircase. Ids themselves are never mixed.
      int dom = -1;
      if (anyZero && !zeroVisible) {
        float domW = 0.0;
        for (int c = 0; c < 8; ++c) {
          if (labs[c] <= 0 || texelFetch(uStyle, ivec2(1, labs[c]), 0).w < 0.5) continue;
          vec3 wv = mix(1.0 - tt, tt, vec3(ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1)));
          float w = wv.x * wv.y * wv.z;
          if (w > domW) {
            domW = w;
            dom = labs[c];
          }
        }
      }
      for (int c = 0; c < 8; ++c) {
        ivec3 cc = ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
        ivec3 v = i0 + cc;
        int lab = labs[c];
        if (lab < 0) continue;
        vec4 g4 = texelFetch(uGrad, v, 0);
        if (lab == 0 && dom > 0 && g4.w > 0.0) lab = dom;
        if (lab != cur) {  // visibility first: invisible rows are never loaded
          cur = lab;
          visible = texelFetch(uStyle, ivec2(1, lab), 0).w > 0.5;
          if (visible) r = loadRow(lab);
        }
        if (!visible) continue;
        vec3 wv = mix(1.0 - tt, tt, vec3(cc));
        float w = wv.x * wv.y * wv.z;
#ifdef USE_CT
        ct4 = texelFetch(uCt, v, 0);
#endif
        if (lab != tvLab) {
          tv = texValue(r, pMm);
          tvLab = lab;
        }
        sum += w * styled(r, lab, g4, ct4, tv, depth, view, H);
      }
#else
      // The cell's lowest corner says whether the 2x2x2 cell carries one label: then that is
      // the nearest label too, and one filtered fetch interpolates the inputs. Otherwise the
      // nearest voxel's label, with distance and gradient interpolated over the corners that
      // carry it only (the gradient points out of each segment: mixing would flip it).
      vec3 fl = floor(p);
      ivec3 i0 = ivec3(fl);
      uvec2 cell = texelFetch(uLabels, clamp(i0, ivec3(0), dims - 1), 0).rg;
      bool uniformCell = cell.g > 0u && all(greaterThanEqual(i0, ivec3(0)));
      int lab = uniformCell ? int(cell.r)
                            : int(texelFetch(uLabels, clamp(ivec3(floor(p + 0.5)), ivec3(0), dims - 1), 0).r);
      if (lab != cur) {
        cur = lab;
        visible = texelFetch(uStyle, ivec2(1, lab), 0).w > 0.5;
        if (visible) r = loadRow(lab);
      }
      if (!visible) continue;
      vec3 tc = (p + 0.5) / uBoxDims;
#ifdef USE_CT
      ct4 = texture(uCt, tc);
#endif
      vec3 tt = p - fl;
      vec4 g4 = vec4(0.0);
      float wsum = 0.0;
      if (uniformCell) {
        g4 = texture(uGrad, tc);
        wsum = 1.0;
      } else for (int c = 0; c < 8; ++c) {
        ivec3 cc = ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
        ivec3 q = clamp(i0 + cc, ivec3(0), dims - 1);
        if (int(texelFetch(uLabels, q, 0).r) != lab) continue;
        vec3 wv = mix(1.0 - tt, tt, vec3(cc));
        float w = wv.x * wv.y * wv.z;
        g4 += w * texelFetch(uGrad, q, 0);
        wsum += w;
      }
      g4 /= wsum;
      vec4 sum = styled(r, lab, g4, ct4, texValue(r, pMm), depth, view, H);
#endif
      if (sum.a > 0.0) {
        vec3 rgb = sum.rgb / sum.a;
        float aStep = 1.0 - pow(max(1.0 - sum.a, 0.0), uStep);
        acc.rgb += (1.0 - acc.a) * aStep * rgb;
        acc.a += (1.0 - acc.a) * aStep;
        if (acc.a >= EARLY_ALPHA) break;
      }
    }
  }
  vec4 outc = acc + (1.0 - acc.a) * vec4(uBackground.rgb * uBackground.a, uBackground.a);
  fragColor = outc.a > 0.0 ? vec4(min(outc.rgb / outc.a, vec3(1.0)), outc.a) : vec4(0.0);
}
)GLSL";

}  // namespace

std::string illustrationFragmentSource(const ShaderVariant& v) {
  std::ostringstream s;
  s << "#version 450 core\n";
  s << (v.eight ? "#define EIGHT\n" : "#define NEAREST\n");
  if (v.ct) s << "#define USE_CT\n";
  if (v.texture) s << "#define USE_TEXTURE\n";
  if (v.textureVolume) s << "#define USE_TEXVOL\n";
  s << "#define ROW_TEXELS " << kRowTexels << "\n#define TF_SIZE " << kTfSize << "\n";
  s << "#define BLOCK_SIZE " << kBlock << "\n#define MAX_STEPS " << (1 << 16) << "\n";
  s << "#define EARLY_ALPHA " << kEarlyAlpha << "\n";
  if (v.texture) s << solidTextureGlsl();
  s << kMain << render::detail::rayCommonGlsl() << kMainBody;
  return s.str();
}

}  // namespace vellum::illustration::detail
