#include "map_layout.hpp"

#include <cctype>
#include <sstream>

#include "vellum/core/error.hpp"
#include "vellum/core/index_frame.hpp"
#include "vellum/render/backward_map.hpp"

namespace vellum::render::detail {

TwistUniforms TwistUniforms::of(const TwistKernel& twist, const Geometry& grid, const Geometry& source) {
  TwistUniforms u;
  u.stages = int(twist.stages().size());
  for (size_t s = 0; s < twist.stages().size(); ++s) {
    u.point[s] = twist.stages()[s].pointMm;
    u.axis[s] = twist.stages()[s].axis;
    u.angle[s] = twist.stages()[s].angleRad;
  }
  u.nodeToMm = indexToMm(grid);
  u.nodeToMmOffset = grid.origin;
  if (!u.nodeToMm.inverse(u.mmToNode)) throw Error("backward map: singular node grid geometry");
  u.mmToNodeOffset = -(u.mmToNode * grid.origin);
  Mat3 srcToMm = indexToMm(source);
  if (!srcToMm.inverse(u.mmToSrc)) throw Error("backward map: singular source geometry");
  u.mmToSrcOffset = -(u.mmToSrc * source.origin);
  return u;
}

std::string mapLayoutGlsl(Upsampling kernel, bool snap, int twistStages) {
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
// A uniform's GLSL declaration, with its meaning as a comment.
#define VELLUM_MAP_UNIFORM_DECL(name, type, array, meaning) \
  s << "uniform " type " u" #name array ";  // " meaning "\n";
  if (twistStages > 0) {
    s << "#define TWIST_KERNEL\n#define TWIST_STAGES " << twistStages << "\n#define TWIST_MAX_STAGES "
      << TwistKernel::kMaxStages << "\n";
    VELLUM_TWIST_UNIFORMS(VELLUM_MAP_UNIFORM_DECL)
  }
  if (!snap) return s.str();
  s << "#define RIGID_SNAP\n#define MAX_SNAP_BODIES " << kMaxSnapBodies << "\n";
  s << "#define SNAP_BODY_ROWS " << kSnapBodyRows << "\n";
  VELLUM_SNAP_UNIFORMS(VELLUM_MAP_UNIFORM_DECL)
#undef VELLUM_MAP_UNIFORM_DECL
  return s.str();
}

}  // namespace vellum::render::detail
