#include "image_compare.hpp"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <stdexcept>

namespace vellum::test {

ImageDiff compareImages(const RgbaImage& a, const RgbaImage& b, const std::vector<uint8_t>* mask) {
  if (a.width != b.width || a.height != b.height) throw std::runtime_error("image sizes differ");
  ImageDiff d;
  std::array<uint64_t, 256> histogram{};
  double sumSq = 0;
  size_t compared = 0;
  for (size_t i = 0; i < a.pixels.size(); ++i) {
    if (mask && !(*mask)[i / 4]) continue;
    ++compared;
    const int diff = std::abs(int(a.pixels[i]) - int(b.pixels[i]));
    d.meanAbs[i % 4] += diff;
    ++histogram[static_cast<size_t>(diff)];
    sumSq += double(diff) * diff;
    d.maxAbs = std::max(d.maxAbs, double(diff));
  }
  if (compared == 0) {
    d.psnr = std::numeric_limits<double>::infinity();
    return d;
  }
  const double pixels = double(compared / 4);
  for (double& m : d.meanAbs) m /= pixels;
  uint64_t seen = 0;
  for (int v = 0; v < 256; ++v) {
    seen += histogram[size_t(v)];
    if (double(seen) >= 0.99 * double(compared)) {
      d.p99 = v;
      break;
    }
  }
  const double mse = sumSq / double(compared);
  d.psnr = mse > 0 ? 10 * std::log10(255.0 * 255.0 / mse) : std::numeric_limits<double>::infinity();
  return d;
}

std::vector<uint8_t> objectMask(const RgbaImage& a, const RgbaImage& b, std::array<uint8_t, 4> background) {
  std::vector<uint8_t> mask(a.pixels.size() / 4, 0);
  for (size_t p = 0; p < mask.size(); ++p)
    mask[p] = std::memcmp(a.pixels.data() + 4 * p, background.data(), 4) != 0 ||
              std::memcmp(b.pixels.data() + 4 * p, background.data(), 4) != 0;
  return mask;
}

void writePng(const RgbaImage& image, const std::filesystem::path& path) {
  cv::Mat rgba(image.height, image.width, CV_8UC4, const_cast<uint8_t*>(image.pixels.data()));
  cv::Mat bgra;
  cv::cvtColor(rgba, bgra, cv::COLOR_RGBA2BGRA);
  if (!cv::imwrite(path.string(), bgra)) throw std::runtime_error("cannot write " + path.string());
}

RgbaImage readPng(const std::filesystem::path& path) {
  if (!std::filesystem::exists(path)) return {};
  const cv::Mat bgra = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  if (bgra.empty() || bgra.type() != CV_8UC4) return {};
  cv::Mat rgba;
  cv::cvtColor(bgra, rgba, cv::COLOR_BGRA2RGBA);
  RgbaImage out(rgba.cols, rgba.rows);
  for (int y = 0; y < rgba.rows; ++y) std::memcpy(out.at(0, y), rgba.ptr(y), size_t(rgba.cols) * 4);
  return out;
}

RgbaImage mirrored(const RgbaImage& image) {
  RgbaImage out(image.width, image.height);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      std::memcpy(out.at(image.width - 1 - x, y), image.at(x, y), 4);
  return out;
}

}  // namespace vellum::test
