#include "vellum/render/contact_sheet.hpp"

#include <algorithm>

#include "vellum/core/error.hpp"

namespace vellum::render {

RgbaImage contactSheet(const std::vector<RgbaImage>& tiles, int columns) {
  if (tiles.empty() || columns < 1) throw Error("contact sheet: no tiles or no columns");
  const int w = tiles.front().width, h = tiles.front().height;
  for (const auto& t : tiles)
    if (t.width != w || t.height != h) throw Error("contact sheet: tiles differ in size");
  const int rows = (static_cast<int>(tiles.size()) + columns - 1) / columns;
  RgbaImage sheet(w * columns, h * rows);
  for (size_t t = 0; t < tiles.size(); ++t) {
    const int ox = static_cast<int>(t) % columns * w, oy = static_cast<int>(t) / columns * h;
    for (int y = 0; y < h; ++y) std::copy_n(tiles[t].at(0, y), w * 4, sheet.at(ox, oy + y));
  }
  return sheet;
}

}  // namespace vellum::render
