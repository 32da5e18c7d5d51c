// The output policy (output_policy.hpp): folder markers, input/output overlap, same-kind
// replacement.
#include "vellum/io/output_policy.hpp"

#include <algorithm>
#include <array>
#include <fstream>
#include <optional>

#include "io_detail.hpp"
#include "vellum/core/error.hpp"
#include "vellum/io/replaced_files.hpp"

namespace vellum::io {

namespace fs = std::filesystem;

namespace {

constexpr std::array<FolderKind, 5> kFolderKinds{FolderKind::DicomSeries, FolderKind::Shape, FolderKind::Frames,
                                                 FolderKind::Demo, FolderKind::Qa};

std::string lowerExtension(const fs::path& p) { return detail::lower(p.extension().string()); }

bool present(const fs::path& p) {
  std::error_code ec;
  return fs::exists(fs::symlink_status(p, ec));
}

/// Absolute, symlinks resolved as far as the path exists, "." and ".." gone.
fs::path resolvedPath(const fs::path& p) {
  std::error_code ec;
  fs::path c = fs::weakly_canonical(fs::absolute(p, ec), ec);
  return ec ? fs::absolute(p).lexically_normal() : c;
}

/// The same file: one canonical path, or two names (hard links) of one existing file.
bool sameFile(const fs::path& a, const fs::path& b) {
  if (resolvedPath(a) == resolvedPath(b)) return true;
  std::error_code ec;
  return fs::exists(a, ec) && fs::exists(b, ec) && fs::equivalent(a, b, ec);
}

/// `inner` lies strictly inside `folder`.
bool inside(const fs::path& inner, const fs::path& folder) {
  const fs::path i = resolvedPath(inner), f = resolvedPath(folder);
  auto [fi, ii] = std::mismatch(f.begin(), f.end(), i.begin(), i.end());
  return fi == f.end() && ii != i.end();
}

/// The first `n` bytes of a file ("" when unreadable).
std::string head(const fs::path& p, size_t n) {
  std::ifstream in(p, std::ios::binary);
  std::string s(n, '\0');
  in.read(s.data(), static_cast<std::streamsize>(n));
  s.resize(static_cast<size_t>(std::max<std::streamsize>(in.gcount(), 0)));
  return s;
}

/// The detached data file a NRRD or MetaImage header names, resolved against its folder ("" when
/// attached, a list or pattern, or unreadable): the readers' own header parsers say.
fs::path detachedDataFile(const fs::path& header) {
  const std::string ext = lowerExtension(header);
  std::string name;
  if (ext == ".nhdr" || ext == ".nrrd") name = detail::nrrdDataFileName(header);
  else if (ext == ".mhd" || ext == ".mha") name = detail::metaDataFileName(header);
  if (name.empty() || name.rfind("LIST", 0) == 0 || name.find(' ') != std::string::npos ||
      name.find('%') != std::string::npos)
    return {};
  const fs::path p(name);
  return p.is_absolute() ? p : header.parent_path() / p;
}

/// Marks `folder` as Vellum's output of `kind`.
void writeMarker(const fs::path& folder, FolderKind kind) {
  detail::writeBinaryFile(folder / folderMarkerName(kind),
                          std::string("Written by Vellum: this folder holds a ") + folderKindName(kind) +
                              " output and may be replaced by the next one.\n",
                          {});
}

/// The kind of folder `folder` holds by its marker, if any.
std::optional<FolderKind> markedKind(const fs::path& folder) {
  for (FolderKind k : kFolderKinds)
    if (present(folder / folderMarkerName(k))) return k;
  return std::nullopt;
}

/// Whether the first bytes of an existing file are the format its extension names (formats
/// without a signature, and empty files, pass).
bool looksLikeFormat(const fs::path& p, const std::string& ext) {
  const std::string h = head(p, 1024);
  if (h.empty()) return true;
  auto startsWith = [&](std::string_view s) { return h.compare(0, s.size(), s) == 0; };
  if (ext == ".nrrd" || ext == ".nhdr") return startsWith("NRRD");
  if (ext == ".png") return startsWith("\x89PNG");
  if (ext == ".tif" || ext == ".tiff") return startsWith(std::string_view("II*\0", 4)) || startsWith(std::string_view("MM\0*", 4));
  if (ext == ".mp4" || ext == ".mov") return h.size() >= 8 && h.compare(4, 4, "ftyp") == 0;
  if (ext == ".json") {
    const size_t first = h.find_first_not_of(" \t\r\n");
    return first == std::string::npos || h[first] == '{' || h[first] == '[';
  }
  if (ext == ".vti") return h.find("<VTKFile") != std::string::npos;
  if (ext == ".mhd" || ext == ".mha") return h.find("NDims") != std::string::npos || h.find("ObjectType") != std::string::npos;
  if (ext == ".ply") return startsWith("ply");
  if (ext == ".raw") return present(fs::path(p.string() + ".json"));  // a RAW volume Vellum wrote has its sidecar
  return true;
}

}  // namespace

const char* folderKindName(FolderKind kind) {
  switch (kind) {
    case FolderKind::DicomSeries: return "series";
    case FolderKind::Shape: return "shape";
    case FolderKind::Frames: return "frames";
    case FolderKind::Demo: return "demo";
    case FolderKind::Qa: return "qa";
  }
  return "folder";
}

std::string folderMarkerName(FolderKind kind) { return std::string(".vellum-") + folderKindName(kind); }

void checkFolderOutput(const fs::path& folder, FolderKind kind, bool force) {
  std::error_code ec;
  if (!present(folder)) return;
  if (!fs::is_directory(folder, ec))
    throw FileError(folder, std::string("exists and is not a folder; refusing to replace it with a ") +
                                folderKindName(kind) + " folder");
  const auto marked = markedKind(folder);
  if (!marked) {
    if (fs::is_empty(folder, ec)) return;  // an empty folder holds nothing to lose
    throw FileError(folder, "is a folder Vellum did not write (no " + folderMarkerName(kind) +
                                " marker in it); refusing to replace it: choose a new folder name");
  }
  if (*marked != kind && !force)
    throw FileError(folder, std::string("holds a Vellum ") + folderKindName(*marked) + " folder, not a " +
                                folderKindName(kind) + " folder; --force replaces it");
}

void writeFolderAtomically(const fs::path& target, FolderKind kind, const std::function<void(const fs::path&)>& write,
                           bool force) {
  if (target.filename().empty()) throw FileError(target, "not a folder name");
  std::error_code ec;
  const fs::path parent = target.parent_path();
  if (!parent.empty() && !fs::is_directory(parent, ec))
    throw FileError(target, "folder " + parent.string() + " does not exist");
  checkFolderOutput(target, kind, force);

  const fs::path tmp = detail::temporarySibling(target, "tmp");
  detail::writeTemporary(target, tmp, [&](const fs::path& t) {
    fs::create_directory(t);
    write(t);
    writeMarker(t, kind);
  });

  // Folders cannot be renamed over non-empty folders: move the old one aside first, so a
  // reader sees either the complete old or the complete new folder (never a mix).
  fs::path old;
  if (present(target)) {
    checkFolderOutput(target, kind, force);  // again: the work may have taken minutes
    old = detail::temporarySibling(target, "old");
    fs::rename(target, old, ec);
    if (ec) {
      detail::removeTemporary(tmp);
      throw FileError(target, "cannot replace the existing folder: " + ec.message());
    }
  }
  fs::rename(tmp, target, ec);
  if (ec) {
    const std::string why = ec.message();
    if (!old.empty()) fs::rename(old, target, ec);  // put the old one back
    detail::removeTemporary(tmp);
    throw FileError(target, "cannot move the new folder into place: " + why);
  }
  if (!old.empty() && !ReplacedFiles::adoptOldFolder(target, old)) detail::removeTemporary(old);
}

void prepareFolderInPlace(const fs::path& folder, FolderKind kind, bool force) {
  checkFolderOutput(folder, kind, force);
  std::error_code ec;
  fs::create_directories(folder, ec);
  if (ec) throw FileError(folder, "cannot create the folder: " + ec.message());
  for (FolderKind k : kFolderKinds)
    if (k != kind) fs::remove(folder / folderMarkerName(k), ec);  // --force changed its kind
  writeMarker(folder, kind);
}

std::vector<fs::path> filesReadFrom(const fs::path& path) {
  std::vector<fs::path> files{path};
  std::error_code ec;
  if (fs::is_directory(path, ec)) return files;
  const std::string ext = lowerExtension(path);
  if (ext == ".raw") files.push_back(path.string() + ".json");
  if (fs::path data = detachedDataFile(path); !data.empty()) files.push_back(data);
  return files;
}

std::vector<fs::path> filesWrittenTo(const fs::path& path, bool gzip) {
  // The names the writers give (nrrd_writer.cpp, metaimage.cpp, raw.cpp).
  const std::string ext = lowerExtension(path);
  if (ext == ".nhdr") return {path, path.parent_path() / (path.stem().string() + (gzip ? ".raw.gz" : ".raw"))};
  if (ext == ".mhd") return {path, path.parent_path() / (path.stem().string() + ".raw")};
  if (ext == ".raw") return {path, path.string() + ".json"};
  return {path};
}

void checkFileOutput(const fs::path& path, const std::string& format) {
  std::error_code ec;
  if (!present(path)) return;
  if (fs::is_directory(path, ec)) throw FileError(path, "is a folder; refusing to replace it with a file");
  const std::string ext = format.empty() ? lowerExtension(path) : format;
  if (!looksLikeFormat(path, ext))
    throw FileError(path, "exists and is not a " + (ext.empty() ? std::string("file") : ext.substr(1) + " file") +
                              " Vellum could have written; refusing to replace it");
}

OutputPlan& OutputPlan::input(const fs::path& path, const std::string& what) {
  if (!path.empty()) inputs_.push_back({path, what, filesReadFrom(path)});
  return *this;
}

OutputPlan& OutputPlan::output(const fs::path& path, const std::string& what, bool gzip) {
  const std::string ext = lowerExtension(path);
  if (!path.empty() && (ext.empty() || ext == ".dcm")) return folder(path, FolderKind::DicomSeries, what);
  if (!path.empty()) outputs_.push_back({path, what, filesWrittenTo(path, gzip)});
  return *this;
}

OutputPlan& OutputPlan::json(const fs::path& path, const std::string& what) {
  if (!path.empty()) outputs_.push_back({path, what, {path}, false, FolderKind::DicomSeries, ".json"});
  return *this;
}

OutputPlan& OutputPlan::folder(const fs::path& path, FolderKind kind, const std::string& what) {
  if (!path.empty()) outputs_.push_back({path, what, {path}, true, kind});
  return *this;
}

void OutputPlan::check() const {
  // An input named as an output first: it says the most about the slip.
  for (const Entry& out : outputs_)
    for (const Entry& in : inputs_)
      for (const fs::path& w : out.files)
        for (const fs::path& r : in.files) {
          if (sameFile(w, r)) {
            const std::string whose = w == out.path ? std::string() : "its file " + w.string() + " ";
            throw FileError(out.path, whose + "is " + in.what + " (" + r.string() + "); refusing to overwrite an input");
          }
          if (out.isFolder && inside(r, out.path))
            throw FileError(out.path, "the folder holds " + in.what + " (" + r.string() + "); refusing to replace it");
        }
  for (size_t a = 0; a < outputs_.size(); ++a)
    for (size_t b = a + 1; b < outputs_.size(); ++b)
      for (const fs::path& x : outputs_[a].files)
        for (const fs::path& y : outputs_[b].files)
          if (sameFile(x, y) || (outputs_[a].isFolder && inside(y, x)) || (outputs_[b].isFolder && inside(x, y)))
            throw FileError(outputs_[b].path, outputs_[a].what + " and " + outputs_[b].what + " would overwrite each other");
  for (const Entry& out : outputs_) {
    if (out.isFolder) {
      checkFolderOutput(out.path, out.kind, force_);
      continue;
    }
    checkFileOutput(out.path, out.format);
    // A detached data file may replace only the one its own header names.
    const fs::path owned = present(out.path) ? detachedDataFile(out.path) : fs::path();
    for (size_t i = 1; i < out.files.size(); ++i) {
      const fs::path& extra = out.files[i];
      if (!present(extra) || lowerExtension(extra) == ".json") continue;
      if (owned.empty() || !sameFile(owned, extra))
        throw FileError(out.path, "its data file " + extra.string() + " already exists and is not " +
                                      out.path.filename().string() + "'s own; refusing to overwrite it");
    }
  }
}

}  // namespace vellum::io
