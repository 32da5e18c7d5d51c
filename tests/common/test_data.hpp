#pragma once
// Locating the third-party sample data (../shared/data) for integration tests.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <unistd.h>

namespace vellum::test {

/// The sample-data folder: $VELLUM_DATA_DIR if set, else the CMake option.
inline std::filesystem::path dataDir() {
  if (const char* env = std::getenv("VELLUM_DATA_DIR"); env && *env) return env;
  return VELLUM_DATA_DIR;
}

/// A fresh, empty temporary folder for one test.
inline std::filesystem::path tempDir(const std::string& name) {
  auto dir = std::filesystem::temp_directory_path() / ("vellum-test-" + name + "-" +
                                                       std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace vellum::test

/// Skips the current test with a message when the sample data (or one entry in it) is absent.
#define VELLUM_REQUIRE_DATA(relative)                                                       \
  do {                                                                                      \
    if (!std::filesystem::exists(::vellum::test::dataDir() / (relative)))                  \
      GTEST_SKIP() << "sample data not found: " << (::vellum::test::dataDir() / (relative)) \
                   << " (set VELLUM_DATA_DIR)";                                              \
  } while (0)
