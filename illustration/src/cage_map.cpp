// CT backward map from a cage pair: y (output voxel) -> sum_i MVC_i(y; deformed) rest_i.
// MVC costs O(cage faces) per point, so it is evaluated on a coarse lattice (every `step`
// voxels, lattice points may lie past the last voxel) and trilinearly interpolated.
#include <algorithm>
#include <cmath>

#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/illustration/curve_analogy.hpp"

namespace vellum::illustration {

std::vector<float> cageBackwardMap(const Cage& rest, const std::vector<Vec3>& deformed,
                                   const Geometry& grid, int step) {
  if (step < 1) throw Error("backward map: step must be >= 1");
  const int64_t nx = grid.dims.x, ny = grid.dims.y, nz = grid.dims.z;
  const int64_t cx = (nx - 1 + step - 1) / step + 1, cy = (ny - 1 + step - 1) / step + 1,
                cz = (nz - 1 + step - 1) / step + 1;
  std::vector<Vec3> lattice;
  lattice.reserve(size_t(cx * cy * cz));
  for (int64_t k = 0; k < cz; ++k)
    for (int64_t j = 0; j < cy; ++j)
      for (int64_t i = 0; i < cx; ++i)
        lattice.push_back(grid.indexToPhysical(Vec3{double(i * step), double(j * step), double(k * step)}));
  Cage deformedCage{deformed, rest.faces};
  const auto source = transferByMeanValueCoordinates(deformedCage, rest.vertices, lattice);
  std::vector<float> map(size_t(nx * ny * nz) * 3);
  parallelFor(nz, [&](int64_t z0, int64_t z1) {
    for (int64_t k = z0; k < z1; ++k)
      for (int64_t j = 0; j < ny; ++j)
        for (int64_t i = 0; i < nx; ++i) {
          const int64_t i0 = i / step, j0 = j / step, k0 = k / step;
          const double fx = double(i % step) / step, fy = double(j % step) / step, fz = double(k % step) / step;
          Vec3 p{0, 0, 0};
          for (int c = 0; c < 8; ++c) {
            const int dx = c & 1, dy = (c >> 1) & 1, dz = c >> 2;
            const double w = (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy) * (dz ? fz : 1 - fz);
            if (w == 0) continue;
            p += source[size_t(((k0 + dz) * cy + (j0 + dy)) * cx + (i0 + dx))] * w;
          }
          float* out = &map[size_t((k * ny + j) * nx + i) * 3];
          out[0] = float(p.x);
          out[1] = float(p.y);
          out[2] = float(p.z);
        }
  });
  return map;
}

}  // namespace vellum::illustration
