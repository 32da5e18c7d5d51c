// Illustration ray caster, part 3: the ray march (CPU reference: illustration_renderer_cpu.cpp).

// Image-space refinement (image_refine.hpp): this pass traces the pixels (i, j) * uLevelSpacing
// of the uViewport image, fragment (i, uLevelRows - 1 - j) of a smaller target; 1 and the
// image's height for every pixel. nearOut: how far (pixels) the ray passed from ink it did not
// draw (a silhouette's line, hatching, a crease): where a coarse ray comes near, the pixels
// between it and its neighbours are traced, not interpolated.
uniform int uLevelSpacing, uLevelRows;
layout(location = 1) out float nearOut;

// Group g of the per-segment distances (mm) at continuous index p, clamped to the grid (each
// group is its own stack of slices: no filtering across the seam).
vec4 fieldAt(vec3 p, int g) {
  vec3 pc = clamp(p, vec3(0.0), uBoxDims - 1.0);
#ifdef EXACT_FILTER
  // Trilinear weights in float (GPU texture units use 8-bit sub-texel weights): a diagnosis
  // switch, VELLUM_GL_EXACT_FILTER=1 (docs/benchmarks-gpu.md).
  ivec3 i0 = ivec3(floor(pc));
  ivec3 i1 = min(i0 + 1, ivec3(uBoxDims) - 1);
  vec3 f = pc - vec3(i0);
  int z0 = i0.z + g * int(uBoxDims.z), z1 = i1.z + g * int(uBoxDims.z);
  vec4 c00 = mix(texelFetch(uFields, ivec3(i0.x, i0.y, z0), 0), texelFetch(uFields, ivec3(i1.x, i0.y, z0), 0), f.x);
  vec4 c10 = mix(texelFetch(uFields, ivec3(i0.x, i1.y, z0), 0), texelFetch(uFields, ivec3(i1.x, i1.y, z0), 0), f.x);
  vec4 c01 = mix(texelFetch(uFields, ivec3(i0.x, i0.y, z1), 0), texelFetch(uFields, ivec3(i1.x, i0.y, z1), 0), f.x);
  vec4 c11 = mix(texelFetch(uFields, ivec3(i0.x, i1.y, z1), 0), texelFetch(uFields, ivec3(i1.x, i1.y, z1), 0), f.x);
  return mix(mix(c00, c10, f.y), mix(c01, c11, f.y), f.z) * FIELD_SCALE;
#else
  pc.z += float(g) * uBoxDims.z;
  // textureLod, not texture(): every call here is in non-uniform control flow (the march loop
  // ends, skips and branches per pixel), where implicit derivatives are undefined (GLSL 4.50
  // section 8.9). One level, so LOD 0 is what texture() was meant to pick.
  return textureLod(uFields, (pc + 0.5) / vec3(uBoxDims.xy, uBoxDims.z * float(NGROUPS)), 0.0) * FIELD_SCALE;
#endif
}

