// Volume ray caster, part 1: uniforms and helpers; then ray_common.glsl and
// raycast_main.frag.glsl. fragmentShaderSource() prepends #version and the per-mode #defines
// (MODE_MIP/MODE_DVR, SHADING, DEFORMED, ...) and constants (TF_SIZE, BLOCK_SIZE, ...).
layout(location = 0) out vec4 fragColor;

uniform vec2 uViewport;
uniform vec3 uEye, uRight, uUp, uForward;
uniform vec2 uHalf;          // perspective: tangents; orthographic: mm
uniform float uPersp;        // 1 perspective, 0 orthographic
uniform mat3 uPhysToBox;     // physical offset -> box index offset
uniform vec3 uBoxOrigin;     // physical position of box index (0,0,0)
uniform vec3 uBoxDims;
uniform vec3 uClipLo, uClipHi;  // the clip box in box index coordinates
uniform int uOnlyLabel;         // LABELS: draw only this id (0 = all)
uniform float uStep;         // mm
uniform float uJitter;       // 1: per-pixel sample offset, 0: none
uniform vec4 uBackground;
uniform float uValueScale;   // normalised texel -> value
uniform vec3 uSourceDims;
uniform sampler3D uVolume;
#ifdef MODE_MIP
uniform float uWinLo, uWinInvWidth;
#else
uniform sampler1D uTf;
uniform float uTfLo, uTfInvSpan;
#endif
#ifdef SHADING
uniform mat3 uGradToPhys;     // texel differences along the index axes -> physical gradient
uniform float uGradMagScale;  // |gradient| -> encoded magnitude (before the clamp to 1)
#endif
#ifdef LIGHTING
uniform sampler3D uLight;      // per cell: transmittance to the key light, ambient openness
uniform vec3 uLightScale;      // box index + 0.5 -> texture coordinate (box: source, or deformed the map's)
uniform vec3 uLightOffset;     // one cell towards the light, in box index units
uniform vec3 uLightDir;        // physical, towards the key light
uniform float uShadowAmount, uOcclusionAmount;
uniform float uExposure;       // 2^stops
#endif

#ifdef DEFORMED
uniform sampler3D uMap;      // source index coordinates per map node (Gaussian kernel: padded)
#endif
#ifdef TURN_NORMALS
uniform mat3 uNormalToSrcIndex;   // physical normal -> source index covector
uniform mat3 uNodeIndexToNormal;  // map node index covector -> physical normal
#endif
#if MAP_KERNEL == MAP_GAUSSIAN
uniform vec3 uMapNodes;      // node grid dims; uMap has 1 more texel below, 2 above per axis
#endif
#ifdef OUTPUT_BOX
uniform vec3 uOutScale, uOutOffset;   // map node index -> output voxel index, per axis
uniform vec3 uOutDims;
#endif
// RIGID_SNAP: the snap uniforms (uClasses, uSrcToClass, ..., uMaxSnap2) are declared by the
// generated prefix (map_layout.hpp).
#ifdef LABELS
uniform usampler3D uLabels;       // label id per source voxel
uniform sampler1D uLabelColours;  // by id: rgb, a = 1 tinted / 0 not
uniform float uLabelBlend;
#endif
#ifdef ATTRIBUTES
uniform sampler3D uAttr;     // dL, da, db, density scale
#endif
#ifdef OPAQUE_DEPTH
uniform sampler2D uOpaqueDepth;  // ray distance / OPAQUE_RANGE_MM of opaque geometry; 1: none
#endif
#ifdef SKIP_EMPTY
uniform sampler3D uOccupancy;  // per block: 1 where the TF has opacity in its value range
uniform ivec3 uBlocks;
#endif
#ifdef SKIP_COARSE
uniform sampler3D uCoarseOccupancy;  // per SKIP_COARSE^3 blocks: 1 where any of them is occupied
uniform ivec3 uCoarseBlocks;
#endif
#ifdef SKIP_MIP
uniform sampler3D uBlockMax;   // per block: largest value its samples can see
uniform ivec3 uBlocks;
#endif

float sampleValue(vec3 idx) {
  return texture(uVolume, (idx + 0.5) / uSourceDims).r * uValueScale;
}

