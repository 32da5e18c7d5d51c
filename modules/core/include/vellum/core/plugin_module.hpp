#pragma once
// Shared objects opened on first use (dlopen), for libraries whose dynamic loading would cost
// every command tens of milliseconds at start-up even when it never uses them (OpenCV's image
// codecs, OpenVDB). The module's file is built in; an environment variable overrides it.
#include <string>

namespace vellum {

/// An opened module, or why it could not be opened. Modules stay open for the process.
class PluginModule {
 public:
  /// Opens `envVar`'s file when that variable is set and not empty, else `builtInFile`.
  /// `what` names the module in messages ("the image codec module").
  PluginModule(std::string what, const char* envVar, const std::string& builtInFile);
  /// The address of the C entry point `name`; throws vellum::Error naming the module and
  /// the file when the module could not be opened or lacks the symbol.
  void* symbol(const char* name) const;

 private:
  std::string what_, file_, problem_;
  void* handle_ = nullptr;
};

}  // namespace vellum
