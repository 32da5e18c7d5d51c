#pragma once
// RgbaImage: 8-bit RGBA pixels, rows top to bottom (what figures and movies are made of).
#include <cstddef>
#include <cstdint>
#include <vector>

namespace vellum {

struct RgbaImage {
  int width = 0;
  int height = 0;
  std::vector<uint8_t> pixels;  ///< width*height*4 bytes, row 0 = top

  RgbaImage() = default;
  RgbaImage(int w, int h) : width(w), height(h), pixels(static_cast<size_t>(w) * h * 4, 0) {}
  uint8_t* at(int x, int y) { return pixels.data() + (static_cast<size_t>(y) * width + x) * 4; }
  const uint8_t* at(int x, int y) const {
    return pixels.data() + (static_cast<size_t>(y) * width + x) * 4;
  }
};

}  // namespace vellum
