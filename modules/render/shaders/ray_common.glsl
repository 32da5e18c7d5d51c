// The ray set-up every ray caster shares (volume and illustration shaders), after their
// uniform declarations. Mirrors render_common.cpp / reference_cpu.cpp step for step; change
// both together.
// Same integer hash as pixelJitter() in render_common.cpp (bit-identical).
float pixelJitter(uint x, uint y) {
  uint h = x * 1973u + y * 9277u + 26699u;
  h = (h ^ (h >> 15)) * 0x2c1b3c6du;
  h = (h ^ (h >> 12)) * 0x297a2d39u;
  h ^= h >> 15;
  return float(h >> 8) * (1.0 / 16777216.0);
}

float nonZero(float d) { return abs(d) < 1e-12 ? (d < 0.0 ? -1e-12 : 1e-12) : d; }

// The ray through this fragment, as pixelRay() in render_common.cpp builds it: physical origin
// and direction, the same in box index coordinates (o, d, inv = 1/d), and the parameters where
// it enters and leaves the voxel box [-0.5, dims - 0.5] (tmax < tmin: it misses).
struct FragmentRay {
  vec3 origin, dir, o, d, inv;
  float tmin, tmax;
};
// The same for a window position fragCoord of a uViewport-sized image (a pass that traces a
// subset of the pixels into a smaller target maps its fragments there).
FragmentRay fragmentRayAt(vec2 fragCoord) {
  FragmentRay r;
  vec2 ndc = fragCoord / uViewport * 2.0 - 1.0;
  vec3 offset = uRight * (ndc.x * uHalf.x) + uUp * (ndc.y * uHalf.y);
  r.origin = uEye + (1.0 - uPersp) * offset;
  r.dir = normalize(uForward + uPersp * offset);
  r.o = uPhysToBox * (r.origin - uBoxOrigin);
  r.d = uPhysToBox * r.dir;
  r.inv = 1.0 / vec3(nonZero(r.d.x), nonZero(r.d.y), nonZero(r.d.z));
  vec3 t0 = (vec3(-0.5) - r.o) * r.inv, t1 = (uBoxDims - vec3(0.5) - r.o) * r.inv;
  vec3 tlo = min(t0, t1), thi = max(t0, t1);
  r.tmin = max(max(max(tlo.x, tlo.y), tlo.z), 0.0);
  r.tmax = min(min(thi.x, thi.y), thi.z);
  return r;
}
FragmentRay fragmentRay() { return fragmentRayAt(gl_FragCoord.xy); }
