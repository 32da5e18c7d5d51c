#pragma once
// Error types. Every message is one line that names the offending file or parameter.
#include <filesystem>
#include <stdexcept>
#include <string>

namespace vellum {

/// Base of all Vellum errors; what() is a complete, user-facing one-line message.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A problem with one file: message is "<path>: <problem>".
class FileError : public Error {
 public:
  FileError(const std::filesystem::path& path, const std::string& problem)
      : Error(path.string() + ": " + problem), path_(path) {}
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

/// The user cancelled a long operation through its Progress object.
class Cancelled : public Error {
 public:
  Cancelled() : Error("cancelled") {}
};

}  // namespace vellum
