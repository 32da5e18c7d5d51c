#pragma once
// The backward map's GPU side, named once: the kernel ids (core Upsampling) and the rigid snap's
// uniforms (core SnapFrame, one row each). mapLayoutGlsl() writes them into the ray caster's
// prefix as #defines and uniform declarations, and the uploader (VolumeRenderer's
// setSnapUniforms) sets the uniforms by the same names, so neither side spells them alone.
#include <string>

#include "vellum/core/backward_map.hpp"

// X(Name, GLSL type, array size or "", meaning). The GLSL name is u<Name>.
#define VELLUM_SNAP_UNIFORMS(X)                                                                     \
  X(Classes, "usampler3D", "", "source-space classes: 0 air, 1 soft tissue, 2 + c body c")          \
  X(SrcToClass, "mat3", "", "SnapFrame::toClass A: source index -> class index")                    \
  X(SrcToClassOffset, "vec3", "", "SnapFrame::toClass b")                                           \
  X(SrcDeltaToMm, "mat3", "", "SnapFrame::deltaToMm: source index offset -> mm")                    \
  X(BodyRows, "vec4", "[SNAP_BODY_ROWS * MAX_SNAP_BODIES]", "SnapFrame::body: source index = rows . (p, 1)") \
  X(BodyValid, "uint", "[(MAX_SNAP_BODIES + 31) / 32]", "SnapFrame::valid, one bit per body")       \
  X(BodyHeld, "uint", "[(MAX_SNAP_BODIES + 31) / 32]", "SnapFrame::held, one bit per body")         \
  X(PointToClass, "mat3", "", "SnapFrame::pointToClass A': map node index -> class index of its place") \
  X(PointToClassOffset, "vec3", "", "SnapFrame::pointToClass b'")                                  \
  X(HeldLo, "vec3", "", "SnapFrame::heldBox min: no held body below (map node index)")             \
  X(HeldHi, "vec3", "", "SnapFrame::heldBox max")                                                  \
  X(Bodies, "int", "", "SnapFrame::body.size()")                                                    \
  X(MaxSnap2, "float", "", "SnapFrame::maxSnap2, mm^2")

namespace vellum::render::detail {

namespace snap_uniform {
#define VELLUM_SNAP_UNIFORM_NAME(name, type, array, meaning) inline constexpr const char* k##name = "u" #name;
VELLUM_SNAP_UNIFORMS(VELLUM_SNAP_UNIFORM_NAME)
#undef VELLUM_SNAP_UNIFORM_NAME
}  // namespace snap_uniform

/// vec4 rows per body in uBodyRows: row r is SnapFrame::body's M row r, then m[r].
constexpr int kSnapBodyRows = 3;

/// MAP_<KERNEL> ids, MAP_KERNEL (the variant's kernel), GAUSS_SIGMA and, with `snap`, RIGID_SNAP,
/// MAX_SNAP_BODIES, SNAP_BODY_ROWS and the snap's uniform declarations.
std::string mapLayoutGlsl(Upsampling kernel, bool snap);

}  // namespace vellum::render::detail
