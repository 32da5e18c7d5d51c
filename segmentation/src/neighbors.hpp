#pragma once
// Neighbour offsets for 6/18/26 connectivity (internal).
#include <array>
#include <cstdint>
#include <vector>

#include "vellum/segmentation/mask.hpp"

namespace vellum::segmentation::detail {

struct Offset {
  int di, dj, dk;
};

/// All offsets of the connectivity (6, 18 or 26 of them).
inline std::vector<Offset> neighborOffsets(Connectivity c) {
  std::vector<Offset> out;
  for (int dk = -1; dk <= 1; ++dk)
    for (int dj = -1; dj <= 1; ++dj)
      for (int di = -1; di <= 1; ++di) {
        const int n = (di != 0) + (dj != 0) + (dk != 0);
        if (n == 0) continue;
        if (c == Connectivity::Face6 && n > 1) continue;
        if (c == Connectivity::Edge18 && n > 2) continue;
        out.push_back({di, dj, dk});
      }
  return out;
}

/// Breadth-first flood fill from `starts` (linear indices) through voxels where
/// allowed(linear index) is true; marks them 1 in `out` (which must be zero there before).
/// Iterative with an explicit queue.
template <class Allowed>
void floodFill(const Dims& d, const std::vector<int64_t>& starts, Connectivity c,
               Allowed&& allowed, uint8_t* out) {
  const auto offs = neighborOffsets(c);
  std::vector<int64_t> queue;
  queue.reserve(1 << 16);
  for (int64_t s : starts)
    if (!out[s] && allowed(s)) { out[s] = 1; queue.push_back(s); }
  const int64_t sx = 1, sy = d.x, sz = d.x * d.y;
  std::vector<int64_t> delta;
  for (const auto& o : offs) delta.push_back(o.di * sx + o.dj * sy + o.dk * sz);
  size_t head = 0;
  while (head < queue.size()) {
    const int64_t p = queue[head++];
    const int64_t k = p / sz, j = (p - k * sz) / sy, i = p - k * sz - j * sy;
    const bool interior = i > 0 && j > 0 && k > 0 && i + 1 < d.x && j + 1 < d.y && k + 1 < d.z;
    for (size_t n = 0; n < offs.size(); ++n) {
      if (!interior) {
        const int64_t ni = i + offs[n].di, nj = j + offs[n].dj, nk = k + offs[n].dk;
        if (ni < 0 || nj < 0 || nk < 0 || ni >= d.x || nj >= d.y || nk >= d.z) continue;
      }
      const int64_t q = p + delta[n];
      if (!out[q] && allowed(q)) { out[q] = 1; queue.push_back(q); }
    }
    // Keep memory bounded on huge regions: drop the processed prefix now and then.
    if (head > (1u << 22) && head * 2 > queue.size()) {
      queue.erase(queue.begin(), queue.begin() + static_cast<std::ptrdiff_t>(head));
      head = 0;
    }
  }
}

}  // namespace vellum::segmentation::detail
