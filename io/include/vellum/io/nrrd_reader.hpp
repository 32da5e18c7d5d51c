#pragma once
// The NRRD reader for samples that are not a plain volume (e.g. the deformation's backward
// maps, a 3-vector per voxel): the same header parsing, encodings (raw, gzip, ascii; attached
// or detached .nhdr), byte orders and error messages as io's volume loader.
#include <cstdint>
#include <filesystem>
#include <vector>

#include "vellum/core/progress.hpp"
#include "vellum/io/nrrd_writer.hpp"

namespace vellum::io {

/// A NRRD file as read.
struct NrrdContents {
  /// type: canonical NRRD name ("signed char", "uchar", "short", "ushort", "int", "uint",
  /// "float", "double"); at most one leading non-spatial axis (its kind, or "???" when the
  /// file has none); geometry in LPS. Comments and extra fields are not kept.
  NrrdLayout layout;
  std::vector<uint8_t> bytes;  ///< the samples in host byte order, leading axis fastest
};

/// Reads `path`; vellum::FileError naming the file (or its data file) for anything wrong. A
/// detached header's data file must lie in the header's folder (LoadOptions::allowOutsideData).
NrrdContents readNrrd(const std::filesystem::path& path, Progress* progress = nullptr);

/// The header only (type, leading axes, geometry), checked as readNrrd checks it (the data
/// file must exist), without reading the samples: for a caller that needs a file's grid.
NrrdLayout readNrrdHeader(const std::filesystem::path& path);

}  // namespace vellum::io
