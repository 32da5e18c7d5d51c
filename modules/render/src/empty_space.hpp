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
/// Coarse skipping blocks: kCoarseSkip^3 skipping blocks (source blocks or map cells) each, so
/// that a ray crosses empty space a coarse block per step (map cells are only s voxels wide).
constexpr int kCoarseSkip = 4;

struct BlockRanges {
  Dims blocks;
  std::vector<float> minValue, maxValue;  ///< per block, x fastest
  /// Per block: the range of its own voxels only (blocks on the grid's faces: and the
  /// background). Map cells use these: they add their own voxel of trilinear support to what
  /// they read, so the air next to tissue is not counted occupied a whole block further out.
  std::vector<float> ownMin, ownMax;
  float background = 0;  ///< the volume's background value (read outside its voxels)
};

BlockRanges computeBlockRanges(const AnyVolume& volume);

/// 255 where the table has non-zero opacity anywhere in the block's range, else 0.
std::vector<uint8_t> blockOccupancy(const BlockRanges& ranges, const TfTable& tf);
/// The same for each block's own range (BlockRanges::ownMin/ownMax): what cellOccupancy reads.
std::vector<uint8_t> ownBlockOccupancy(const BlockRanges& ranges, const TfTable& tf);
/// 255 where the table gives the background value (BlockRanges::background) opacity, else 0.
uint8_t backgroundOccupancy(const BlockRanges& ranges, const TfTable& tf);

/// The same for a backward map: per map cell (the box between 2x2x2 nodes; cells on the
/// grid's faces also cover the half-node margin) the source blocks its samples can read.
/// Trilinear u stays inside the bounding box of the cell's 8 corner u's, so that box, grown by
/// one voxel (the trilinear support) and clamped to the volume, holds every voxel a sample
/// reads: the blocks it touches, by their own ranges (whose face blocks include the
/// background), are conservative. The cells on the map grid's faces also see the background
/// (the output box's fade, PreparedMap::outputWeight).
struct MapCells {
  Dims cells;                            ///< max(nodes - 1, 1) per axis
  /// Per cell: inclusive block range x0,y0,z0,x1,y1,z1 (16 bits: a 512^2 x 350 map has 12 M
  /// cells, made every movie frame).
  std::vector<std::array<int16_t, 6>> box;
};
/// Whether cell (cx, cy, cz) of `cells` lies on the grid's faces (it also sees the background).
inline bool isFaceCell(const Dims& cells, int64_t cx, int64_t cy, int64_t cz) {
  return cx == 0 || cy == 0 || cz == 0 || cx + 1 == cells.x || cy + 1 == cells.y || cz + 1 == cells.z;
}
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
/// `storage`: a box vector to fill (a former map's: no fresh memory when it has the size).
MapCells computeMapCells(const Dims& nodes, const std::vector<float>& mapIndex,
                         const BlockRanges& ranges, const MapCellSupport* support = nullptr,
                         std::vector<std::array<int16_t, 6>> storage = {});
/// The coarse blocks' occupancy (kCoarseSkip^3 blocks of `occ` each, the last ones partial):
/// 255 where any of their blocks is occupied. `coarse` gets their count per axis.
std::vector<uint8_t> coarseOccupancy(const std::vector<uint8_t>& occ, const Dims& blocks, Dims& coarse);

/// Per cell: the largest value its samples can see (MIP skipping; made when a MIP is drawn, not
/// with the cells: a DVR movie frame never needs it).
std::vector<float> cellMaxValues(const MapCells& cells, const BlockRanges& ranges);

/// Per cell: 255 if any block in its box is occupied (`blockOcc`: ownBlockOccupancy), or it
/// lies on the grid's faces and the background is (`backgroundOcc`).
std::vector<uint8_t> cellOccupancy(const MapCells& cells, const std::vector<uint8_t>& blockOcc,
                                   const Dims& blocks, bool backgroundOcc);

}  // namespace vellum::render::detail