#ifdef SHADING
// Twin of GradientNormals::sample() (normal_volume.hpp): central differences of the trilinear
// volume one voxel either side (= trilinear interpolation of the voxels' central differences),
// in physical space: unit normal, encoded magnitude; zero where there is no gradient.
vec4 gradientNormal(vec3 u) {
  vec3 tc = (u + 0.5) / uSourceDims, h = 1.0 / uSourceDims;
  vec3 diff = vec3(texture(uVolume, tc + vec3(h.x, 0.0, 0.0)).r - texture(uVolume, tc - vec3(h.x, 0.0, 0.0)).r,
                   texture(uVolume, tc + vec3(0.0, h.y, 0.0)).r - texture(uVolume, tc - vec3(0.0, h.y, 0.0)).r,
                   texture(uVolume, tc + vec3(0.0, 0.0, h.z)).r - texture(uVolume, tc - vec3(0.0, 0.0, h.z)).r);
  vec3 g = uGradToPhys * diff;
  float m = length(g);
  return m > 0.0 ? vec4(g / m, min(m * uGradMagScale, 1.0)) : vec4(0.0);
}
#endif


#ifdef DEFORMED
#if MAP_KERNEL == MAP_GAUSSIAN
// gaussianUpsamplingWeights() of core/backward_map.hpp, in GLSL (all four positive).
vec4 gaussWeights(float f) {
  vec4 x = vec4(-1.0, 0.0, 1.0, 2.0) - f;
  vec4 w = exp(x * x * (-0.5 / (GAUSS_SIGMA * GAUSS_SIGMA)));
  float beta = -dot(w, x) / dot(w, x * x);
  w *= 1.0 + beta * x;
  return w / dot(w, vec4(1.0));
}
#endif

#ifdef TWIST_KERNEL
// What the last mapAt() met at each stage: the position it turned (mm), where it read w (texture
// coordinates), w and the turn's cosine and sine. The shading normal's Jacobian at the same
// sample (twistJacobian, right after deformedSource) starts from them instead of fetching w and
// taking the sine again.
vec3 gTwistX[TWIST_STAGES], gTwistTc[TWIST_STAGES];
float gTwistW[TWIST_STAGES], gTwistCos[TWIST_STAGES], gTwistSin[TWIST_STAGES];
#endif

// u (source index) at map node index p: the node map interpolated as CPU synthesis upsamples it.
vec3 mapAt(vec3 p) {
#ifdef TWIST_KERNEL
  // TwistKernel::sourceMm(): per stage, the position turned by -angle * w, w (uMap's channel s)
  // read trilinearly where the stages before left it (clamped onto the nodes by the texture).
  // The stage count is the variant's (TWIST_STAGES): the loop unrolls, the channels are constant.
  vec3 x = uNodeToMm * clamp(p, vec3(0.0), uBoxDims - 1.0) + uNodeToMmOffset;
  for (int s = 0; s < TWIST_STAGES; ++s) {
    vec3 tc = (uMmToNode * x + uMmToNodeOffset + 0.5) / uBoxDims;
    float w = texture(uMap, tc)[s];
    gTwistX[s] = x;
    gTwistTc[s] = tc;
    gTwistW[s] = w;
    gTwistCos[s] = 1.0;
    gTwistSin[s] = 0.0;
    if (w == 0.0) continue;
    vec3 a = uTwistAxis[s], r = x - uTwistPoint[s];
    float angle = -uTwistAngle[s] * w, c = cos(angle), sn = sin(angle);
    gTwistCos[s] = c;
    gTwistSin[s] = sn;
    x = uTwistPoint[s] + r * c + cross(a, r) * sn + a * (dot(a, r) * (1.0 - c));
  }
  return uMmToSrc * x + uMmToSrcOffset;
#elif MAP_KERNEL == MAP_GAUSSIAN
  // 4 taps per axis as 2 linear fetches (positive weights): 8 trilinear fetches in all.
  vec3 q = clamp(p, vec3(0.0), uMapNodes - 1.0);
  vec3 n0 = floor(q), f = q - n0;
  vec4 wx = gaussWeights(f.x), wy = gaussWeights(f.y), wz = gaussWeights(f.z);
  vec3 w0 = vec3(wx.x, wy.x, wz.x), w1 = vec3(wx.y, wy.y, wz.y);
  vec3 w2 = vec3(wx.z, wy.z, wz.z), w3 = vec3(wx.w, wy.w, wz.w);
  vec3 g0 = w0 + w1, g1 = w2 + w3;
  vec3 inv = 1.0 / (uMapNodes + 3.0);
  vec3 h0 = (n0 + w1 / g0 + 0.5) * inv, h1 = (n0 + 2.0 + w3 / g1 + 0.5) * inv;
  vec3 u = vec3(0.0);
  for (int c = 0; c < 8; ++c) {
    bvec3 hi = bvec3((c & 1) != 0, (c & 2) != 0, (c & 4) != 0);
    vec3 g = mix(g0, g1, hi);
    u += (g.x * g.y * g.z) * texture(uMap, mix(h0, h1, hi)).xyz;
  }
  return u;
#else
  return texture(uMap, (p + 0.5) / uBoxDims).xyz;
#endif
}

