#pragma once
// Breadth-first flood fill over the 26-connected neighbourhood of a voxel grid.
#include <cstdint>
#include <vector>

#include "vellum/core/geometry.hpp"

namespace vellum {

/// Grows one 26-connected component from linear index `start` (x fastest) over a grid of
/// `dims`. The caller marks `start` as taken before calling. For each neighbour q of a
/// component voxel, `claim(q)` decides whether q joins; it must also mark q so that it is
/// not claimed twice. `visit(p)` is called once per component voxel in breadth-first order,
/// `start` first. `queue` is scratch space (reused across calls to avoid reallocation).
/// Returns the component's voxel count.
template <class Claim, class Visit>
int64_t floodFill26(const Dims& dims, int64_t start, std::vector<int64_t>& queue, Claim&& claim,
                    Visit&& visit) {
  const int64_t nx = dims.x, nxy = dims.x * dims.y;
  queue.assign(1, start);
  for (size_t h = 0; h < queue.size(); ++h) {
    const int64_t p = queue[h];
    visit(p);
    const int64_t i = p % nx, j = (p / nx) % dims.y, k = p / nxy;
    for (int64_t dk = -1; dk <= 1; ++dk) {
      if (k + dk < 0 || k + dk >= dims.z) continue;
      for (int64_t dj = -1; dj <= 1; ++dj) {
        if (j + dj < 0 || j + dj >= dims.y) continue;
        for (int64_t di = -1; di <= 1; ++di) {
          if (i + di < 0 || i + di >= dims.x) continue;
          const int64_t q = p + dk * nxy + dj * nx + di;
          if (q != p && claim(q)) queue.push_back(q);
        }
      }
    }
  }
  return static_cast<int64_t>(queue.size());
}

}  // namespace vellum
