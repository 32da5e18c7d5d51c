// Figures through OpenCV, written atomically (the temporary keeps the extension because
// cv::imwrite picks the encoder from it). The codecs are loaded on first use (image_codecs.hpp).
#include "vellum/io/image_io.hpp"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cctype>
#include <cstring>

#include "vellum/core/error.hpp"
#include "vellum/io/atomic_file.hpp"
#include "vellum/io/image_codecs.hpp"

namespace vellum::io {

namespace fs = std::filesystem;

namespace {
std::string lowerExt(const fs::path& p) {
  std::string e = p.extension().string();
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}
}  // namespace

void saveImage(const RgbaImage& image, const fs::path& path) {
  const std::string ext = lowerExt(path);
  const bool jpeg = ext == ".jpg" || ext == ".jpeg";
  if (!jpeg && ext != ".png" && ext != ".tif" && ext != ".tiff")
    throw FileError(path, "unsupported image extension '" + ext + "' (.png, .tif, .tiff, .jpg, .jpeg)");
  if (image.width <= 0 || image.height <= 0 ||
      image.pixels.size() != static_cast<size_t>(image.width) * image.height * 4)
    throw FileError(path, "image is empty or its pixel buffer does not match " +
                              std::to_string(image.width) + "x" + std::to_string(image.height));
  const cv::Mat rgba(image.height, image.width, CV_8UC4, const_cast<uint8_t*>(image.pixels.data()));
  cv::Mat out;
  cv::cvtColor(rgba, out, jpeg ? cv::COLOR_RGBA2BGR : cv::COLOR_RGBA2BGRA);
  std::vector<int> params;
  if (jpeg) params = {cv::IMWRITE_JPEG_QUALITY, 95};
  writeAtomically(path, [&](const fs::path& tmp) {
    std::string error;
    const bool ok = codecs::imwrite(tmp, out, params, error);
    if (!error.empty()) throw FileError(path, "OpenCV could not write the image: " + error);
    if (!ok) throw FileError(path, "OpenCV could not write the image");
  });
}

RgbaImage loadImage(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw FileError(path, "no such file");
  cv::Mat m;
  std::string error;
  if (!codecs::imread(path, cv::IMREAD_UNCHANGED, m, error)) throw FileError(path, "cannot decode image: " + error);
  if (m.empty()) throw FileError(path, "cannot decode image (unsupported or corrupt)");
  if (m.depth() == CV_16U) m.convertTo(m, CV_8U, 1.0 / 257.0);
  else if (m.depth() != CV_8U) m.convertTo(m, CV_8U);
  cv::Mat rgba;
  switch (m.channels()) {
    case 1: cv::cvtColor(m, rgba, cv::COLOR_GRAY2RGBA); break;
    case 3: cv::cvtColor(m, rgba, cv::COLOR_BGR2RGBA); break;
    case 4: cv::cvtColor(m, rgba, cv::COLOR_BGRA2RGBA); break;
    default: throw FileError(path, "images with " + std::to_string(m.channels()) + " channels are not supported");
  }
  RgbaImage img(rgba.cols, rgba.rows);
  for (int y = 0; y < rgba.rows; ++y)
    std::memcpy(img.at(0, y), rgba.ptr<uint8_t>(y), static_cast<size_t>(rgba.cols) * 4);
  return img;
}

}  // namespace vellum::io