#if defined(TURN_NORMALS) && defined(TWIST_KERNEL)
// TwistKernel::jacobian() at the sample the last mapAt() turned (its stages' positions, w and
// turns: gTwist*): per stage R (I - angle t grad(w)^T), grad(w) from the weight's filtered
// fetches NORMAL_STEP nodes either side.
mat3 twistJacobian() {
  mat3 J = mat3(1.0);
  vec3 h = vec3(NORMAL_STEP) / uBoxDims;
  for (int s = 0; s < TWIST_STAGES; ++s) {
    vec3 tc = gTwistTc[s];
    float w = gTwistW[s];
    vec3 g = vec3(texture(uMap, tc + vec3(h.x, 0.0, 0.0))[s] - texture(uMap, tc - vec3(h.x, 0.0, 0.0))[s],
                  texture(uMap, tc + vec3(0.0, h.y, 0.0))[s] - texture(uMap, tc - vec3(0.0, h.y, 0.0))[s],
                  texture(uMap, tc + vec3(0.0, 0.0, h.z))[s] - texture(uMap, tc - vec3(0.0, 0.0, h.z))[s]) /
             (2.0 * NORMAL_STEP);
    if (w == 0.0 && g == vec3(0.0)) continue;
    vec3 a = uTwistAxis[s], r = gTwistX[s] - uTwistPoint[s];
    vec3 gm = transpose(uMmToNode) * g, t = cross(a, r);
    float c = gTwistCos[s], sn = gTwistSin[s];
    // Rodrigues: c I + sn [a]x + (1 - c) a a^T (GLSL matrices are column-major).
    mat3 R = c * mat3(1.0) + sn * mat3(0.0, a.z, -a.y, -a.z, 0.0, a.x, a.y, -a.x, 0.0) + (1.0 - c) * outerProduct(a, a);
    J = R * (mat3(1.0) - uTwistAngle[s] * outerProduct(t, gm)) * J;
  }
  return J;
}
#endif

#ifdef TURN_NORMALS
// Twin of PreparedMap::nodeTexture(): the node texture, hardware-filtered (either kernel).
vec3 nodeTexture(vec3 p) {
#if MAP_KERNEL == MAP_GAUSSIAN
  return texture(uMap, (p + 1.5) / (uMapNodes + 3.0)).xyz;
#else
  return texture(uMap, (p + 0.5) / uBoxDims).xyz;
#endif
}

#ifdef RIGID_SNAP
// J^T of a sample the snap moved with body `body`: its rows (source index per map node index).
mat3 bodyJt(int body) {
  int r = SNAP_BODY_ROWS * body;
  return mat3(uBodyRows[r].xyz, uBodyRows[r + 1].xyz, uBodyRows[r + 2].xyz);
}
#endif

