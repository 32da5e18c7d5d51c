#include "vellum/deformation/control_volume.hpp"

#include "vellum/core/error.hpp"
#include "vellum/core/memory_budget.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum::deformation {

const char* upsamplingName(Upsampling u) { return u == Upsampling::Trilinear ? "trilinear" : "gaussian"; }

Upsampling parseUpsampling(const std::string& name) {
  if (name == "trilinear") return Upsampling::Trilinear;
  if (name == "gaussian") return Upsampling::Gaussian;
  throw Error("unknown upsampling '" + name + "' (trilinear, gaussian)");
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
  const Dims d = cv.grid.dims;
  checkMemoryBudget(d, 3 * sizeof(float), "control volume");
  cv.sourceMm.resize(static_cast<size_t>(d.voxelCount()) * 3);
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) {
          const Vec3 p = cv.grid.indexToPhysical({double(i), double(j), double(k)});
          float* o = cv.sourceMm.data() + 3 * ((k * d.y + j) * d.x + i);
          o[0] = static_cast<float>(p.x); o[1] = static_cast<float>(p.y); o[2] = static_cast<float>(p.z);
        }
  });
  return cv;
}

}  // namespace vellum::deformation
