#include "map_layout.hpp"

#include <cctype>
#include <sstream>

#include "vellum/render/backward_map.hpp"

namespace vellum::render::detail {

std::string mapLayoutGlsl(Upsampling kernel, bool snap) {
  std::ostringstream s;
  s.precision(9);
  s << "// Backward map layout, generated from core/backward_map.hpp and map_layout.hpp.\n";
  for (const Upsampling u : {Upsampling::Trilinear, Upsampling::Gaussian}) {
    std::string name = upsamplingName(u);
    for (char& c : name) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    s << "#define MAP_" << name << ' ' << static_cast<int>(u) << "\n";
  }
  s << "#define MAP_KERNEL " << static_cast<int>(kernel) << "\n";
  s << std::showpoint << "#define GAUSS_SIGMA " << kGaussianUpsamplingSigma << "\n";
  if (!snap) return s.str();
  s << "#define RIGID_SNAP\n#define MAX_SNAP_BODIES " << kMaxSnapBodies << "\n";
  s << "#define SNAP_BODY_ROWS " << kSnapBodyRows << "\n";
#define VELLUM_SNAP_UNIFORM_DECL(name, type, array, meaning) \
  s << "uniform " type " u" #name array ";  // " meaning "\n";
  VELLUM_SNAP_UNIFORMS(VELLUM_SNAP_UNIFORM_DECL)
#undef VELLUM_SNAP_UNIFORM_DECL
  return s.str();
}

}  // namespace vellum::render::detail
