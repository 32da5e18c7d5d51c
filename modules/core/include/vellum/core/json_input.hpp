#pragma once
// The one way Vellum reads JSON that a user hands it (styles, scenes, studio scripts, curves,
// control points, keyframes, raw sidecars, shape reports). Size and nesting depth are checked
// before parsing: nlohmann's parser is iterative, but dump(), comparisons and the readers'
// error text walk values recursively, so a 200 000-deep "[[[...]]]" overflows the stack.
#include <cstdint>
#include <filesystem>
#include <string_view>

#include <nlohmann/json.hpp>

namespace vellum {

/// Deeper than any file Vellum writes (a scene is about 5 levels) and far from the stack's end.
inline constexpr int kMaxJsonDepth = 64;

/// Parses `text`, read from `source`. vellum::FileError naming `source`, one line:
/// "JSON nested deeper than 64 levels", "not valid JSON: line L: <problem>".
nlohmann::json parseJson(std::string_view text, const std::filesystem::path& source);

/// Reads and parses `path` as parseJson does; files above `maxBytes` (`what` names the kind:
/// "style file") are refused before they are read.
nlohmann::json readJsonFile(const std::filesystem::path& path, uint64_t maxBytes, const char* what);

}  // namespace vellum
