// Illustration ray caster, part 3: the ray march (CPU reference: illustration_renderer_cpu.cpp).
void main() {
  FragmentRay ray = fragmentRay();
  vec3 origin = ray.origin, dir = ray.dir, o = ray.o, d = ray.d, inv = ray.inv;
  float tmin = ray.tmin, tmax = ray.tmax;
  vec3 view = -dir;
  vec3 H = normalize(uLight + view);
  bool zeroVisible = STYLE_VISIBLE_AT(0);
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
          if (labs[c] <= 0 || !STYLE_VISIBLE_AT(labs[c])) continue;
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
          visible = STYLE_VISIBLE_AT(lab);
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
        visible = STYLE_VISIBLE_AT(lab);
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
