#pragma once
// Hostile JSON for the tests of every JSON reader (vellum/core/json_input.hpp): a file nested
// 200 000 levels deep (it crashed the style reader with SIGSEGV) and one a byte over the
// reader's size cap (sparse: it costs no disk, and must be refused before it is read).
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

#include "file_errors.hpp"

namespace vellum::test {

inline std::string deepJson(int levels = 200000) { return std::string(size_t(levels), '[') + std::string(size_t(levels), ']'); }

/// `read` reads `file` (directly, or through the file or folder that names it): the deep file
/// and a file of `capBytes` + 1 bytes each give one line of FileError naming `file`.
inline void expectHostileJsonRefused(const std::filesystem::path& file, uint64_t capBytes,
                                     const std::function<void()>& read) {
  const auto load = [&](const std::filesystem::path&) { read(); };
  EXPECT_NE(fileErrorOf(load, file, deepJson()).find("JSON nested deeper than 64 levels"), std::string::npos);
  const auto oversize = [&](const std::filesystem::path& f) {
    std::filesystem::resize_file(f, capBytes + 1);
    read();
  };
  EXPECT_NE(fileErrorOf(oversize, file, "{}").find("more than the"), std::string::npos);
}

}  // namespace vellum::test
