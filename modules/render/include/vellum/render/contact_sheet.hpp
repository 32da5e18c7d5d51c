#pragma once
// Several figures of the same size laid out in a grid: the demo's overview and comparison
// plates (e.g. plain DVR / colour shading / opacity modulation side by side).
#include <vector>

#include "vellum/core/image.hpp"

namespace vellum::render {

/// Tiles (all the same size) row by row, `columns` per row; empty cells stay transparent.
/// Throws vellum::Error for no tiles, columns < 1 or tiles of different sizes.
RgbaImage contactSheet(const std::vector<RgbaImage>& tiles, int columns);

}  // namespace vellum::render
