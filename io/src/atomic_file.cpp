#include "vellum/io/atomic_file.hpp"

#include <unistd.h>

#include <atomic>
#include <string>
#include <system_error>

#include "vellum/core/error.hpp"

namespace vellum::io {

namespace fs = std::filesystem;

namespace {

std::atomic<uint64_t> gCounter{0};

/// A hidden sibling that ends with the target's own file name, so the extension is kept
/// (OpenCV and VTK pick the format from it) and the rename stays on one file system.
fs::path uniqueSibling(const fs::path& target, const char* tag) {
  const fs::path folder = target.parent_path();
  for (int attempt = 0; attempt < 1000; ++attempt) {
    const std::string name = ".vellum-" + std::string(tag) + "-" + std::to_string(::getpid()) + "-" +
                             std::to_string(gCounter.fetch_add(1)) + "-" +
                             target.filename().string();
    fs::path p = folder.empty() ? fs::path(name) : folder / name;
    std::error_code ec;
    if (!fs::exists(p, ec)) return p;
  }
  throw FileError(target, "cannot find a free temporary name next to it");
}

void removeQuietly(const fs::path& p) {
  std::error_code ec;
  fs::remove_all(p, ec);
}

}  // namespace

void writeAtomically(const fs::path& target,
                     const std::function<void(const fs::path& tmp)>& write) {
  if (target.filename().empty()) throw FileError(target, "not a file or folder name");
  const fs::path folder = target.parent_path();
  std::error_code ec;
  if (!folder.empty() && !fs::is_directory(folder, ec))
    throw FileError(target, "folder " + folder.string() + " does not exist");

  const fs::path tmp = uniqueSibling(target, "tmp");
  try {
    write(tmp);
  } catch (...) {
    removeQuietly(tmp);
    throw;
  }

  const auto st = fs::status(tmp, ec);
  if (!fs::exists(st)) throw FileError(target, "writer produced no output");

  if (fs::is_directory(st)) {
    // Folders cannot be renamed over non-empty folders: move the old one aside first, so a
    // reader sees either the complete old or the complete new folder (never a mix).
    fs::path old;
    if (fs::exists(target, ec)) {
      old = uniqueSibling(target, "old");
      fs::rename(target, old, ec);
      if (ec) {
        removeQuietly(tmp);
        throw FileError(target, "cannot replace existing folder: " + ec.message());
      }
    }
    fs::rename(tmp, target, ec);
    if (ec) {
      const std::string why = ec.message();
      if (!old.empty()) fs::rename(old, target, ec);  // put the old one back
      removeQuietly(tmp);
      throw FileError(target, "cannot move new folder into place: " + why);
    }
    if (!old.empty()) removeQuietly(old);
    return;
  }

  if (fs::is_directory(target, ec)) {
    removeQuietly(tmp);
    throw FileError(target, "is a folder; refusing to replace it with a file");
  }
  fs::rename(tmp, target, ec);  // atomic replacement on POSIX
  if (ec) {
    removeQuietly(tmp);
    throw FileError(target, "cannot rename temporary file into place: " + ec.message());
  }
}

}  // namespace vellum::io
