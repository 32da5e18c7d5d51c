#pragma once
// Image differences and PNG files for the renderer tests (OpenCV stays in the .cpp).
#include <array>
#include <filesystem>

#include "vellum/core/image.hpp"

namespace vellum::test {

struct ImageDiff {
  std::array<double, 4> meanAbs{};  ///< per channel, in 8-bit levels
  double p99 = 0;                   ///< 99th percentile of |difference| over all channels
  double maxAbs = 0;
  double psnr = 0;                  ///< dB over all channels; +inf when identical
};
/// Throws std::runtime_error when sizes differ.
ImageDiff compareImages(const RgbaImage& a, const RgbaImage& b);

void writePng(const RgbaImage& image, const std::filesystem::path& path);
/// Empty image when the file does not exist or cannot be read.
RgbaImage readPng(const std::filesystem::path& path);

/// Left-right mirror.
RgbaImage mirrored(const RgbaImage& image);

}  // namespace vellum::test
