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
  // Own ranges: a face block's samples can read the background beyond the volume.
  r.background = bg;
  r.ownMin = std::move(rawMin);
  r.ownMax = std::move(rawMax);
  parallelFor(nb.z, [&](int64_t bz0, int64_t bz1) {
    for (int64_t bz = bz0; bz < bz1; ++bz)
      for (int64_t by = 0; by < nb.y; ++by)
        for (int64_t bx = 0; bx < nb.x; ++bx)
          if (bx == 0 || by == 0 || bz == 0 || bx + 1 == nb.x || by + 1 == nb.y || bz + 1 == nb.z) {
            const size_t b = static_cast<size_t>((bz * nb.y + by) * nb.x + bx);
            r.ownMin[b] = std::min(r.ownMin[b], bg);
            r.ownMax[b] = std::max(r.ownMax[b], bg);
          }
  });
  return r;
}

// 255 where the table has non-zero opacity anywhere in [minValue, maxValue], else 0.
std::vector<uint8_t> rangeOccupancy(const std::vector<float>& minValue, const std::vector<float>& maxValue,
                                    const TfTable& tf) {
  // prefix[i] = number of entries below i with non-zero opacity.
  std::vector<int> prefix(kTfTableSize + 1, 0);
  for (int i = 0; i < kTfTableSize; ++i) prefix[i + 1] = prefix[i] + (tf.rgba[4 * i + 3] > 0);
  auto entry = [&](double v) {
    return std::clamp((v - tf.lo) / (tf.hi - tf.lo), 0.0, 1.0) * (kTfTableSize - 1);
  };
  std::vector<uint8_t> occ(minValue.size());
  for (size_t b = 0; b < occ.size(); ++b) {
    // Entries the shader can interpolate between, with one entry of margin for float rounding.
    const int i0 = std::max(0, static_cast<int>(std::floor(entry(minValue[b]))) - 1);
    const int i1 = std::min(kTfTableSize - 1, static_cast<int>(std::floor(entry(maxValue[b]))) + 2);
    occ[b] = prefix[i1 + 1] - prefix[i0] > 0 ? 255 : 0;
  }
  return occ;
}

}  // namespace

BlockRanges computeBlockRanges(const AnyVolume& volume) {
  return std::visit([](const auto& v) { return computeTyped(v); }, volume);
}

std::vector<uint8_t> blockOccupancy(const BlockRanges& ranges, const TfTable& tf) {
  return rangeOccupancy(ranges.minValue, ranges.maxValue, tf);
}

std::vector<uint8_t> ownBlockOccupancy(const BlockRanges& ranges, const TfTable& tf) {
  return rangeOccupancy(ranges.ownMin, ranges.ownMax, tf);
}

uint8_t backgroundOccupancy(const BlockRanges& ranges, const TfTable& tf) {
  return rangeOccupancy({ranges.background}, {ranges.background}, tf).front();
}

namespace {
// floor(x / kBlockSize) clamped to [0, last], without libm (x is never NaN here: the extremes
// pass NaN texels over; +-inf clamp to the ends).
inline int blockOf(double x, double last) { return x <= 0 ? 0 : int(std::min(x * (1.0 / kBlockSize), last)); }
}  // namespace

MapCells computeMapCells(const Dims& nodes, const std::vector<float>& mapIndex,
                         const BlockRanges& ranges, const MapCellSupport* support,
                         std::vector<std::array<int16_t, 6>> storage) {
  const MapCellSupport sup = support ? *support : MapCellSupport{nodes, 0, 1, 0.0};
  const Dims& td = sup.texDims;
  // One voxel: the trilinear support (voxels floor(u) and floor(u) + 1); a little more for rounding.
  const double margin = 1.001 + sup.marginVoxels;
  MapCells mc;
  mc.cells = {std::max<int64_t>(nodes.x - 1, 1), std::max<int64_t>(nodes.y - 1, 1),
              std::max<int64_t>(nodes.z - 1, 1)};
  const auto count = static_cast<size_t>(mc.cells.voxelCount());
  mc.box = std::move(storage);
  mc.box.resize(count);  // every entry is written below
  const Dims& nb = ranges.blocks;
  parallelFor(mc.cells.z, [&](int64_t z0, int64_t z1) {
    // Per row of cells: the extremes over the row's (j, k) window in every texel column, then
    // over each cell's columns (each texel read once per row, not once per cell around it).
    // The same extremes as texel by texel per cell (std::min / std::max pass a NaN texel over).
    std::vector<float> colLo(static_cast<size_t>(3 * td.x)), colHi(static_cast<size_t>(3 * td.x));
    for (int64_t cz = z0; cz < z1; ++cz)
      for (int64_t cy = 0; cy < mc.cells.y; ++cy) {
        std::fill(colLo.begin(), colLo.end(), INFINITY);
        std::fill(colHi.begin(), colHi.end(), -INFINITY);
        for (int64_t k = std::max<int64_t>(cz + sup.lo, 0); k <= std::min<int64_t>(cz + sup.hi, td.z - 1); ++k)
          for (int64_t j = std::max<int64_t>(cy + sup.lo, 0); j <= std::min<int64_t>(cy + sup.hi, td.y - 1); ++j) {
            const float* row = mapIndex.data() + static_cast<size_t>((k * td.y + j) * td.x) * 3;
            for (size_t q = 0; q < colLo.size(); ++q) {
              colLo[q] = std::min(colLo[q], row[q]);
              colHi[q] = std::max(colHi[q], row[q]);
            }
          }
        for (int64_t cx = 0; cx < mc.cells.x; ++cx) {
          float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
          for (int64_t i = std::max<int64_t>(cx + sup.lo, 0); i <= std::min<int64_t>(cx + sup.hi, td.x - 1); ++i)
            for (int a = 0; a < 3; ++a) {
              lo[a] = std::min(lo[a], colLo[static_cast<size_t>(3 * i + a)]);
              hi[a] = std::max(hi[a], colHi[static_cast<size_t>(3 * i + a)]);
            }
          std::array<int, 6> box{};
          for (int a = 0; a < 3; ++a) {
            const double last = double(nb[a] - 1);
            // Blocks hold voxels [b*B, b*B+B-1]; their own ranges count (the margin holds the
            // support), the face blocks' with the background.
            box[a] = blockOf(lo[a] - margin, last);
            box[a + 3] = blockOf(hi[a] + margin, last);
            if (!std::isfinite(lo[a]) || !std::isfinite(hi[a])) {  // NaN in the map: no skipping
              box[a] = 0;
              box[a + 3] = int(last);
            }
          }
          const size_t n = static_cast<size_t>((cz * mc.cells.y + cy) * mc.cells.x + cx);
          for (int a = 0; a < 6; ++a) mc.box[n][static_cast<size_t>(a)] = static_cast<int16_t>(box[static_cast<size_t>(a)]);
        }
      }
  });
  return mc;
}

