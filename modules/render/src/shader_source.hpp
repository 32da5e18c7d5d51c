#pragma once
// GLSL sources of the ray caster (modules/render/shaders/*.glsl, built in by embed_glsl.cmake).
// The fragment shader is specialised per mode with #defines prepended at compile time
// (llvmpipe executes both sides of a uniform branch).
#include <string>

namespace vellum::render::detail {

struct ShaderVariant {
  bool mip = false;         ///< MODE_MIP, else MODE_DVR
  bool shading = false;     ///< SHADING (DVR only)
  bool deformed = false;    ///< DEFORMED: sample the source at u = map(v)
  bool attributes = false;  ///< ATTRIBUTES: Lab colour shift + density (deformed only)
  bool gaussian = false;    ///< MAP_KERNEL == MAP_GAUSSIAN (map_layout.hpp): Gaussian map upsampling (deformed only)
  bool snap = false;        ///< RIGID_SNAP (map_layout.hpp): voxel-level snap of rigid bodies (deformed only)
  bool held = false;        ///< HELD_BODIES: the snap holds bodies (fixed regions) at their own place (with snap)
  bool outputBox = false;   ///< OUTPUT_BOX: background outside the output volume's box
  bool labels = false;      ///< LABELS: label colours tint the samples (DVR only)
  bool opaqueDepth = false; ///< OPAQUE_DEPTH: rays stop at opaque geometry (render_target.hpp)
  bool turnNormals = false; ///< TURN_NORMALS: normals turned by the map's Jacobian (shaded, deformed)
  bool lighting = false;    ///< LIGHTING: key light with shadows and occlusion (light_volume.hpp; shaded DVR)
  bool toneMap = false;     ///< TONE_MAP: the scene lights (lights.glsl) in linear light, ACES tone mapped (with LIGHTING)
  bool pathTrace = false;   ///< the cinematic path tracer's main (path_trace_main.frag.glsl) instead of the ray march
  int twistStages = 0;      ///< TWIST_KERNEL, TWIST_STAGES (map_layout.hpp): the map's twist kernel, 0..4 stages (deformed only)
  int key() const {
    return int(mip) | int(shading) << 1 | int(deformed) << 2 | int(attributes) << 3 | int(gaussian) << 4 |
           int(snap) << 5 | int(outputBox) << 6 | int(labels) << 7 | int(opaqueDepth) << 8 | int(turnNormals) << 9 |
           int(lighting) << 10 | int(pathTrace) << 11 | int(toneMap) << 12 | int(held) << 13 | twistStages << 14;
  }
};

std::string vertexShaderSource();
/// GLSL every ray caster shares (volume and illustration shaders): pixelJitter(), nonZero() and
/// fragmentRay(), the camera ray of a fragment clipped to the voxel box. Needs the uniforms
/// uViewport, uRight, uUp, uHalf, uEye, uPersp, uForward, uPhysToBox, uBoxOrigin, uBoxDims.
const char* rayCommonGlsl();
std::string fragmentShaderSource(const ShaderVariant& v);

}  // namespace vellum::render::detail
