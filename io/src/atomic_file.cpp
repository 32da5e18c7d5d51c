#include "vellum/io/atomic_file.hpp"

#include <unistd.h>

#include <atomic>
#include <string>
#include <system_error>

#include "vellum/core/error.hpp"
#include "vellum/io/replaced_files.hpp"

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

/// A FileError about the hidden temporary names the target instead: users know the target.
[[noreturn]] void rethrowNamingTarget(const fs::path& tmp, const fs::path& target) {
  try {
    throw;
  } catch (const FileError& e) {
    const std::string where = e.path().string(), what = e.what();
    if (where.rfind(tmp.string(), 0) != 0 || what.rfind(where + ": ", 0) != 0) throw;
    // A file inside a temporary folder keeps its name relative to the folder.
    const fs::path rel = e.path().lexically_relative(tmp);
    throw FileError(rel.empty() || rel == "." ? target : target / rel, what.substr(where.size() + 2));
  }
}

}  // namespace

namespace detail {

fs::path temporarySibling(const fs::path& target, const char* tag) { return uniqueSibling(target, tag); }

void removeTemporary(const fs::path& p) { removeQuietly(p); }

void writeTemporary(const fs::path& target, const fs::path& tmp, const std::function<void(const fs::path&)>& write) {
  try {
    write(tmp);
  } catch (...) {
    removeQuietly(tmp);
    rethrowNamingTarget(tmp, target);
  }
}

}  // namespace detail

void writeAtomically(const fs::path& target,
                     const std::function<void(const fs::path& tmp)>& write) {
  if (target.filename().empty()) throw FileError(target, "not a file or folder name");
  const fs::path folder = target.parent_path();
  std::error_code ec;
  if (!folder.empty() && !fs::is_directory(folder, ec))
    throw FileError(target, "folder " + folder.string() + " does not exist");
  if (fs::is_directory(target, ec)) throw FileError(target, "is a folder; refusing to replace it with a file");

  const fs::path tmp = uniqueSibling(target, "tmp");
  detail::writeTemporary(target, tmp, write);

  const auto st = fs::status(tmp, ec);
  if (!fs::exists(st)) throw FileError(target, "writer produced no output");
  if (fs::is_directory(st)) {
    removeQuietly(tmp);
    throw FileError(target, "a folder output must be written with writeFolderAtomically");
  }
  if (fs::is_directory(target, ec)) {
    removeQuietly(tmp);
    throw FileError(target, "is a folder; refusing to replace it with a file");
  }
  ReplacedFiles::keepBeforeReplacing(target);  // a run that fails later puts it back
  fs::rename(tmp, target, ec);  // atomic replacement on POSIX
  if (ec) {
    removeQuietly(tmp);
    throw FileError(target, "cannot rename temporary file into place: " + ec.message());
  }
}

}  // namespace vellum::io
