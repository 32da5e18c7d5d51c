#include "illustration_renderer_shader.hpp"

#include <algorithm>
#include <iomanip>
#include <sstream>

#include "illustration_renderer_common.hpp"
#include "shader_source.hpp"  // modules/render: the shared ray set-up GLSL
#include "vellum_illustration_glsl.hpp"  // generated from ../shaders/*.glsl

namespace vellum::illustration::detail {

std::string illustrationFragmentSource(const ShaderVariant& v) {
  std::ostringstream s;
  s << "#version 450 core\n";
  s << (v.eight ? "#define EIGHT\n" : "#define NEAREST\n");
  if (v.ct) s << "#define USE_CT\n";
  if (v.texture) s << "#define USE_TEXTURE\n";
  if (v.textureVolume) s << "#define USE_TEXVOL\n";
  if (v.ink) s << "#define USE_INK\n#define INK_NONE 1e30\n";
  s << "#define NSLOTS " << v.slots << "\n#define SLOT_CAP " << std::max(v.slots, 1) << "\n";
  s << "#define NGROUPS " << std::max((v.slots + 3) / 4, 1) << "\n";
  s << "#define FIELD_SCALE " << std::setprecision(9) << kFieldScaleMm << "\n";
  s << "#define TF_SIZE " << kTfSize << "\n";
  s << "#define BLOCK_SIZE " << kBlock << "\n#define MAX_STEPS " << (1 << 16) << "\n";
  s << "#define EARLY_ALPHA " << kEarlyAlpha << "\n";
  s << styleLayoutGlsl();
  if (v.texture) s << glsl::kSolidTexture;
  s << glsl::kIllustrationSampleFrag << render::detail::rayCommonGlsl() << glsl::kIllustrationMainFrag;
  return s.str();
}

}  // namespace vellum::illustration::detail
