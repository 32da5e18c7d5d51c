// Opens the OpenCV codec module (io/codecs/opencv_codecs_module.cpp) on first use.
#include "vellum/io/image_codecs.hpp"

#include "vellum/core/plugin_module.hpp"

#ifndef VELLUM_CODECS_MODULE_PATH
#error "VELLUM_CODECS_MODULE_PATH (the codec module's file) must be defined by the build"
#endif

namespace vellum::io::codecs {
namespace {

using ImwriteFn = bool (*)(const std::string*, const cv::Mat*, const std::vector<int>*, std::string*);
using ImreadFn = bool (*)(const std::string*, int, cv::Mat*, std::string*);
using ImencodeFn = bool (*)(const std::string*, const cv::Mat*, std::vector<uint8_t>*, std::string*);

struct Module {
  ImwriteFn imwrite = nullptr;
  ImreadFn imread = nullptr;
  ImencodeFn imencode = nullptr;
};

const Module& module() {
  static const PluginModule file("the image codec module", "VELLUM_CODECS_MODULE", VELLUM_CODECS_MODULE_PATH);
  static const Module m{reinterpret_cast<ImwriteFn>(file.symbol("vellum_codecs_imwrite")),
                        reinterpret_cast<ImreadFn>(file.symbol("vellum_codecs_imread")),
                        reinterpret_cast<ImencodeFn>(file.symbol("vellum_codecs_imencode"))};
  return m;
}

}  // namespace

bool imwrite(const std::filesystem::path& path, const cv::Mat& image, const std::vector<int>& params,
             std::string& error) {
  const std::string p = path.string();
  return module().imwrite(&p, &image, &params, &error);
}

bool imread(const std::filesystem::path& path, int flags, cv::Mat& out, std::string& error) {
  const std::string p = path.string();
  return module().imread(&p, flags, &out, &error);
}

bool imencode(const std::string& ext, const cv::Mat& image, std::vector<uint8_t>& out, std::string& error) {
  return module().imencode(&ext, &image, &out, &error);
}

}  // namespace vellum::io::codecs
