#include "vellum/core/json_input.hpp"

#include <algorithm>
#include <fstream>
#include <string>

#include "vellum/core/error.hpp"
#include "vellum/core/memory_budget.hpp"

namespace vellum {
namespace {

/// One linear pass over the bytes, counting brackets outside strings.
void checkDepth(std::string_view text, const std::filesystem::path& source) {
  int depth = 0;
  bool inString = false, escaped = false;
  for (const char c : text) {
    if (inString) {
      if (escaped) escaped = false;
      else if (c == '\\') escaped = true;
      else if (c == '"') inString = false;
    } else if (c == '"') {
      inString = true;
    } else if (c == '[' || c == '{') {
      if (++depth > kMaxJsonDepth)
        throw FileError(source, "JSON nested deeper than " + std::to_string(kMaxJsonDepth) + " levels");
    } else if (c == ']' || c == '}') {
      depth = std::max(depth - 1, 0);  // a stray closer is the parser's error to report
    }
  }
}

/// nlohmann's message without its "[json.exception.parse_error.101] parse error at line 1,
/// column 2: " prefix, kept short: its "last read" token can be a whole long string.
std::string problemOf(const nlohmann::json::exception& e) {
  std::string m = e.what();
  if (const auto at = m.find("] "); m.rfind("[json.exception.", 0) == 0 && at != std::string::npos) m.erase(0, at + 2);
  if (const auto col = m.find(", column "); m.rfind("parse error at line ", 0) == 0 && col != std::string::npos)
    if (const auto colon = m.find(": ", col); colon != std::string::npos) m.erase(0, colon + 2);
  constexpr size_t kMaxProblem = 200;
  if (m.size() > kMaxProblem) m = m.substr(0, kMaxProblem - 3) + "...";
  std::replace_if(m.begin(), m.end(), [](unsigned char c) { return c < 0x20; }, ' ');
  return m;
}

}  // namespace

nlohmann::json parseJson(std::string_view text, const std::filesystem::path& source) {
  checkDepth(text, source);
  try {
    return nlohmann::json::parse(text.begin(), text.end());
  } catch (const nlohmann::json::parse_error& e) {
    const size_t end = std::min<size_t>(e.byte, text.size());
    const auto line = 1 + std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(end), '\n');
    throw FileError(source, "not valid JSON: line " + std::to_string(line) + ": " + problemOf(e));
  } catch (const nlohmann::json::exception& e) {  // e.g. out_of_range: a number beyond double
    throw FileError(source, "not valid JSON: " + problemOf(e));
  }
}

nlohmann::json readJsonFile(const std::filesystem::path& path, uint64_t maxBytes, const char* what) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const auto status = fs::status(path, ec);
  if (!fs::exists(status)) throw FileError(path, std::string("no such ") + what);
  if (fs::is_directory(status)) throw FileError(path, std::string("is a folder (a ") + what + " is expected)");
  if (!fs::is_regular_file(status)) throw FileError(path, std::string("not a regular file (a ") + what + " is expected)");
  const uint64_t size = fs::file_size(path, ec);
  if (ec) throw FileError(path, "cannot read the file size: " + ec.message());
  if (size > maxBytes)
    throw FileError(path, "is " + formatBytes(size) + ", more than the " + formatBytes(maxBytes) + " a " + what +
                              " may have");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError(path, std::string("cannot open the ") + what);
  std::string text(static_cast<size_t>(size), '\0');
  in.read(text.data(), static_cast<std::streamsize>(size));
  if (static_cast<uint64_t>(in.gcount()) != size) throw FileError(path, std::string("cannot read the ") + what);
  return parseJson(text, path);
}

}  // namespace vellum
