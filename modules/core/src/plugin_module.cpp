#include "vellum/core/plugin_module.hpp"

#include <dlfcn.h>

#include <cstdlib>

#include "vellum/core/error.hpp"

namespace vellum {

PluginModule::PluginModule(std::string what, const char* envVar, const std::string& builtInFile)
    : what_(std::move(what)) {
  const char* env = envVar ? std::getenv(envVar) : nullptr;
  file_ = env && *env ? env : builtInFile;
  handle_ = ::dlopen(file_.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle_) {
    const char* why = ::dlerror();
    problem_ = "cannot load " + what_ + " " + file_ + " (" + (why ? why : "unknown error") + ")";
  }
}

void* PluginModule::symbol(const char* name) const {
  if (!handle_) throw Error(problem_);
  void* address = ::dlsym(handle_, name);
  if (!address) throw Error(what_ + " " + file_ + " lacks the entry point " + name);
  return address;
}

}  // namespace vellum
