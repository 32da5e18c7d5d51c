#pragma once
// Figures (PNG, TIFF, JPEG) through OpenCV, written atomically.
#include <filesystem>

#include "vellum/core/image.hpp"

namespace vellum::io {

/// Writes PNG (with alpha), TIFF (with alpha) or JPEG (alpha dropped) by extension.
/// Throws vellum::FileError for an unsupported extension or a failed write.
void saveImage(const RgbaImage& image, const std::filesystem::path& path);
/// Reads any image OpenCV reads into RGBA; throws vellum::FileError when it cannot.
RgbaImage loadImage(const std::filesystem::path& path);

}  // namespace vellum::io
