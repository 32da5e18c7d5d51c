#pragma once
// Procedural solid (3D) textures, in C++ for the CPU reference and as GLSL for the shader:
// the same integer hash and formulas, so both agree to float rounding. Internal.
#include <string>

namespace vellum::illustration::detail {

/// kind: 1 noise, 2 marble, 3 wood, 4 stripes, 5 stipple (SolidTexture order); q in feature
/// units (position in mm / texture_scale_mm). Returns [0, 1].
float solidTextureAt(int kind, float qx, float qy, float qz);

/// GLSL: float solidTexture(int kind, vec3 q).
std::string solidTextureGlsl();

}  // namespace vellum::illustration::detail