// Twin of PreparedMap::turnNormal(): the source normal at u(p) turned into output space by
// J^T (J = du/dp by central differences of the node texture), keeping its length.
// A sample the rigid snap moved (snappedBody >= 0) turns with that body exactly: J^T's
// columns are the body's rows.
vec4 deformedNormal(vec3 p, vec4 n, int snappedBody) {
  float len = length(n.xyz);
  if (!(len > 1e-4) || !(n.w > GRAD_LOW)) return n;
#ifdef TWIST_KERNEL
  if (snappedBody < 0) {  // TwistKernel::jacobian(), in mm: grad (f o u) = J^T grad f
    vec3 tm = transpose(twistJacobian()) * n.xyz;  // p's: deformedSource(p) ran last
    float tl = length(tm);
    return tl > 0.0 ? vec4(tm * (len / tl), n.w) : n;
  }
#endif
  mat3 jt;
#if defined(TWIST_KERNEL) && defined(RIGID_SNAP)
  // Only snapped samples get here. The node texture's differences below would be dead code,
  // and llvmpipe runs every branch its SIMD lanes hold (masked), dead or not: left out.
  jt = bodyJt(snappedBody);
#else
#ifdef RIGID_SNAP
  if (snappedBody >= 0) {
    jt = bodyJt(snappedBody);
  } else
#endif
  {
    vec3 jx = nodeTexture(p + vec3(NORMAL_STEP, 0.0, 0.0)) - nodeTexture(p - vec3(NORMAL_STEP, 0.0, 0.0));
    vec3 jy = nodeTexture(p + vec3(0.0, NORMAL_STEP, 0.0)) - nodeTexture(p - vec3(0.0, NORMAL_STEP, 0.0));
    vec3 jz = nodeTexture(p + vec3(0.0, 0.0, NORMAL_STEP)) - nodeTexture(p - vec3(0.0, 0.0, NORMAL_STEP));
    jt = transpose(mat3(jx, jy, jz));
  }
#endif
  vec3 m = uNodeIndexToNormal * (jt * (uNormalToSrcIndex * n.xyz));
  float ml = length(m);
  return ml > 0.0 ? vec4(m * (len / ml), n.w) : n;
}
#endif

#ifdef RIGID_SNAP
// The class at class index c (rounded), or -1 outside the class grid.
int classAt(vec3 c) {
  if (any(lessThanEqual(c, vec3(-0.5)))) return -1;
  ivec3 ci = ivec3(floor(c + 0.5));
  if (any(greaterThanEqual(ci, textureSize(uClasses, 0)))) return -1;
  return int(texelFetch(uClasses, ci, 0).r);
}

bool bodyFlag(uint bits[(MAX_SNAP_BODIES + 31) / 32], int body) {
  return ((bits[body >> 5] >> uint(body & 31)) & 1u) != 0u;
}

// Body `body`'s source position of map node index p.
vec3 bodySource(int body, vec3 p) {
  vec4 p1 = vec4(p, 1.0);
  int r = SNAP_BODY_ROWS * body;
  return vec3(dot(uBodyRows[r], p1), dot(uBodyRows[r + 1], p1), dot(uBodyRows[r + 2], p1));
}

#ifdef HELD_BODIES
// SnapFrame::heldAt(): the held body (a fixed region) at p's own place, or -1. Compiled in only
// when the snap holds a body (llvmpipe would run its lookup for every sample, box test or not).
int heldAt(vec3 p) {
  if (any(lessThan(p, uHeldLo)) || any(greaterThan(p, uHeldHi))) return -1;
  int body = classAt(uPointToClass * p + uPointToClassOffset) - 2;
  return body >= 0 && body < uBodies && bodyFlag(uBodyHeld, body) ? body : -1;
}
#endif

// CPU synthesis' voxel snap: u in the class voxel of valid body c and R_c v + t_c within
// maxSnapMm of u -> u = R_c v + t_c.
vec3 snapRigid(vec3 p, vec3 u, out int snappedBody) {
  snappedBody = -1;
  int body = classAt(uSrcToClass * u + uSrcToClassOffset) - 2;
  if (body < 0 || body >= uBodies || !bodyFlag(uBodyValid, body)) return u;
  vec3 s = bodySource(body, p);
  vec3 dmm = uSrcDeltaToMm * (s - u);
  if (!(dot(dmm, dmm) <= uMaxSnap2)) return u;
  snappedBody = body;
  return s;
}
#endif

// Twin of PreparedMap::at(): the source index of map node index p, through the map and the
// snap; a held body's place needs no map.
vec3 deformedSource(vec3 p, out int snappedBody) {
  snappedBody = -1;
#ifdef RIGID_SNAP
#ifdef HELD_BODIES
  snappedBody = heldAt(p);
  if (snappedBody >= 0) return bodySource(snappedBody, p);
#endif
  return snapRigid(p, mapAt(p), snappedBody);
#else
  return mapAt(p);
#endif
}
#endif

