#pragma once
// The user's per-application folders (XDG base directories): where the studio keeps what is
// the user's and not the data's (recent files, autosaves).
#include <filesystem>

namespace vellum::studio {

/// `$<xdgVariable>/vellum` when that variable holds an absolute path (the XDG rule: relative
/// values are ignored), else `$HOME/<underHome>/vellum`; empty when neither is set.
std::filesystem::path userFolder(const char* xdgVariable, const std::filesystem::path& underHome);

}  // namespace vellum::studio
