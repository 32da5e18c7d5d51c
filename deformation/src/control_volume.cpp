#include "vellum/deformation/control_volume.hpp"

#include "vellum/core/error.hpp"

namespace vellum::deformation {

BackwardMap renderedMap(const ControlVolume& cv, const Geometry& output, Upsampling upsampling) {
  BackwardMap m = cv;
  m.output = output;
  m.upsampling = upsampling;
  return m;
}

Geometry controlGrid(const Geometry& output, int scale) {
  if (scale < 1 || scale > 64) throw Error("control-volume scale must be in 1..64");
  Geometry g = output;
  auto n = [&](int64_t d) { return d <= 1 ? int64_t{1} : (d - 1 + scale - 1) / scale + 1; };
  g.dims = {n(output.dims.x), n(output.dims.y), n(output.dims.z)};
  g.spacing = output.spacing * static_cast<double>(scale);
  return g;
}

ControlVolume identityControlVolume(const Geometry& output, int scale) {
  ControlVolume cv;
  cv.grid = controlGrid(output, scale);
  cv.scale = scale;
  cv.sourceMm = identityNodes(cv.grid);
  return cv;
}

}  // namespace vellum::deformation
