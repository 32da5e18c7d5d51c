// Volume ray caster, part 3: the ray march (CPU reference: reference_cpu.cpp).
#if defined(SKIP_EMPTY) || defined(SKIP_MIP)
// Where the ray (box index o + t d, inv = 1 / d) leaves skipping block b of `size` box units,
// one of `count` per axis; the first and last blocks reach past the box.
float blockExit(ivec3 b, int size, ivec3 count, vec3 o, vec3 d, vec3 inv) {
  vec3 lo = mix(vec3(b * size), vec3(-2.0), equal(b, ivec3(0)));
  vec3 hi = mix(vec3((b + 1) * size), uBoxDims + 2.0, equal(b, count - 1));
  vec3 tb = (mix(lo, hi, greaterThan(d, vec3(0.0))) - o) * inv;
  // An axis the ray does not move along never exits the block (its inv is infinite and
  // 0 * inf or -inf would end the ray early).
  tb = mix(tb, vec3(1.0e30), equal(d, vec3(0.0)));
  return min(min(tb.x, tb.y), tb.z);
}
#endif

void main() {
  FragmentRay ray = fragmentRay();
  vec3 origin = ray.origin, dir = ray.dir, o = ray.o, d = ray.d, inv = ray.inv;
  float tmin = ray.tmin, tmax = ray.tmax;
  {  // the clip box (the whole voxel box unless set): the same steps, fewer of them
    vec3 c0 = (uClipLo - o) * inv, c1 = (uClipHi - o) * inv;
    vec3 lo = min(c0, c1), hi = max(c0, c1);
    tmin = max(tmin, max(max(lo.x, lo.y), lo.z));
    tmax = min(tmax, min(min(hi.x, hi.y), hi.z));
  }

  vec4 acc = vec4(0.0);
#ifdef MODE_MIP
  float maxV = -3.0e38;
  bool hit = false;
#endif
  float jitter = uJitter * pixelJitter(uint(gl_FragCoord.x), uint(uViewport.y - gl_FragCoord.y));
#ifdef OPAQUE_DEPTH
  // Opaque geometry ends the ray: only samples at t < its distance count (clipOpaque() on the CPU).
  float surfaceT = texelFetch(uOpaqueDepth, ivec2(gl_FragCoord.xy), 0).r * OPAQUE_RANGE_MM;
  bool surface = surfaceT < OPAQUE_RANGE_MM;
#endif
#ifdef OUTPUT_BOX
  // The background's value, fetched once: a fetch in the loop costs every sample on llvmpipe,
  // which runs a branch for all the lanes of a SIMD group when any of them takes it.
  float outsideValue = sampleValue(vec3(OUTSIDE));
#endif
  if (tmax >= tmin) {
    int k0 = int(ceil(tmin / uStep - jitter));
    int k1 = min(int(floor(tmax / uStep - jitter)), k0 + MAX_STEPS);
#ifdef OPAQUE_DEPTH
    if (surface) k1 = min(k1, int(ceil(surfaceT / uStep - jitter)) - 1);
#endif
    for (int k = k0; k <= k1; ++k) {
      vec3 p = o + ((float(k) + jitter) * uStep) * d;
#if defined(SKIP_EMPTY) || defined(SKIP_MIP)
      // In a block that cannot change the result (every sample has opacity 0, or for MIP
      // none exceeds the maximum so far): jump to the first step beyond it (the step is
      // clamped before int()). Empty coarse blocks first: one fetch skips SKIP_COARSE^3 blocks
      // (the samples left are the same: a coarse block is empty only if all of its blocks are).
#ifdef SKIP_COARSE
      ivec3 cb = clamp(ivec3(floor(p / float(BLOCK_SIZE * SKIP_COARSE))), ivec3(0), uCoarseBlocks - 1);
      if (texelFetch(uCoarseOccupancy, cb, 0).r < 0.5) {
        float tExit = blockExit(cb, BLOCK_SIZE * SKIP_COARSE, uCoarseBlocks, o, d, inv);
        k = max(k, int(clamp(ceil(tExit / uStep - jitter), float(k), float(k1 + 1))) - 1);
        continue;
      }
#endif
      ivec3 b = clamp(ivec3(floor(p / float(BLOCK_SIZE))), ivec3(0), uBlocks - 1);
#ifdef SKIP_EMPTY
      bool skip = texelFetch(uOccupancy, b, 0).r < 0.5;
#else
      bool skip = texelFetch(uBlockMax, b, 0).r <= maxV;
#endif
      if (skip) {
        float tExit = blockExit(b, BLOCK_SIZE, uBlocks, o, d, inv);
        k = max(k, int(clamp(ceil(tExit / uStep - jitter), float(k), float(k1 + 1))) - 1);
        continue;
      }
#endif
#ifdef DEFORMED
      vec3 mapTc = (p + 0.5) / uBoxDims;
      int snappedBody;
      vec3 u = deformedSource(p, snappedBody);
#ifdef OUTPUT_BOX
      // Beyond the output voxel centres the value fades to the background over one voxel, as
      // the synthesised volume's texture fades to its border (PreparedMap::outputWeight).
      vec3 xo = uOutScale * p + uOutOffset;
      vec3 wo = clamp(min(1.0 + xo, uOutDims - xo), 0.0, 1.0);
      float inside = wo.x * wo.y * wo.z;
      if (inside <= 0.0) u = vec3(OUTSIDE);
#endif
#else
      vec3 u = p;
#endif
      float v = sampleValue(u);
#ifdef OUTPUT_BOX
      if (inside < 1.0) v = mix(outsideValue, v, inside);
#endif
#ifdef MODE_MIP
      maxV = max(maxV, v);
      hit = true;
#else
      vec4 c = tfLookup(v);
      if (c.a > 0.0) {
#ifdef ATTRIBUTES
        vec4 at = texture(uAttr, mapTc);
        c.rgb = labShift(c.rgb, at.xyz);
        c.a = 1.0 - pow(max(1.0 - c.a, 1e-6), max(at.w, 0.0));
#endif
#ifdef LABELS
        {
          float onlyShare;
          c.rgb = labelTint(c.rgb, u, onlyShare);
          if (uOnlyLabel > 0) c.a *= onlyShare;  // "this segment only", blended at its boundary
        }
#endif
#ifdef SHADING
        vec4 n = gradientNormal(u);
#ifdef TURN_NORMALS
        n = deformedNormal(p, n, snappedBody);
#endif
        // The light volume lies in the box the ray marches (deformed: output space), at p.
#if defined(LIGHTING) && defined(TONE_MAP)
        c.rgb = sceneRadianceAt(c.rgb, n, -dir, p);
#elif defined(LIGHTING)
        c.rgb = shadeLit(c.rgb, n, -dir, p);
#else
        c.rgb = shade(c.rgb, n, -dir);
#endif
#endif
        acc.rgb += (1.0 - acc.a) * c.a * c.rgb;
        acc.a += (1.0 - acc.a) * c.a;
        if (acc.a >= EARLY_ALPHA) break;
      }
#endif
    }
  }
#ifdef MODE_MIP
  if (hit) acc = vec4(clamp((maxV - uWinLo) * uWinInvWidth, 0.0, 1.0));
#endif
#ifdef TONE_MAP
  // acc holds linear radiance (premultiplied): the covered part's straight radiance, exposed and
  // tone mapped like the path tracer's (finishPathTraced), before the background.
  if (acc.a > 0.0) acc.rgb = toneMap(acc.rgb / acc.a * uExposure) * acc.a;
#endif
#ifdef OPAQUE_DEPTH
  // Premultiplied, blended (ONE, ONE_MINUS_SRC_ALPHA) over the surface colour in the target.
  if (surface) { fragColor = acc; return; }
#endif
  vec4 outc = acc + (1.0 - acc.a) * vec4(uBackground.rgb * uBackground.a, uBackground.a);
#ifdef OPAQUE_DEPTH
  fragColor = vec4(min(outc.rgb, vec3(outc.a)), outc.a);  // premultiplied (blending is on)
#else
  fragColor = outc.a > 0.0 ? vec4(min(outc.rgb / outc.a, vec3(1.0)), outc.a) : vec4(0.0);
#endif
}
