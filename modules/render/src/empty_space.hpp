#pragma once
// Empty-space skipping for the GL ray caster: per block of kBlockSize^3 voxels the value
// range its samples can see (grown by one block on each side, so trilinear samples anywhere
// in the block are covered), and per render an occupancy bit: does the transfer function
// give any opacity in that range? Rays jump over unoccupied blocks; the picture is unchanged
// because every skipped sample would have had opacity exactly 0.
#include <array>
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

/// The same for a backward map: per map cell (the box between 2x2x2 nodes; cells on the
/// grid's faces also cover the half-node margin) the source blocks its samples can read.
/// Trilinear u stays inside the bounding box of the cell's 8 corner u's, so that box (grown
/// by one voxel, clamped to the volume, whose face blocks include the background) is
/// conservative.
struct MapCells {
  Dims cells;                            ///< max(nodes - 1, 1) per axis
  /// Per cell: inclusive block range x0,y0,z0,x1,y1,z1 (16 bits: a 512^2 x 350 map has 12 M
  /// cells, made every movie frame).
  std::vector<std::array<int16_t, 6>> box;
  std::vector<float> maxValue;           ///< per cell: largest value its samples can see
};
/// Which texels of the map texture a cell's samples read, and how far beyond their bounding box
/// u can go: trilinear reads the cell's corner nodes; the Gaussian kernel (positive weights, so u
/// stays in the box too) reads texels cx .. cx + 4 of the padded texture; a rigid snap moves u
/// by up to maxSnapMm.
struct MapCellSupport {
  Dims texDims;          ///< dims of mapIndex (the nodes, or the padded Gaussian texture)
  int lo = 0, hi = 1;    ///< texels cx + lo .. cx + hi per axis
  double marginVoxels = 0;  ///< extra source voxels of margin (snap)
};
/// `mapIndex`: source index coordinates per texel (3 floats, x fastest); default support:
/// trilinear over the nodes themselves.
MapCells computeMapCells(const Dims& nodes, const std::vector<float>& mapIndex,
                         const BlockRanges& ranges, const MapCellSupport* support = nullptr);
/// Per cell: 255 if any block in its box is occupied.
std::vector<uint8_t> cellOccupancy(const MapCells& cells, const std::vector<uint8_t>& blockOcc,
                                   const Dims& blocks);

}  // namespace vellum::render::detail
