// The OpenCV image codecs as a module that io opens on first use (image_codecs.cpp): linking
// libopencv_imgcodecs into every executable costs ~40 ms of dynamic loading at each start
// (it pulls ~95 further libraries: GDAL, Poppler, HDF5 ...), paid even by commands that never
// touch an image. Entry points have C names (found with dlsym) and report OpenCV exceptions
// as text.
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <string>
#include <vector>

extern "C" {

bool vellum_codecs_imwrite(const std::string* path, const cv::Mat* image, const std::vector<int>* params,
                           std::string* error) {
  try {
    return cv::imwrite(*path, *image, *params);
  } catch (const cv::Exception& e) {
    *error = e.what();
    return false;
  }
}

bool vellum_codecs_imread(const std::string* path, int flags, cv::Mat* out, std::string* error) {
  try {
    *out = cv::imread(*path, flags);
    return true;
  } catch (const cv::Exception& e) {
    *error = e.what();
    return false;
  }
}

bool vellum_codecs_imencode(const std::string* ext, const cv::Mat* image, std::vector<uchar>* out,
                            std::string* error) {
  try {
    return cv::imencode(*ext, *image, *out);
  } catch (const cv::Exception& e) {
    *error = e.what();
    return false;
  }
}

}  // extern "C"