#ifdef USE_INK
// Slot s's unit normal at p (central differences; zero where its field is flat).
vec3 slotNormal(vec3 p, int s) {
  int g = s / 4, j = s % 4;
  // Samples in variables, halved before the subtraction: see the march's gradients in main().
  float xp = fieldAt(p + vec3(1.0, 0.0, 0.0), g)[j], xm = fieldAt(p - vec3(1.0, 0.0, 0.0), g)[j];
  float yp = fieldAt(p + vec3(0.0, 1.0, 0.0), g)[j], ym = fieldAt(p - vec3(0.0, 1.0, 0.0), g)[j];
  float zp = fieldAt(p + vec3(0.0, 0.0, 1.0), g)[j], zm = fieldAt(p - vec3(0.0, 0.0, 1.0), g)[j];
  vec3 gi = vec3(0.5 * xp - 0.5 * xm, 0.5 * yp - 0.5 * ym, 0.5 * zp - 0.5 * zm);
  float len;
  return normOrZero(uGradToPhys * gi, len);
}
// One direction's crease ink from the unit normals at -R, -h, +h, +R mm (CPU reference:
// creaseProfile() in illustration_renderer_common.cpp): the turn between -R and +R, times how
// much of it is concentrated within +-h (a rounded part turning evenly gets none), times the
// coverage of a widthPx line around where the turn is centred.
float creaseProfile(vec3 nm, vec3 nh, vec3 ph, vec3 np, float R, float h, float c0, float c1, float widthPx,
                    float pixMm) {
  if (!(dot(nm, nm) > 0.5 && dot(np, np) > 0.5 && dot(nh, nh) > 0.5 && dot(ph, ph) > 0.5)) return 0.0;
  float strength = clamp((c0 - dot(nm, np)) / max(c0 - c1, 1e-6), 0.0, 1.0);
  if (!(strength > 0.0)) return 0.0;
  vec3 dn = np - nm;
  float dl = sqrt(dot(dn, dn));
  if (!(dl > 1e-6)) return 0.0;
  vec3 u = dn * (1.0 / dl);
  float sm = dot(nm, u), sp = dot(np, u), sl = dot(nh, u), sr = dot(ph, u);
  float rate = (sr - sl) / (2.0 * h), mean = (sp - sm) / (2.0 * R);
  if (!(rate > 0.0 && mean > 0.0)) return 0.0;
  float concentrated = clamp((rate / mean - 1.25) / 0.75, 0.0, 1.0);
  float x = -h + 2.0 * h * (0.5 * (sm + sp) - sl) / (sr - sl);
  float cover = clamp((0.5 * widthPx * pixMm - abs(x)) / pixMm + 0.5, 0.0, 1.0);
  return strength * concentrated * cover;
}
// Crease ink at the surface point q (CPU reference: creaseInk()): the turn of slot s's normal
// across +-R mm (R at least uCreaseProbeMm, a few voxels) along four screen directions, the
// line placed where the turn is, within +-h (half the width plus half a pixel) of q.
float creaseInk(vec3 q, int s, float widthPx, float angleDeg, float pixMm) {
  // Inner probes at least a voxel apart (creaseInk() on the CPU: rough bone's voxel noise).
  float h = max((0.5 * widthPx + 0.5) * pixMm, uCreaseProbeMm * (1.0 / float(CREASE_PROBE_VOXELS))), R = max(h, uCreaseProbeMm);
  vec3 ax = uPhysToBox * uRight, ay = uPhysToBox * uUp;
  float c0 = cos(radians(angleDeg)), c1 = cos(radians(min(angleDeg + 15.0, 180.0)));
  float ink = 0.0;
  for (int i = 0; i < 4; ++i) {
    vec3 a = i == 0 ? ax : i == 1 ? ay : i == 2 ? 0.70710678 * (ax + ay) : 0.70710678 * (ax - ay);
    ink = max(ink, creaseProfile(slotNormal(q - a * R, s), slotNormal(q - a * h, s), slotNormal(q + a * h, s),
                                 slotNormal(q + a * R, s), R, h, c0, c1, widthPx, pixMm));
  }
  return ink;
}
#endif

