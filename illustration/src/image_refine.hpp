#pragma once
// Image-space refinement of the illustration ray caster (internal; GL and CPU reference alike).
//
// An illustration is mostly smooth fills, so not every pixel needs its own ray: the caster
// first traces every 2^levels-th pixel in x and y, then, level by level, halves the spacing:
// a tile of 4 x 4 points of the finer level is traced where the coarser points around it
// (3 x 3) disagree (a colour range or a curvature above the tolerance) or where one of them
// passed near ink it did not draw (a silhouette line, hatching, a crease: Level::near), and
// interpolated from them (bilinear) elsewhere. A tile is 4 x 4 fragments of the level's
// target, one llvmpipe block: a traced tile costs its 16 rays, a skipped one nothing.
#include <cstdint>
#include <functional>
#include <vector>

#include "vellum/core/image.hpp"

namespace vellum::illustration::detail {

/// One level: points (i * spacing, j * spacing) of the image, i < nx, j < ny (a margin of
/// points past the image edge; nx and ny are multiples of 4, so tiles are whole).
struct RefineLevel {
  int spacing = 1, nx = 0, ny = 0;
  std::vector<float> rgba;  ///< nx * ny * 4: straight colour and alpha, 0..1 (the shader's output)
  std::vector<float> near;  ///< nx * ny: pixels from the nearest undrawn ink (<= 0: on it)
};
/// A run of tiles of one tile row: points [4 x0, 4 x1) x [4 y, 4 y + 4) of the level.
struct TileRun {
  int y = 0, x0 = 0, x1 = 0;
};
/// Traces the points of `runs` into level.rgba / level.near (the other points must stay as
/// they are).
using TraceRuns = std::function<void(RefineLevel& level, const std::vector<TileRun>& runs)>;

struct RefineStats {
  int64_t traced = 0;  ///< rays traced, all levels
  int levels = 0;
};

/// The refined width x height image: `levels` coarse levels (0: every pixel traced, one
/// level), `tolerance` the largest colour range (0..1 per channel) or estimated interpolation
/// error left to interpolation. Quantised as the GL target does (round to nearest).
RgbaImage refineImage(int width, int height, int levels, float tolerance, const TraceRuns& trace,
                      RefineStats* stats = nullptr);

}  // namespace vellum::illustration::detail
