#pragma once
// Procedural solid (3D) textures, in C++ for the CPU reference; the shader's twin is
// illustration/shaders/solid_texture.glsl (the same integer hash and formulas, so both agree
// to float rounding). Internal.
#include "vellum/illustration/style.hpp"

namespace vellum::illustration::detail {

/// A procedural kind (not None or Volume: 0); q in feature units (position in mm /
/// texture_scale_mm). Returns [0, 1].
float solidTextureAt(SolidTexture kind, float qx, float qy, float qz);

}  // namespace vellum::illustration::detail
