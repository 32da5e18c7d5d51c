#include "illustration_renderer_shader.hpp"

#include <algorithm>
#include <cstdlib>
#include <iomanip>
#include <sstream>
#include <string>
#include <utility>

#include "illustration_renderer_common.hpp"
#include "shader_source.hpp"  // modules/render: the shared ray set-up GLSL
#include "vellum_illustration_glsl.hpp"  // generated from ../shaders/*.glsl

namespace vellum::illustration::detail {

namespace {
// "const int NAME[n] = int[n](a, b, ...);" (one 0 entry when empty: GLSL has no empty arrays).
std::string constList(const char* name, const std::vector<int>& v) {
  std::ostringstream s;
  const size_t n = std::max<size_t>(v.size(), 1);
  s << "const int " << name << "[" << n << "] = int[" << n << "](";
  for (size_t i = 0; i < n; ++i) s << (i ? ", " : "") << (i < v.size() ? v[i] : 0);
  s << ");\n";
  return s.str();
}
}  // namespace

std::string ShaderVariant::key() const {
  std::ostringstream s;
  s << eight << ct << texture << textureVolume << ink << ':' << slots << ':';
  for (int i : items) s << i << ',';
  s << ':';
  for (int i : inkSlots) s << i << ',';
  return s.str();
}

std::string illustrationFragmentSource(const ShaderVariant& v) {
  std::ostringstream s;
  s << "#version 450 core\n";
  s << (v.eight ? "#define EIGHT\n" : "#define NEAREST\n");
  // Diagnosis switch for GPUs whose texture units filter with low-precision weights.
  if (const char* e = std::getenv("VELLUM_GL_EXACT_FILTER"); v.eight && e && std::string(e) == "1")
    s << "#define EXACT_FILTER\n";
  // Diagnosis switches for GPU-only defects (docs/benchmarks-gpu.md), comma-separated:
  // VELLUM_GL_DIAG=normals draws each sample's shading normal as its colour (magenta: not
  // finite, black: zero); nowindow computes field gradients everywhere (no gradient windows);
  // noskip steps every sample (no empty-space or adaptive skip); terms draws the style model's
  // normal weight, gradient length and depth in the band as colour.
  if (const char* e = std::getenv("VELLUM_GL_DIAG"); e) {
    const std::string d = std::string(",") + e + ",";
    for (const auto& [name, define] : {std::pair{"normals", "DIAG_NORMALS"}, {"nowindow", "DIAG_NO_GRAD_WINDOW"},
                                       {"noskip", "DIAG_NO_SKIP"}, {"terms", "DIAG_TERMS"}})
      if (d.find(std::string(",") + name + ",") != std::string::npos) s << "#define " << define << "\n";
  }
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
  s << "#define CREASE_PROBE_VOXELS " << kCreaseProbeVoxels << "\n";
  s << "#define NUM_ITEMS " << v.items.size() << "\n" << constList("kItems", v.items);
  s << "#define NUM_INK " << v.inkSlots.size() << "\n" << constList("kInkSlots", v.inkSlots);
  s << styleLayoutGlsl();
  if (v.texture) s << glsl::kSolidTexture;
  s << glsl::kIllustrationSampleFrag << render::detail::rayCommonGlsl() << glsl::kIllustrationMainFrag;
  return s.str();
}

}  // namespace vellum::illustration::detail
