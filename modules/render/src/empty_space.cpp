#include "empty_space.hpp"

#include <algorithm>
#include <cmath>

#include "vellum/core/parallel.hpp"

namespace vellum::render::detail {
namespace {

template <class T>
BlockRanges computeTyped(const Volume<T>& vol) {
  const Dims d = vol.dims();
  BlockRanges r;
  r.blocks = {(d.x + kBlockSize - 1) / kBlockSize, (d.y + kBlockSize - 1) / kBlockSize,
              (d.z + kBlockSize - 1) / kBlockSize};
  const Dims& nb = r.blocks;
  const auto count = static_cast<size_t>(nb.voxelCount());
  std::vector<float> rawMin(count), rawMax(count);
  // Raw range of each block's own voxels.
  parallelFor(nb.z, [&](int64_t bz0, int64_t bz1) {
    for (int64_t bz = bz0; bz < bz1; ++bz)
      for (int64_t by = 0; by < nb.y; ++by)
        for (int64_t bx = 0; bx < nb.x; ++bx) {
          double lo = INFINITY, hi = -INFINITY;
          for (int64_t k = bz * kBlockSize; k < std::min(d.z, (bz + 1) * kBlockSize); ++k)
            for (int64_t j = by * kBlockSize; j < std::min(d.y, (by + 1) * kBlockSize); ++j) {
              const T* row = vol.data() + vol.linearIndex(0, j, k);
              for (int64_t i = bx * kBlockSize; i < std::min(d.x, (bx + 1) * kBlockSize); ++i) {
                lo = std::min(lo, double(row[i]));
                hi = std::max(hi, double(row[i]));
              }
            }
          const size_t b = static_cast<size_t>((bz * nb.y + by) * nb.x + bx);
          rawMin[b] = static_cast<float>(lo);
          rawMax[b] = static_cast<float>(hi);
        }
  });
  // Grow by the 26 neighbours; blocks on the grid's faces also see the background.
  r.minValue.resize(count);
  r.maxValue.resize(count);
  const float bg = static_cast<float>(vol.background());
  parallelFor(nb.z, [&](int64_t bz0, int64_t bz1) {
    for (int64_t bz = bz0; bz < bz1; ++bz)
      for (int64_t by = 0; by < nb.y; ++by)
        for (int64_t bx = 0; bx < nb.x; ++bx) {
          float lo = INFINITY, hi = -INFINITY;
          bool edge = false;
          for (int64_t z = bz - 1; z <= bz + 1; ++z)
            for (int64_t y = by - 1; y <= by + 1; ++y)
              for (int64_t x = bx - 1; x <= bx + 1; ++x) {
                if (x < 0 || y < 0 || z < 0 || x >= nb.x || y >= nb.y || z >= nb.z) {
                  edge = true;
                  continue;
                }
                const size_t n = static_cast<size_t>((z * nb.y + y) * nb.x + x);
                lo = std::min(lo, rawMin[n]);
                hi = std::max(hi, rawMax[n]);
              }
          if (edge) {
            lo = std::min(lo, bg);
            hi = std::max(hi, bg);
          }
          const size_t b = static_cast<size_t>((bz * nb.y + by) * nb.x + bx);
          r.minValue[b] = lo;
          r.maxValue[b] = hi;
        }
  });
  return r;
}

}  // namespace

BlockRanges computeBlockRanges(const AnyVolume& volume) {
  return std::visit([](const auto& v) { return computeTyped(v); }, volume);
}

std::vector<uint8_t> blockOccupancy(const BlockRanges& ranges, const TfTable& tf) {
  // prefix[i] = number of entries below i with non-zero opacity.
  std::vector<int> prefix(kTfTableSize + 1, 0);
  for (int i = 0; i < kTfTableSize; ++i) prefix[i + 1] = prefix[i] + (tf.rgba[4 * i + 3] > 0);
  auto entry = [&](double v) {
    return std::clamp((v - tf.lo) / (tf.hi - tf.lo), 0.0, 1.0) * (kTfTableSize - 1);
  };
  std::vector<uint8_t> occ(ranges.minValue.size());
  for (size_t b = 0; b < occ.size(); ++b) {
    // Entries the shader can interpolate between, with one entry of margin for float rounding.
    const int i0 = std::max(0, static_cast<int>(std::floor(entry(ranges.minValue[b]))) - 1);
    const int i1 = std::min(kTfTableSize - 1, static_cast<int>(std::floor(entry(ranges.maxValue[b]))) + 2);
    occ[b] = prefix[i1 + 1] - prefix[i0] > 0 ? 255 : 0;
  }
  return occ;
}

}  // namespace vellum::render::detail