#ifndef MODE_MIP
vec4 tfLookup(float v) {
  float x = clamp((v - uTfLo) * uTfInvSpan, 0.0, 1.0) * float(TF_SIZE - 1);
  int i = min(int(x), TF_SIZE - 2);
  return mix(texelFetch(uTf, i, 0), texelFetch(uTf, i + 1, 0), x - float(i));
}
#endif

#ifdef LABELS
// Label colours (twin of tintByLabels() in label_colour.hpp): the one-hot label colours of the 8
// voxels around u, trilinear and weighted by each voxel's opacity in this transfer function, so
// colours blend smoothly across a boundary and a sample on a bone's surface takes the bone's
// colour, not that of the faint muscle beside it. Untinted voxels pull towards the TF colour.
// One pass over the 8 corners: the pull towards their label colours, the weight on uOnlyLabel
// and the weights' sum, with trilinear weights times each corner's opacity and with plain ones
// (what labelTint() falls back to where no corner is opaque). Both sums in the one loop: a
// second loop under the fallback's branch would run for every sample on llvmpipe, which runs
// a branch for all the lanes of a SIMD group when any of them takes it.
struct LabelSums {
  vec3 pull;
  float only, wsum;
};

void labelCorners(vec3 c, vec3 u, out LabelSums opaque, out LabelSums plain) {
  vec3 b = floor(u), f = u - b;
  ivec3 bi = ivec3(b), dims = ivec3(uSourceDims);
  opaque = LabelSums(vec3(0.0), 0.0, 0.0);
  plain = LabelSums(vec3(0.0), 0.0, 0.0);
  for (int n = 0; n < 8; ++n) {
    ivec3 o = ivec3(n & 1, (n >> 1) & 1, (n >> 2) & 1);
    ivec3 q = bi + o;
    if (any(lessThan(q, ivec3(0))) || any(greaterThanEqual(q, dims))) continue;
    vec3 t = mix(1.0 - f, f, vec3(o));
    float w = t.x * t.y * t.z;
    float wo = w * tfLookup(texelFetch(uVolume, q, 0).r * uValueScale).a;
    uint id = texelFetch(uLabels, q, 0).r;
    vec4 lc = id < uint(MAX_TINT_LABELS) ? texelFetch(uLabelColours, int(id), 0) : vec4(0.0);
    bool isOnly = id == uint(uOnlyLabel);
    opaque.wsum += wo;
    opaque.pull += wo * lc.a * (lc.rgb - c);
    if (isOnly) opaque.only += wo;
    plain.wsum += w;
    plain.pull += w * lc.a * (lc.rgb - c);
    if (isOnly) plain.only += w;
  }
}

// `onlyShare`: how much of the sample belongs to uOnlyLabel ("this segment only"), blended
// across its boundary like the colours.
vec3 labelTint(vec3 c, vec3 u, out float onlyShare) {
  LabelSums opaque, plain;
  labelCorners(c, u, opaque, plain);
  // No corner is opaque (a faint sample between clear voxels): plain trilinear weights.
  LabelSums l = opaque.wsum > 1e-6 ? opaque : plain;
  onlyShare = l.wsum > 0.0 ? l.only / l.wsum : 0.0;
  return l.wsum > 0.0 ? c + uLabelBlend * l.pull / l.wsum : c;
}

vec3 labelTint(vec3 c, vec3 u) {
  float onlyShare;
  return labelTint(c, u, onlyShare);
}
#endif

#ifdef SHADING
vec3 shade(vec3 c, vec4 n, vec3 l) {
  float len = length(n.xyz);
  float w = len > 1e-4 ? clamp((n.w - GRAD_LOW) / (GRAD_HIGH - GRAD_LOW), 0.0, 1.0) : 0.0;
  float ndl = abs(dot(n.xyz, l)) / max(len, 1e-4);
  vec3 lit = c * (AMBIENT + DIFFUSE * ndl) + SPECULAR * pow(ndl, SHININESS);
  return mix(c, min(lit, vec3(1.0)), w);
}
#endif

