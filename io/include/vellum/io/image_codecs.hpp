#pragma once
// OpenCV's image codecs (imread, imwrite, imencode), loaded on first use from a module
// (io/codecs), so executables do not link libopencv_imgcodecs: its ~95 dependencies (GDAL,
// Poppler, HDF5 ...) cost ~40 ms of dynamic loading at every start, also for commands that
// never touch an image. Callers include OpenCV's core header themselves; this one only names
// cv::Mat. The module's path is built in; VELLUM_CODECS_MODULE overrides it.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace cv {
class Mat;
}

namespace vellum::io::codecs {

/// cv::imwrite. False when OpenCV cannot write; `error` holds OpenCV's exception text when it
/// threw. vellum::Error when the codec module cannot be loaded.
bool imwrite(const std::filesystem::path& path, const cv::Mat& image, const std::vector<int>& params,
             std::string& error);
/// cv::imread into `out` (empty when the file cannot be decoded). False when OpenCV threw.
bool imread(const std::filesystem::path& path, int flags, cv::Mat& out, std::string& error);
/// cv::imencode (`ext` such as ".png"). False when encoding failed or OpenCV threw.
bool imencode(const std::string& ext, const cv::Mat& image, std::vector<uint8_t>& out, std::string& error);

}  // namespace vellum::io::codecs
