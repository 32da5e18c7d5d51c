#include "shader_source.hpp"

#include <sstream>

#include "empty_space.hpp"
#include "map_layout.hpp"
#include "map_sampling.hpp"
#include "path_tracer.hpp"
#include "render_common.hpp"
#include "vellum/render/label_tint.hpp"
#include "vellum/render/render_target.hpp"
#include "vellum_render_glsl.hpp"  // generated from ../shaders/*.glsl

namespace vellum::render::detail {

std::string vertexShaderSource() { return glsl::kFullscreenVert; }

const char* rayCommonGlsl() { return glsl::kRayCommon; }

std::string fragmentShaderSource(const ShaderVariant& v) {
  std::ostringstream s;
  s.precision(9);
  s << "#version 450 core\n";
  s << (v.mip ? "#define MODE_MIP\n" : "#define MODE_DVR\n");
  if (v.shading && !v.mip) s << "#define SHADING\n";
  if (v.deformed) s << "#define DEFORMED\n";
  if (v.attributes && v.deformed && !v.mip) s << "#define ATTRIBUTES\n";
  if (v.outputBox && v.deformed) s << "#define OUTPUT_BOX\n";
  if (v.labels && !v.mip) s << "#define LABELS\n#define MAX_TINT_LABELS " << kMaxTintLabels << "\n";
  if (v.held && v.snap && v.deformed) s << "#define HELD_BODIES\n";
  if (v.opaqueDepth) s << "#define OPAQUE_DEPTH\n";
  if (v.turnNormals && v.deformed && v.shading && !v.mip) s << "#define TURN_NORMALS\n";
  if (v.lighting && v.shading && !v.mip) s << "#define LIGHTING\n";
  if (v.toneMap && v.lighting && v.shading && !v.mip) s << "#define TONE_MAP\n";
  // Skipping works on source blocks, or on map cells (between nodes) when deformed.
  s << (v.mip ? "#define SKIP_MIP\n" : "#define SKIP_EMPTY\n");
  if (!v.mip && !v.pathTrace) s << "#define SKIP_COARSE " << kCoarseSkip << "\n";
  s << "#define BLOCK_SIZE " << (v.deformed ? 1 : kBlockSize) << "\n";
  s << "#define TF_SIZE " << kTfTableSize << "\n";
  s << "#define MAX_STEPS " << kMaxStepsPerRay << "\n";
  s << std::showpoint;
  s << "#define EARLY_ALPHA " << kEarlyTerminationAlpha << "\n";
  s << "#define AMBIENT " << kAmbient << "\n#define DIFFUSE " << kDiffuse << "\n";
  s << "#define SPECULAR " << kSpecular << "\n#define SHININESS " << kShininess << "\n";
  s << "#define KEY_SHARE " << kKeyLightShare << "\n";
  s << "#define OUTSIDE " << PreparedMap::kOutside << "\n";
  s << "#define OPAQUE_RANGE_MM " << kOpaqueDepthRangeMm << "\n";
  s << "#define NORMAL_STEP " << PreparedMap::kNormalStepNodes << "\n";
  s << "#define PHASE_G " << kPhaseG << "\n";
  s << "#define GRAD_LOW " << kGradLow << "\n#define GRAD_HIGH " << kGradHigh << "\n";
  s << mapLayoutGlsl(v.gaussian && v.deformed ? Upsampling::Gaussian : Upsampling::Trilinear, v.snap && v.deformed,
                     v.deformed ? v.twistStages : 0);
  if (v.pathTrace) {
    s << "#define MAX_PATH_ALPHA " << kMaxPathAlpha << "\n";
    s << "#define MIN_TRANSMITTANCE " << kMinTransmittance << "\n#define BLOCK_NUDGE " << kBlockNudgeMm << "\n";
    s << "#define MAX_TRACKING " << kMaxTrackingSteps << "\n";
  }
  s << glsl::kLights << glsl::kRaycastFrag << glsl::kRayCommon << (v.pathTrace ? glsl::kPathTraceMainFrag : glsl::kRaycastMainFrag);
  return s.str();
}

}  // namespace vellum::render::detail
