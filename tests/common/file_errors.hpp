#pragma once
// Bad-input tests: the one-line vellum::Error a call must raise (errorOf), and the
// vellum::FileError that loading a written file must raise (fileErrorOf); a test failure, and
// "", for no error.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

#include "vellum/core/error.hpp"

namespace vellum::test {

/// The one-line vellum::Error (or FileError) `run` throws; "" and a failure otherwise.
inline std::string errorOf(const std::function<void()>& run) {
  try {
    run();
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_EQ(m.find('\n'), std::string::npos) << "not one line: " << m;
    return m;
  }
  ADD_FAILURE() << "no error";
  return "";
}

/// With `namesFile`, the message must also name `file` (errors about a file it references name
/// that one instead).
inline std::string fileErrorOf(const std::function<void(const std::filesystem::path&)>& load,
                               const std::filesystem::path& file, const std::string& text, bool namesFile = true) {
  std::ofstream(file, std::ios::binary) << text;
  try {
    load(file);
  } catch (const FileError& e) {
    const std::string m = e.what();
    if (namesFile) {
      EXPECT_NE(m.find(file.filename().string()), std::string::npos) << m;
    }
    EXPECT_EQ(m.find('\n'), std::string::npos) << "not one line: " << m;
    return m;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "not a vellum::FileError: " << e.what() << "\n  input: " << text;
    return "";
  }
  ADD_FAILURE() << "no error for: " << text;
  return "";
}

}  // namespace vellum::test
