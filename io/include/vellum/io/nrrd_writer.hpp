#pragma once
// The one NRRD writer (and atomic text writer) of Vellum: volumes, label maps and the
// deformation's vector-valued backward maps all go through it, so gzip, byte order, temporary
// files and error messages behave the same everywhere.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "vellum/core/geometry.hpp"
#include "vellum/core/progress.hpp"

namespace vellum::io {

/// What a NRRD file holds, beyond the fields the writer owns (magic, endian, encoding,
/// data file): samples of `type` over optional leading non-spatial axes, then the three
/// domain axes of `geometry` (x fastest after the leading axes).
struct NrrdLayout {
  std::string type;                        ///< NRRD type name: "float", "short", "unsigned char", ...
  std::vector<int64_t> leadingSizes;       ///< e.g. {3} for a vector per voxel
  std::vector<std::string> leadingKinds;   ///< e.g. {"vector"}; same length as leadingSizes
  Geometry geometry;                       ///< the domain axes (sizes, space directions, origin)
  std::vector<std::string> comments;       ///< "# ..." lines
  std::string extraFields;                 ///< further complete header lines ("key:=value\n" ...)
};

/// Writes `bytes` (host byte order) as a NRRD file, atomically. A `.nhdr` path writes a
/// detached header plus `<stem>.raw[.gz]` beside it. gzip is io::gzipCompress (one gzip
/// stream of blocks deflated in parallel at a fast level: CT and float fields gain little from
/// more effort). Throws
/// vellum::FileError naming `path`; vellum::Cancelled when `progress` is cancelled (nothing is
/// left behind either way).
void writeNrrd(const std::filesystem::path& path, const NrrdLayout& layout, const void* bytes,
               size_t byteCount, bool gzip, Progress* progress = nullptr);

/// Writes `text` to `path` atomically (temporary sibling + rename). FileError naming `path`.
void writeTextFile(const std::filesystem::path& path, const std::string& text);

}  // namespace vellum::io
