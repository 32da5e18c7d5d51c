// Cinematic path tracer, part 3 (after raycast.frag.glsl's uniforms and helpers and
// ray_common.glsl): uSamplesPerPass paths per pixel, summed into an RGBA32F target by additive
// blending (premultiplied radiance, coverage). CPU twin: CpuTracer in path_tracer.cpp, step for
// step; constants from path_tracer.hpp.
uniform sampler3D uMajorant;   // extinction majorant per mm, per block (or map cell)
uniform int uSampleBase, uSamplesPerPass;
uniform uint uSeed;
uniform float uPickKey;
uniform int uBounces;
uniform float uSurfaceOffset;  // mm

uint pcgHash(uint v) {
  uint state = v * 747796405u + 2891336453u;
  uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
  return (word >> 22u) ^ word;
}
uint gRng;
float rnd() {
  gRng = pcgHash(gRng);
  return float(gRng >> 8) * (1.0 / 16777216.0);
}

// Source position of box index p (deformed: through the map and the snap) and its value.
struct Point { vec3 u; float inside; int snapped; };
Point locate(vec3 p) {
  Point q;
  q.u = p;
  q.inside = 1.0;
  q.snapped = -1;
#ifdef DEFORMED
  q.u = deformedSource(p, q.snapped);
#ifdef OUTPUT_BOX
  vec3 xo = uOutScale * p + uOutOffset;
  vec3 wo = clamp(min(1.0 + xo, uOutDims - xo), 0.0, 1.0);
  q.inside = wo.x * wo.y * wo.z;
  if (q.inside <= 0.0) q.u = vec3(OUTSIDE);
#endif
#endif
  return q;
}
float valueOf(Point q) {
  float v = sampleValue(q.u);
#ifdef OUTPUT_BOX
  if (q.inside < 1.0) v = mix(sampleValue(vec3(OUTSIDE)), v, q.inside);
#endif
  return v;
}
float sigmaAt(vec3 p) {
  float s = -log(1.0 - min(tfLookup(valueOf(locate(p))).a, MAX_PATH_ALPHA)) / uStep;
#ifdef ATTRIBUTES
  s *= max(texture(uAttr, (p + 0.5) / uBoxDims).w, 0.0);
#endif
  return s;
}

// The block of o + t d and where the ray leaves it (the ray caster's skipping blocks).
float blockAt(vec3 o, vec3 d, float t, out float tExit) {
  vec3 p = o + t * d;
  ivec3 b = clamp(ivec3(floor(p / float(BLOCK_SIZE))), ivec3(0), uBlocks - 1);
  vec3 lo = mix(vec3(b * BLOCK_SIZE), vec3(-2.0), equal(b, ivec3(0)));
  vec3 hi = mix(vec3((b + 1) * BLOCK_SIZE), uBoxDims + 2.0, equal(b, uBlocks - 1));
  vec3 tb = (mix(lo, hi, greaterThan(d, vec3(0.0))) - o) / mix(d, vec3(1.0), equal(d, vec3(0.0)));
  tb = mix(tb, vec3(1.0e30), equal(d, vec3(0.0)));
  tExit = min(min(tb.x, tb.y), tb.z);
  return texelFetch(uMajorant, b, 0).r;
}
float boxExit(vec3 p, vec3 d) {
  vec3 tb = (mix(vec3(-0.5), uBoxDims - 0.5, greaterThan(d, vec3(0.0))) - p) / mix(d, vec3(1.0), equal(d, vec3(0.0)));
  tb = mix(tb, vec3(1.0e30), equal(d, vec3(0.0)));
  return max(min(min(tb.x, tb.y), tb.z), 0.0);
}

