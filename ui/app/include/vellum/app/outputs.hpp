#pragma once
// Output rules every pipeline (and every `vellum` command) follows: never overwrite the
// input, create the output's folder, write JSON atomically.
#include <nlohmann/json.hpp>

#include <filesystem>

namespace vellum::app {

/// Throws vellum::Error if `out` is the same file or folder as `in` (Vellum never
/// overwrites its input).
void refuseOverwritingInput(const std::filesystem::path& in, const std::filesystem::path& out);

/// Creates the parent folder of `path` if needed.
void ensureParentFolder(const std::filesystem::path& path);

/// Writes JSON text atomically (pretty-printed, trailing newline), creating the folder.
void writeJsonFile(const nlohmann::json& j, const std::filesystem::path& path);

}  // namespace vellum::app
