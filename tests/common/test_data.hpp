#pragma once
// Locating the third-party sample data (../shared/data) for integration tests.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>
#include <unistd.h>
#include <vector>

namespace vellum::test {

/// The sample-data folder: $VELLUM_DATA_DIR if set, else the CMake option.
inline std::filesystem::path dataDir() {
  if (const char* env = std::getenv("VELLUM_DATA_DIR"); env && *env) return env;
  return VELLUM_DATA_DIR;
}

namespace detail {
/// Folders made by tempDir() during the running test.
inline std::vector<std::filesystem::path>& tempDirsOfThisTest() {
  static std::vector<std::filesystem::path> dirs;
  return dirs;
}
/// Removes the running test's temporary folders when it ends, passed or failed, so that a
/// run of the suite leaves nothing in the system temp folder.
class TempDirCleaner : public ::testing::EmptyTestEventListener {
  void OnTestEnd(const ::testing::TestInfo&) override {
    for (const auto& dir : tempDirsOfThisTest()) {
      std::error_code ignored;  // best effort: a failing removal must not fail the test
      std::filesystem::remove_all(dir, ignored);
    }
    tempDirsOfThisTest().clear();
  }
};
// Registered once per test executable (an inline variable is initialised once).
inline const bool tempDirCleanerRegistered = [] {
  ::testing::UnitTest::GetInstance()->listeners().Append(new TempDirCleaner);
  return true;
}();
}  // namespace detail

/// A fresh, empty temporary folder for one test; removed with its contents when the test
/// ends (on success and on failure). Set VELLUM_KEEP_TEST_FILES=1 to keep it for debugging.
inline std::filesystem::path tempDir(const std::string& name) {
  auto dir = std::filesystem::temp_directory_path() / ("vellum-test-" + name + "-" +
                                                       std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  if (const char* keep = std::getenv("VELLUM_KEEP_TEST_FILES"); !keep || std::string(keep) != "1")
    detail::tempDirsOfThisTest().push_back(dir);
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