// Delta (Woodcock) tracking: the first real collision in (t, t1).
bool deltaTrack(vec3 o, vec3 d, float t, float t1, out float tHit) {
  tHit = 0.0;
  for (int it = 0; it < MAX_TRACKING && t < t1; ++it) {
    float tExit;
    float m = blockAt(o, d, t, tExit);
    float tEnd = min(tExit, t1);
    if (!(m > 0.0)) { t = max(tEnd, t) + BLOCK_NUDGE; continue; }
    t += -log(1.0 - rnd()) / m;
    if (t >= tEnd) { t = tEnd + BLOCK_NUDGE; continue; }
    if (rnd() * m < sigmaAt(o + t * d)) { tHit = t; return true; }
  }
  return false;
}

// Ratio tracking: transmittance from o along d out of the box.
float ratioTrack(vec3 o, vec3 d) {
  float t1 = boxExit(o, d), t = 0.0, T = 1.0;
  for (int it = 0; it < MAX_TRACKING && t < t1; ++it) {
    float tExit;
    float m = blockAt(o, d, t, tExit);
    float tEnd = min(tExit, t1);
    if (!(m > 0.0)) { t = max(tEnd, t) + BLOCK_NUDGE; continue; }
    t += -log(1.0 - rnd()) / m;
    if (t >= tEnd) { t = tEnd + BLOCK_NUDGE; continue; }
    T *= max(0.0, 1.0 - sigmaAt(o + t * d) / m);
    if (T < MIN_TRANSMITTANCE) return 0.0;
  }
  return T;
}

void basis(vec3 n, out vec3 b1, out vec3 b2) {
  float sgn = n.z >= 0.0 ? 1.0 : -1.0;
  float a = -1.0 / (sgn + n.z), b = n.x * n.y * a;
  b1 = vec3(1.0 + sgn * n.x * n.x * a, sgn * b, -sgn * n.x);
  b2 = vec3(b, sgn + n.y * n.y * a, -n.y);
}
vec3 around(vec3 axis, float cosT, float phi) {
  vec3 b1, b2;
  basis(axis, b1, b2);
  float sinT = sqrt(max(0.0, 1.0 - cosT * cosT));
  return b1 * (sinT * cos(phi)) + b2 * (sinT * sin(phi)) + axis * cosT;
}
vec3 sampleHg(vec3 axis, float xi1, float xi2) {
  float g = PHASE_G;
  float sq = (1.0 - g * g) / (1.0 + g - 2.0 * g * xi1);
  return around(axis, clamp((1.0 + g * g - sq * sq) / (2.0 * g), -1.0, 1.0), 2.0 * PI * xi2);
}
vec3 sampleCosine(vec3 n, float xi1, float xi2) {
  return around(n, sqrt(max(0.0, 1.0 - xi1)), 2.0 * PI * xi2);
}