#ifdef LIGHTING
// Twin of shadeLit() in reference_cpu.cpp: the key light (shadowed) with a headlight fill,
// ambient scaled by the openness; regions without a gradient keep their colour, darkened alike.
vec3 shadeLit(vec3 c, vec4 n, vec3 v, vec3 p) {
  vec2 lo = texture(uLight, (p + uLightOffset + 0.5) * uLightScale).rg;
  float T = mix(1.0, lo.r, uShadowAmount), A = mix(1.0, lo.g, uOcclusionAmount);
  float len = length(n.xyz);
  float w = len > 1e-4 ? clamp((n.w - GRAD_LOW) / (GRAD_HIGH - GRAD_LOW), 0.0, 1.0) : 0.0;
  vec3 nn = len > 1e-4 ? n.xyz / len : v;
  if (dot(nn, v) < 0.0) nn = -nn;
  float key = max(dot(nn, uLightDir), 0.0), head = max(dot(nn, v), 0.0);
  vec3 h = normalize(uLightDir + v);
  float spec = SPECULAR * pow(max(dot(nn, h), 0.0), SHININESS) * T;
  vec3 lit = (c * (AMBIENT * A + DIFFUSE * (KEY_SHARE * key * T + (1.0 - KEY_SHARE) * head)) + spec) * uExposure;
  vec3 plain = c * (AMBIENT * A + DIFFUSE * (KEY_SHARE * T + (1.0 - KEY_SHARE))) * uExposure;
  return mix(min(plain, vec3(1.0)), min(lit, vec3(1.0)), w);
}
#endif

#if defined(LIGHTING) && defined(TONE_MAP)
// The scene lights' radiance of a sample (sceneRadiance() of lights.glsl) with the light volume's
// key-light transmittance (softened by the light's size) and openness.
vec3 sceneRadianceAt(vec3 c, vec4 n, vec3 v, vec3 p) {
  vec2 lo = texture(uLight, (p + uLightOffset + 0.5) * uLightScale).rg;
  float T = mix(1.0, lo.r, uShadowAmount), A = mix(1.0, lo.g, uOcclusionAmount);
  float len = length(n.xyz);
  float w = len > 1e-4 ? clamp((n.w - GRAD_LOW) / (GRAD_HIGH - GRAD_LOW), 0.0, 1.0) : 0.0;
  return sceneRadiance(srgbToLinear(c), n.xyz, w, v, T, A);
}
#endif

#ifdef ATTRIBUTES
float toLinear(float c) { return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4); }
float toSrgb(float c) { return c <= 0.0031308 ? 12.92 * c : 1.055 * pow(c, 1.0 / 2.4) - 0.055; }
const float kD = 6.0 / 29.0;
float labF(float t) { return t > kD * kD * kD ? pow(t, 1.0 / 3.0) : t / (3.0 * kD * kD) + 4.0 / 29.0; }
float labFInv(float t) { return t > kD ? t * t * t : 3.0 * kD * kD * (t - 4.0 / 29.0); }
vec3 labShift(vec3 rgb, vec3 dLab) {
  vec3 lin = vec3(toLinear(rgb.r), toLinear(rgb.g), toLinear(rgb.b));
  float X = 0.4124 * lin.r + 0.3576 * lin.g + 0.1805 * lin.b;
  float Y = 0.2126 * lin.r + 0.7152 * lin.g + 0.0722 * lin.b;
  float Z = 0.0193 * lin.r + 0.1192 * lin.g + 0.9505 * lin.b;
  float fx = labF(X / 0.95047), fy = labF(Y), fz = labF(Z / 1.08883);
  float L = 116.0 * fy - 16.0 + dLab.x, A = 500.0 * (fx - fy) + dLab.y, B = 200.0 * (fy - fz) + dLab.z;
  float gy = (L + 16.0) / 116.0, gx = gy + A / 500.0, gz = gy - B / 200.0;
  float X2 = 0.95047 * labFInv(gx), Y2 = labFInv(gy), Z2 = 1.08883 * labFInv(gz);
  vec3 l2 = vec3(3.2406 * X2 - 1.5372 * Y2 - 0.4986 * Z2, -0.9689 * X2 + 1.8758 * Y2 + 0.0415 * Z2,
                 0.0557 * X2 - 0.2040 * Y2 + 1.0570 * Z2);
  l2 = max(l2, vec3(0.0));
  return clamp(vec3(toSrgb(l2.r), toSrgb(l2.g), toSrgb(l2.b)), 0.0, 1.0);
}
#endif

