#pragma once
// Atomic output: write to a temporary sibling, then rename over the target.
#include <filesystem>
#include <functional>

namespace vellum::io {

/// Calls write(tmpPath) with a unique temporary path in the target's folder, then renames it
/// onto `target`. On any exception the temporary is removed and the target is untouched.
/// Works for files and for folders (e.g. a DICOM series): for a folder, an existing target
/// folder is replaced only after the new one is complete.
void writeAtomically(const std::filesystem::path& target,
                     const std::function<void(const std::filesystem::path& tmp)>& write);

}  // namespace vellum::io