vec4 tracePath(int px, int py, uint smp) {
  gRng = pcgHash(pcgHash(pcgHash(uSeed) ^ uint(px)) ^ (uint(py) * 0x9E3779B9u)) ^ pcgHash(smp + 0x632BE5ABu);
  float jx = rnd(), jy = rnd();
  vec2 ndc = vec2((float(px) + jx) / uViewport.x * 2.0 - 1.0, 1.0 - (float(py) + jy) / uViewport.y * 2.0);
  vec3 offset = uRight * (ndc.x * uHalf.x) + uUp * (ndc.y * uHalf.y);
  vec3 origin = uEye + (1.0 - uPersp) * offset;
  vec3 dir = normalize(uForward + uPersp * offset);
  vec3 o = uPhysToBox * (origin - uBoxOrigin), d = uPhysToBox * dir;
  vec3 inv = 1.0 / vec3(nonZero(d.x), nonZero(d.y), nonZero(d.z));
  vec3 t0 = (uClipLo - o) * inv, t1 = (uClipHi - o) * inv;  // primary rays: the clip box
  vec3 tlo = min(t0, t1), thi = max(t0, t1);
  float tmin = max(max(max(tlo.x, tlo.y), tlo.z), 0.0), tmax = min(min(thi.x, thi.y), thi.z);
  vec4 outc = vec4(0.0);
  float tHit;
  if (tmax < tmin || !deltaTrack(o, d, tmin, tmax, tHit)) return outc;
  outc.a = 1.0;
  vec3 p = o + tHit * d;
  vec3 beta = vec3(1.0);
  for (int bounce = 1; bounce <= uBounces; ++bounce) {
    Point q = locate(p);
    vec3 pLight = p;  // the light volume lies in the box (deformed: output space)
    vec4 c = tfLookup(valueOf(q));
#ifdef ATTRIBUTES
    c.rgb = labShift(c.rgb, texture(uAttr, (p + 0.5) / uBoxDims).xyz);
#endif
#ifdef LABELS
    c.rgb = labelTint(c.rgb, q.u);
#endif
    vec3 albedo = srgbToLinear(c.rgb);
    vec4 n = gradientNormal(q.u);
#ifdef TURN_NORMALS
    n = deformedNormal(p, n, q.snapped);
#endif
    float len = length(n.xyz);
    float grad = len > 1e-4 ? clamp((n.w - GRAD_LOW) / (GRAD_HIGH - GRAD_LOW), 0.0, 1.0) : 0.0;
    vec3 wo = -dir;
    bool surface = rnd() < grad;
    vec3 nn = len > 1e-4 ? n.xyz / len : wo;
    if (dot(nn, wo) < 0.0) nn = -nn;
    // Outgoing rays of a surface event start above it (path_tracer.cpp says why).
    if (surface) p += uPhysToBox * (nn * min(3.0 / max(sigmaAt(p), 1e-6), uSurfaceOffset));

    float xiL = rnd(), xi1 = rnd(), xi2 = rnd();
    bool key = xiL < uPickKey;
    vec3 wl = key ? around(uKeyDir, 1.0 - xi1 * (1.0 - uKeyCos), 2.0 * PI * xi2) : uFillDir;
    float E = key ? uKeyE / uPickKey : uFillE / (1.0 - uPickKey);
    float fr, spec = 0.0;
    if (surface) {
      float cosL = dot(nn, wl);
      fr = cosL > 0.0 ? cosL / PI : 0.0;
      if (cosL > 0.0)
        spec = SPECULAR * (SHININESS + 8.0) / (8.0 * PI) * pow(max(dot(nn, normalize(wl + wo)), 0.0), SHININESS) * cosL;
    } else {
      fr = hgPhase(dot(dir, wl));
    }
    if (fr > 0.0) {
#ifdef LIGHTING
      // Volume shadows (cinematic.volumeShadows): the key light's transmittance from the light
      // volume (its disc already softens it); the fill is unshadowed, as in the ray caster.
      float T = key ? texture(uLight, (pLight + uLightOffset + 0.5) * uLightScale).r : 1.0;
#else
      float T = ratioTrack(p, uPhysToBox * wl);
#endif
      outc.rgb += beta * (albedo * fr + spec) * E * T;
    }
    float xi3 = rnd(), xi4 = rnd();
    dir = surface ? sampleCosine(nn, xi3, xi4) : sampleHg(dir, xi3, xi4);
    beta *= albedo;
    vec3 dd = uPhysToBox * dir;
    if (bounce == uBounces) {
#ifdef LIGHTING
      outc.rgb += beta * (skyRadiance(dir) * texture(uLight, (pLight + 0.5) * uLightScale).g);  // the openness
#else
      outc.rgb += beta * (skyRadiance(dir) * ratioTrack(p, dd));
#endif
      break;
    }
    if (!deltaTrack(p, dd, 0.0, boxExit(p, dd), tHit)) {
      outc.rgb += beta * skyRadiance(dir);
      break;
    }
    p += tHit * dd;
  }
  return outc;
}

void main() {
  int px = int(gl_FragCoord.x), py = int(uViewport.y) - 1 - int(gl_FragCoord.y);
  vec4 sum = vec4(0.0);
  for (int k = 0; k < uSamplesPerPass; ++k) sum += tracePath(px, py, uint(uSampleBase + k));
  fragColor = sum;
}
