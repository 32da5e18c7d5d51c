#pragma once
// Image differences and PNG files for the renderer tests (OpenCV stays in the .cpp).
#include <array>
#include <cstdint>
#include <filesystem>
#include <vector>

#include "vellum/core/image.hpp"

namespace vellum::test {

struct ImageDiff {
  std::array<double, 4> meanAbs{};  ///< per channel, in 8-bit levels
  double p99 = 0;                   ///< 99th percentile of |difference| over all channels
  double maxAbs = 0;
  double psnr = 0;                  ///< dB over all channels; +inf when identical
};
/// Throws std::runtime_error when sizes differ. With a mask (one byte per pixel, non-zero =
/// compare), only the masked pixels count: so a shading error on a small object is not
/// diluted by a large, identical background.
ImageDiff compareImages(const RgbaImage& a, const RgbaImage& b, const std::vector<uint8_t>* mask = nullptr);
/// Pixels of either image whose RGBA differs from `background` (the object's footprint).
std::vector<uint8_t> objectMask(const RgbaImage& a, const RgbaImage& b, std::array<uint8_t, 4> background);

void writePng(const RgbaImage& image, const std::filesystem::path& path);
/// Empty image when the file does not exist or cannot be read.
RgbaImage readPng(const std::filesystem::path& path);

/// Left-right mirror.
RgbaImage mirrored(const RgbaImage& image);

}  // namespace vellum::test