namespace {
// `body(n, box, face)` for every cell n of `cells` (in parallel): its block box, and whether it
// lies on the grid's faces.
template <class Body>
void forEachCell(const MapCells& cells, const Body& body) {
  const Dims& c = cells.cells;
  parallelFor(c.z, [&](int64_t z0, int64_t z1) {
    for (int64_t cz = z0; cz < z1; ++cz)
      for (int64_t cy = 0; cy < c.y; ++cy)
        for (int64_t cx = 0; cx < c.x; ++cx) {
          const size_t n = static_cast<size_t>((cz * c.y + cy) * c.x + cx);
          body(n, cells.box[n], isFaceCell(c, cx, cy, cz));
        }
  });
}
}  // namespace

std::vector<float> cellMaxValues(const MapCells& cells, const BlockRanges& ranges) {
  const Dims& nb = ranges.blocks;
  std::vector<float> out(cells.box.size());
  forEachCell(cells, [&](size_t n, const std::array<int16_t, 6>& b, bool face) {
    float m = face ? ranges.background : -INFINITY;
    for (int64_t z = b[2]; z <= b[5]; ++z)
      for (int64_t y = b[1]; y <= b[4]; ++y)
        for (int64_t x = b[0]; x <= b[3]; ++x)
          m = std::max(m, ranges.ownMax[static_cast<size_t>((z * nb.y + y) * nb.x + x)]);
    out[n] = m;
  });
  return out;
}

std::vector<uint8_t> coarseOccupancy(const std::vector<uint8_t>& occ, const Dims& blocks, Dims& coarse) {
  constexpr int f = kCoarseSkip;
  coarse = {(blocks.x + f - 1) / f, (blocks.y + f - 1) / f, (blocks.z + f - 1) / f};
  std::vector<uint8_t> out(static_cast<size_t>(coarse.voxelCount()), 0);
  parallelFor(coarse.z, [&](int64_t z0, int64_t z1) {
    for (int64_t cz = z0; cz < z1; ++cz)
      for (int64_t z = cz * f; z < std::min(blocks.z, (cz + 1) * f); ++z)
        for (int64_t y = 0; y < blocks.y; ++y)
          for (int64_t x = 0; x < blocks.x; ++x)
            if (occ[static_cast<size_t>((z * blocks.y + y) * blocks.x + x)])
              out[static_cast<size_t>((cz * coarse.y + y / f) * coarse.x + x / f)] = 255;
  });
  return out;
}

std::vector<uint8_t> cellOccupancy(const MapCells& cells, const std::vector<uint8_t>& blockOcc,
                                   const Dims& blocks, bool backgroundOcc) {
  // Summed-volume table of occupied blocks: any box query in O(1).
  const int64_t sx = blocks.x + 1, sy = blocks.y + 1;
  std::vector<int32_t> sum(static_cast<size_t>(sx * sy * (blocks.z + 1)), 0);
  auto at = [&](int64_t x, int64_t y, int64_t z) -> int32_t& {
    return sum[static_cast<size_t>((z * sy + y) * sx + x)];
  };
  for (int64_t z = 0; z < blocks.z; ++z)
    for (int64_t y = 0; y < blocks.y; ++y)
      for (int64_t x = 0; x < blocks.x; ++x)
        at(x + 1, y + 1, z + 1) = (blockOcc[static_cast<size_t>((z * blocks.y + y) * blocks.x + x)] ? 1 : 0) +
                                  at(x, y + 1, z + 1) + at(x + 1, y, z + 1) + at(x + 1, y + 1, z) -
                                  at(x, y, z + 1) - at(x, y + 1, z) - at(x + 1, y, z) + at(x, y, z);
  std::vector<uint8_t> occ(cells.box.size());
  forEachCell(cells, [&](size_t n, const std::array<int16_t, 6>& b, bool face) {
    const int64_t x0 = b[0], y0 = b[1], z0 = b[2], x1 = b[3] + 1, y1 = b[4] + 1, z1 = b[5] + 1;
    const int32_t total = at(x1, y1, z1) - at(x0, y1, z1) - at(x1, y0, z1) - at(x1, y1, z0) +
                          at(x0, y0, z1) + at(x0, y1, z0) + at(x1, y0, z0) - at(x0, y0, z0);
    occ[n] = total > 0 || (backgroundOcc && face) ? 255 : 0;
  });
  return occ;
}

}  // namespace vellum::render::detail
