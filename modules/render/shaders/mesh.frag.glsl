// Headlight shading as the ray caster's shade(); the depth is the ray distance / range.
// Prepended by meshFragmentSource(): #version, AMBIENT, DIFFUSE, SPECULAR, SHININESS, DEPTH_RANGE_MM.
in vec3 vPosition;
in vec3 vNormal;
uniform vec3 uEye, uForward, uRgb;
uniform float uPersp;
uniform float uDepthBias;  // mm nearer than the surface
layout(location = 0) out vec4 fragColor;
void main() {
  vec3 rel = vPosition - uEye;
  float t = uPersp > 0.5 ? length(rel) : dot(rel, uForward);
  vec3 l = uPersp > 0.5 ? -normalize(rel) : -uForward;
  vec3 n = vNormal;
  if (dot(n, n) < 1e-12) n = cross(dFdx(vPosition), dFdy(vPosition));  // unused-normal fallback
  float ndl = abs(dot(normalize(n), l));
  fragColor = vec4(min(uRgb * (AMBIENT + DIFFUSE * ndl) + SPECULAR * pow(ndl, SHININESS), vec3(1.0)), 1.0);
  gl_FragDepth = clamp((t - uDepthBias) / DEPTH_RANGE_MM, 0.0, 1.0);
}
