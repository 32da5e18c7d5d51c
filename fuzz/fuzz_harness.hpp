#pragma once
// Shared body of the file-reader fuzz harnesses: the input bytes are written to a file with
// the reader's extension and handed to the reader, exactly as a user's file would be.
// A reader may refuse the input only with vellum::Error (a one-line, named message);
// anything else — a crash, a sanitizer report, another exception type, a hang — is a bug.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>

#include "vellum/core/error.hpp"

namespace vellum::fuzz {

/// A per-process scratch folder (removed at exit) holding the current input file.
inline const std::filesystem::path& scratchDir() {
  // Never destroyed: the atexit handler below runs after static destructors would have.
  static const auto* dir = [] {
    auto* d = new std::filesystem::path(std::filesystem::temp_directory_path() /
                                        ("vellum-fuzz-" + std::to_string(::getpid())));
    std::filesystem::create_directories(*d);
    std::atexit([] {
      std::error_code ignored;
      std::filesystem::remove_all(scratchDir(), ignored);
    });
    return d;
  }();
  return *dir;
}

inline std::filesystem::path writeInput(const uint8_t* data, size_t size, const std::string& name) {
  const auto path = scratchDir() / name;
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(reinterpret_cast<const char*>(data),
                                                               static_cast<std::streamsize>(size));
  return path;
}

/// Runs `read`; vellum::Error is the only acceptable way to refuse an input.
template <class F>
void expectCleanRefusal(F&& read) {
  try {
    read();
  } catch (const vellum::Error&) {
  } catch (const std::exception& e) {
    std::fprintf(stderr, "reader threw a non-vellum exception: %s\n", e.what());
    std::abort();
  }
}

}  // namespace vellum::fuzz
