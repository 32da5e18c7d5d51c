#pragma once
// The backward map's GPU side, named once: the kernel ids (core Upsampling) and the rigid snap's
// uniforms (core SnapFrame, one row each). mapLayoutGlsl() writes them into the ray caster's
// prefix as #defines and uniform declarations, and the uploader (VolumeRenderer's
// setSnapUniforms) sets the uniforms by the same names, so neither side spells them alone.
#include <array>
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

// The twist kernel's (core TwistKernel): X(Name, GLSL type, array size or "", meaning).
#define VELLUM_TWIST_UNIFORMS(X)                                                                     \
  X(TwistPoint, "vec3", "[TWIST_MAX_STAGES]", "per stage: a point on the axis, mm")                 \
  X(TwistAxis, "vec3", "[TWIST_MAX_STAGES]", "per stage: the unit axis")                            \
  X(TwistAngle, "float", "[TWIST_MAX_STAGES]", "per stage: the angle (rad); a sample turns by -angle * w") \
  X(NodeToMm, "mat3", "", "map node index -> mm (linear part)")                                    \
  X(NodeToMmOffset, "vec3", "", "map node index -> mm (offset)")                                   \
  X(MmToNode, "mat3", "", "mm -> map node index (linear part)")                                    \
  X(MmToNodeOffset, "vec3", "", "mm -> map node index (offset)")                                   \
  X(MmToSrc, "mat3", "", "mm -> source index (linear part)")                                       \
  X(MmToSrcOffset, "vec3", "", "mm -> source index (offset)")

namespace vellum::render::detail {

// A uniform's C++ name constant: k<Name> = "u<Name>".
#define VELLUM_MAP_UNIFORM_NAME(name, type, array, meaning) inline constexpr const char* k##name = "u" #name;

namespace twist_uniform {
VELLUM_TWIST_UNIFORMS(VELLUM_MAP_UNIFORM_NAME)
}  // namespace twist_uniform

/// The twist kernel's uniforms for one map and source (the frames' affine maps as linear part
/// and offset).
struct TwistUniforms {
  int stages = 0;
  std::array<Vec3, TwistKernel::kMaxStages> point{}, axis{};
  std::array<double, TwistKernel::kMaxStages> angle{};
  Mat3 nodeToMm, mmToNode, mmToSrc;
  Vec3 nodeToMmOffset, mmToNodeOffset, mmToSrcOffset;
  static TwistUniforms of(const TwistKernel& twist, const Geometry& grid, const Geometry& source);
};

namespace snap_uniform {
VELLUM_SNAP_UNIFORMS(VELLUM_MAP_UNIFORM_NAME)
}  // namespace snap_uniform

/// vec4 rows per body in uBodyRows: row r is SnapFrame::body's M row r, then m[r].
constexpr int kSnapBodyRows = 3;

/// MAP_<KERNEL> ids, MAP_KERNEL (the variant's kernel), GAUSS_SIGMA; with `snap`, RIGID_SNAP,
/// MAX_SNAP_BODIES, SNAP_BODY_ROWS and the snap's uniform declarations;
/// with `twistStages` > 0, TWIST_KERNEL, TWIST_STAGES (uMap's channels 0 .. hold their weights),
/// TWIST_MAX_STAGES and the twist kernel's uniform declarations.
std::string mapLayoutGlsl(Upsampling kernel, bool snap, int twistStages = 0);

}  // namespace vellum::render::detail
