#pragma once
// Empty-space skipping for the GL ray caster: per block of kBlockSize^3 voxels the value
// range its samples can see (grown by one block on each side, so trilinear samples anywhere
// in the block are covered), and per render an occupancy bit: does the transfer function
// give any opacity in that range? Rays jump over unoccupied blocks; the picture is unchanged
// because every skipped sample would have had opacity exactly 0.
#include <cstdint>
#include <vector>

#include "render_common.hpp"
#include "vellum/core/volume.hpp"

namespace vellum::render::detail {

constexpr int kBlockSize = 8;

struct BlockRanges {
  Dims blocks;
  std::vector<float> minValue, maxValue;  ///< per block, x fastest
};

BlockRanges computeBlockRanges(const AnyVolume& volume);

/// 255 where the table has non-zero opacity anywhere in the block's range, else 0.
std::vector<uint8_t> blockOccupancy(const BlockRanges& ranges, const TfTable& tf);

}  // namespace vellum::render::detail