// The style row last loaded (consecutive samples mostly style the same rows).
int gCur = -1;
Row gRow;
void addRow(int id, float w, vec3 g, float dd, vec4 ct4, vec3 pMm, float depth, vec3 view, vec3 H, inout vec4 sum) {
  if (!(w > 0.0) || !STYLE_VISIBLE_AT(id)) return;
  if (id != gCur) {
    gCur = id;
    gRow = loadRow(id);
  }
  sum += w * styled(gRow, id, vec4(g, dd), ct4, texValue(gRow, pMm), depth, view, H);
}
void main() {
  // The image pixel this fragment traces (image rows top down).
  ivec2 pix = ivec2(int(gl_FragCoord.x), uLevelRows - 1 - int(gl_FragCoord.y)) * uLevelSpacing;
  FragmentRay ray = fragmentRayAt(vec2(float(pix.x) + 0.5, uViewport.y - float(pix.y) - 0.5));
  vec3 origin = ray.origin, dir = ray.dir, o = ray.o, d = ray.d, inv = ray.inv;
  float tmin = ray.tmin, tmax = ray.tmax;
  vec3 view = -dir;
  float hLen;  // normalize() of a zero vector (light straight behind the viewer) is undefined
  vec3 H = normOrZero(uLight + view, hLen);  // as normalizeOrZero on the CPU
  float depth0 = dot(origin - uCentre, uForward), depthRate = dot(dir, uForward);

  vec4 acc = vec4(0.0);
  float jitter = uJitter * pixelJitter(uint(pix.x), uint(pix.y));
  float near = 1e30;  // nearOut
  if (tmax >= tmin) {
    int k0 = int(ceil(tmin / uStep - jitter));
    int k1 = min(int(floor(tmax / uStep - jitter)), k0 + MAX_STEPS);
    ivec3 lastBlock = ivec3(-1);
    bool blockOccupied = false, blockSame = false;
    int emptyRun = 1;
#ifndef USE_INK
    const bool holdInk = false;
#else
    vec2 hist[SLOT_CAP];     // each slot's distance two samples and one sample ago
    bool holdInk = false;    // some slot's pass near its surface may still get a line
    float inked[SLOT_CAP];   // line ink laid in the ray's current pass near each slot's surface
    bool inPass[SLOT_CAP];   // the ray is near the slot's surface
    vec4 passAcc[SLOT_CAP];  // what was composited when that pass began
    bool entered[SLOT_CAP];  // the ray has been well inside the slot: no lines behind
    int creaseS = -1;        // the first slot with creases the ray entered (inked after the march)
    float creaseT = 0.0;     // where (mm along the ray)
    vec4 creaseAcc = vec4(0.0);  // what was composited when that pass began
    for (int s = 0; s < NSLOTS; ++s) {
      hist[s] = vec2(INK_NONE);
      inked[s] = 0.0;
      inPass[s] = false;
      passAcc[s] = vec4(0.0);
      entered[s] = false;
    }
#endif
    for (int k = k0; k <= k1; ++k) {
      vec3 p = o + ((float(k) + jitter) * uStep) * d;
      ivec3 b = clamp(ivec3(floor(p / float(BLOCK_SIZE))), ivec3(0), uBlocks - 1);
      if (b != lastBlock) {  // one occupancy fetch per block entered, not per sample
        lastBlock = b;
        // occupancyTexels(): 255 mixed, 254 homogeneous, else empty for that many blocks around.
        int occ = int(texelFetch(uOccupancy, b, 0).r * 255.0 + 0.5);
        blockOccupied = occ >= 254;
        blockSame = occ == 254 && uSkipOn > 0.0;
        emptyRun = max(occ, 1);
      }
#ifdef DIAG_NO_SKIP
      blockOccupied = true;
      blockSame = false;
#endif
      if (!blockOccupied) {
        // The cube of empty blocks around b (grid edges: the box's margin).
        ivec3 bl = b - (emptyRun - 1), bh = b + (emptyRun - 1);
        vec3 lo = mix(vec3(bl * BLOCK_SIZE), vec3(-2.0), lessThanEqual(bl, ivec3(0)));
        vec3 hi = mix(vec3((bh + 1) * BLOCK_SIZE), uBoxDims + 2.0, greaterThanEqual(bh, uBlocks - 1));
        // Sides chosen with nonZero()'s sign (a +0 component counts as positive), and the
        // step index clamped before int conversion: axis-aligned rays give +-1e12 here.
        vec3 tb = (mix(lo, hi, greaterThanEqual(d, vec3(0.0))) - o) * inv;
        float tExit = min(min(tb.x, tb.y), tb.z);
        float kExit = clamp(ceil(tExit / uStep - jitter), float(k), float(k1) + 1.0);
        k = max(k, int(kExit) - 1);
#ifdef USE_INK
        for (int s = 0; s < NSLOTS; ++s) {  // samples no longer consecutive
          hist[s] = vec2(INK_NONE);
          inPass[s] = false;
          inked[s] = 0.0;
        }
#endif
        continue;
      }
      float t = (float(k) + jitter) * uStep;
      vec3 pMm = origin + t * dir;
      float depth = (depth0 + t * depthRate) / (2.0 * uRadius) + 0.5;
#ifdef USE_CT
      vec4 ct4 = textureLod(uCt, (p + 0.5) / uBoxDims, 0.0);  // no implicit derivatives in the loop
#else
      vec4 ct4 = vec4(0.0);
#endif
      // Every segment's own distance and its gradient, from the interpolated field.
      float D[SLOT_CAP];
      vec3 G[SLOT_CAP];
      float homog = 1e30;  // distance to the nearest slot band (skipBands; skipSamples on the CPU)
      for (int g = 0; g < NGROUPS; ++g) {
        vec4 c = fieldAt(p, g);
        vec4 r4 = max(max(c - uSkipOut[g], -uSkipIn[g] - c), vec4(0.0));
        homog = min(homog, min(min(r4.x, r4.y), min(r4.z, r4.w)));
        vec4 gx = vec4(0.0), gy = vec4(0.0), gz = vec4(0.0);
        // Gradients only where they can change the picture (gradientWindows).
#ifdef DIAG_NO_GRAD_WINDOW
        if (true) {
#else
        if (any(bvec4(uvec4(greaterThan(c, uGradLo[g])) & uvec4(lessThan(c, uGradHi[g]))))) {
#endif
#ifdef EIGHT
          // Each sample in its own variable, halved before the subtraction (exact in float, so
          // the same numbers): written as 0.5 * (fieldAt(p + e) - fieldAt(p - e)), NVIDIA's
          // compiler (H200) made it exactly zero for a segment inside an invisible one, which
          // drew that bone flat (docs/benchmarks-gpu.md, s25).
          vec4 xp = fieldAt(p + vec3(1.0, 0.0, 0.0), g), xm = fieldAt(p - vec3(1.0, 0.0, 0.0), g);
          vec4 yp = fieldAt(p + vec3(0.0, 1.0, 0.0), g), ym = fieldAt(p - vec3(0.0, 1.0, 0.0), g);
          vec4 zp = fieldAt(p + vec3(0.0, 0.0, 1.0), g), zm = fieldAt(p - vec3(0.0, 0.0, 1.0), g);
          gx = 0.5 * xp - 0.5 * xm;
          gy = 0.5 * yp - 0.5 * ym;
          gz = 0.5 * zp - 0.5 * zm;
#else
          gx = fieldAt(p + vec3(1.0, 0.0, 0.0), g) - c;
          gy = fieldAt(p + vec3(0.0, 1.0, 0.0), g) - c;
          gz = fieldAt(p + vec3(0.0, 0.0, 1.0), g) - c;
#endif
        }
        for (int j = 0; j < 4; ++j) {
          int s = 4 * g + j;
          if (s < NSLOTS) {
            D[s] = c[j];
            G[s] = uGradToPhys * vec3(gx[j], gy[j], gz[j]);
          }
        }
      }
      // Soft painter's order (shadeSample in illustration_renderer_common.cpp). First every
      // slot's weights, innermost first (an invisible slot still covers what lies inside it);
      // then one styled() call site in a loop over the items whose row can show (kItems:
      // item 2k is slot n-1-k's shell row, or the slot's row when it has no shell; 2k+1 its
      // core row; 2n label 0). llvmpipe runs masked code for every lane, so the loop's trip
      // count, not a branch, is what saves the style model of an invisible row.
      const int n = NSLOTS;
      float wFirst[SLOT_CAP], wCore[SLOT_CAP];
      float rest = 1.0;
      for (int s = n - 1; s >= 0; --s) {
        vec4 sl = uSlots[s];
        float c = clamp(0.5 - D[s] / uCoverageH, 0.0, 1.0);
        float wSlot = c * rest;
        rest *= 1.0 - c;
        float sf = sl.y > 0.0 ? clamp(0.5 + (D[s] + sl.z) / uCoverageH, 0.0, 1.0) : 1.0;
        wFirst[s] = wSlot * sf;
        wCore[s] = wSlot * (1.0 - sf);
      }
      vec4 sum = vec4(0.0);
      for (int q = 0; q < NUM_ITEMS; ++q) {
        int i = kItems[q];
        int id;
        float w, dd;
        vec3 g;
        if (i < 2 * n) {
          int s = n - 1 - i / 2;
          vec4 sl = uSlots[s];
          float ds = D[s];
          if ((i & 1) == 0) {
            w = wFirst[s];
            if (sl.y > 0.0) {
              id = int(sl.y);
              g = ds > -0.5 * sl.z ? G[s] : -G[s];
              dd = max(ds, -sl.z - ds);
            } else {
              id = int(sl.x);
              g = G[s];
              dd = ds;
            }
          } else {
            id = int(sl.x);
            w = wCore[s];
            g = G[s];
            dd = ds + sl.z;
          }
        } else {
          int best = -1;
          float bd = FIELD_SCALE;
          for (int s = 0; s < n; ++s)
            if (D[s] < bd) {
              bd = D[s];
              best = s;
            }
          id = 0;
          w = rest;
          g = best >= 0 ? G[best] : vec3(0.0);
          dd = bd;
        }
        addRow(id, w, g, dd, ct4, pMm, depth, view, H, sum);
      }
#ifdef USE_INK
      // Ink goes in front of everything composited since the ray came near the slot's surface
      // (passAcc): lines at a minimum of the slot's distance at the previous sample b, hatching
      // where the ray enters the surface (this sample c). Row: the slot's outermost (shell).
      float pixB = uPixMm.x + uPixMm.y * (t - uStep), pixC = uPixMm.x + uPixMm.y * t;
      holdInk = false;
      for (int q = 0; q < NUM_INK; ++q) {  // the slots whose ink row draws (kInkSlots)
        int s = kInkSlots[q];
        vec4 sl = uSlots[s];
        int iid = sl.y > 0.0 ? int(sl.y) : int(sl.x);
        float a = hist[s].x, b = hist[s].y, c = D[s];
        hist[s] = vec2(b, c);
        if (!STYLE_INK_AT(iid)) continue;
        vec3 lc = STYLE_LINE_COLOUR_AT(iid);
        float op = STYLE_LINE_OPACITY_AT(iid), lw = STYLE_LINE_WIDTH_PX_AT(iid), hs = STYLE_HATCH_SPACING_PX_AT(iid);
        // At every sampled minimum (ties too: along a grazing ray past a flat surface d varies
        // less than its quantum) the line's ink, laid once per pass: the strongest minimum of
        // the pass counts, so no pass is missed nor inked twice.
        float hw = (0.5 * lw + 1.0) * pixB;
        // How far this minimum's line would be (pixels beyond its half width and edge pixel);
        // not on a plateau (a clamped field: far from the surface) nor behind an entered slot.
        if (lw > 0.0 && !entered[s] && a < INK_NONE && b <= a && b <= c && (b < a || b < c))
          near = min(near, max(abs(b) - 0.25 * abs(c - a), 0.0) / pixB - (0.5 * lw + 0.5));
        if (lw > 0.0 && !entered[s] && a < INK_NONE && b <= a && b <= c && inPass[s] && b - 0.25 * abs(c - a) < hw && b > -hw) {
          // Refined at a quarter step around the three samples' vertex: the closest approach
          // then no longer depends on where the (jittered) samples fell, so lines do not break.
          float x = inkVertex(a, b, c);
          float kb = float(k - 1) + jitter;
          float m0 = fieldAt(o + ((kb + x - 0.25) * uStep) * d, s / 4)[s % 4];
          float m1 = fieldAt(o + ((kb + x) * uStep) * d, s / 4)[s % 4];
          float m2 = fieldAt(o + ((kb + x + 0.25) * uStep) * d, s / 4)[s % 4];
          float vox = uCreaseProbeMm * (1.0 / float(CREASE_PROBE_VOXELS));
          float tv = (kb + x) * uStep;
          // Outline-only rows (no fill) keep every line (the CPU reference's comment).
          float fade = STYLE_OPACITY_AT(iid) > 0.0
                           ? inkFeatureFade(fieldAt(o + (tv - vox) * d, s / 4)[s % 4], m1, fieldAt(o + (tv + vox) * d, s / 4)[s % 4], vox)
                           : 1.0;
          float ia = op * inkLine(m0, m1, m2, lw, pixB) * fade;
          if (ia > inked[s]) {
            float add = (ia - inked[s]) / (1.0 - inked[s]);
            inked[s] = ia;
            acc = inkUnder(acc, passAcc[s], vec4(add * lc, add));
          }
        }
        // Hidden lines: once the ray is well inside the slot, its silhouettes further on (the
        // far side of a transparent skin, the other foot behind it) are not drawn.
        if (c < -(0.5 * lw + 1.0) * pixC) entered[s] = true;
        // The pass near the surface: it starts before any sample of it is composited.
        if (!(abs(c) < max((0.5 * lw + 1.0) * pixC, 1.5 * uCoverageH))) {
          inPass[s] = false;
          inked[s] = 0.0;
        } else if (!inPass[s]) {
          inPass[s] = true;
          passAcc[s] = acc;
        }
        // A line may still come in this pass: no early termination until it is over (hatching
        // and an opaque fill would otherwise end the ray before the silhouette's minimum).
        holdInk = holdInk || (inPass[s] && lw > 0.0);
        float gl;
        vec3 nn = normOrZero(G[s], gl);
        if (hs > 0.0 && b < INK_NONE && b > 0.0 && c <= 0.0 && gl > 1e-6 && inPass[s]) {
          if (dot(nn, uLight) < 0.6) near = -1.0;  // hatched: strokes finer than a coarse spacing
          float ia = op * inkHatch(dot(nn, uLight), pMm, nn, hs, STYLE_HATCH_WIDTH_PX_AT(iid));
          acc = inkUnder(acc, passAcc[s], vec4(ia * lc, ia));
        }
        // Creases: evaluated once per ray after the march (six normals a direction), at the
        // first entry into a slot that draws them; the ink goes in front of that pass.
        if (creaseS < 0 && STYLE_CREASE_WIDTH_PX_AT(iid) > 0.0 && b < INK_NONE && b > 0.0 && c <= 0.0 && inPass[s]) {
          creaseS = s;
          creaseT = (float(k - 1) + jitter + b / (b - c)) * uStep;
          creaseAcc = passAcc[s];
        }
      }
#endif
      // Adaptive step: in homogeneous space this sample stands for the next ones up to the
      // nearest band (the landing sample still inside it, so the ink history stays exact).
      float span = floor(0.9 * homog / uStep);
      if (blockSame) {  // to the block's exit (the landing sample is the first one past it)
        vec3 lo = mix(vec3(b * BLOCK_SIZE), vec3(-2.0), equal(b, ivec3(0)));
        vec3 hi = mix(vec3((b + 1) * BLOCK_SIZE), uBoxDims + 2.0, equal(b, uBlocks - 1));
        vec3 tb = (mix(lo, hi, greaterThanEqual(d, vec3(0.0))) - o) * inv;
        float kExit = clamp(ceil(min(min(tb.x, tb.y), tb.z) / uStep - jitter), float(k), float(k1) + 1.0);
        span = max(span, kExit - float(k));
      }
      span = uSkipOn > 0.0 && span >= 2.0 ? min(span, float(k1 - k + 1)) : 1.0;
#ifdef DIAG_NO_SKIP
      span = 1.0;
#endif
      k += int(span) - 1;
      if (sum.a > 0.0) {
        vec3 rgb = sum.rgb / sum.a;
        float aStep = 1.0 - pow(max(1.0 - sum.a, 0.0), uStep * span);
        acc.rgb += (1.0 - acc.a) * aStep * rgb;
        acc.a += (1.0 - acc.a) * aStep;
        if (acc.a >= EARLY_ALPHA && !holdInk) break;
      }
    }
#ifdef USE_INK
    if (creaseS >= 0) {
      vec4 sl = uSlots[creaseS];
      int iid = sl.y > 0.0 ? int(sl.y) : int(sl.x);
      // A coarse pass looks for the crease as far as the pixels it stands for (1.5 spacings
      // wider): where it finds one, they are traced with the exact width.
      float ia = STYLE_LINE_OPACITY_AT(iid) * creaseInk(o + creaseT * d, creaseS,
                                                        STYLE_CREASE_WIDTH_PX_AT(iid) + 1.5 * float(uLevelSpacing - 1),
                                                        STYLE_CREASE_ANGLE_DEG_AT(iid), uPixMm.x + uPixMm.y * creaseT);
      if (ia > 0.0) near = -1.0;
      acc = inkUnder(acc, creaseAcc, vec4(ia * STYLE_LINE_COLOUR_AT(iid), ia));
    }
#endif
  }
  vec4 outc = acc + (1.0 - acc.a) * vec4(uBackground.rgb * uBackground.a, uBackground.a);
  fragColor = outc.a > 0.0 ? vec4(min(outc.rgb / outc.a, vec3(1.0)), outc.a) : vec4(0.0);
  nearOut = near;

}
