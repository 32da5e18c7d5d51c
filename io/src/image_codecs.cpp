// Opens the OpenCV codec module (io/codecs/opencv_codecs_module.cpp) on first use.
#include "vellum/io/image_codecs.hpp"

#include <dlfcn.h>

#include <cstdlib>

#include "vellum/core/error.hpp"

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
  std::string problem;  ///< why it could not be loaded (empty when loaded)
};

Module open() {
  Module m;
  const char* env = std::getenv("VELLUM_CODECS_MODULE");
  const std::string file = env && *env ? env : VELLUM_CODECS_MODULE_PATH;
  void* handle = ::dlopen(file.c_str(), RTLD_NOW | RTLD_LOCAL);  // kept open for the process
  if (!handle) {
    const char* why = ::dlerror();
    m.problem = "cannot load the image codec module " + file + " (" + (why ? why : "unknown error") + ")";
    return m;
  }
  m.imwrite = reinterpret_cast<ImwriteFn>(::dlsym(handle, "vellum_codecs_imwrite"));
  m.imread = reinterpret_cast<ImreadFn>(::dlsym(handle, "vellum_codecs_imread"));
  m.imencode = reinterpret_cast<ImencodeFn>(::dlsym(handle, "vellum_codecs_imencode"));
  if (!m.imwrite || !m.imread || !m.imencode) m.problem = "the image codec module " + file + " lacks an entry point";
  return m;
}

const Module& module() {
  static const Module m = open();  // once, thread-safe
  if (!m.problem.empty()) throw Error(m.problem);
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
