#pragma once
// DICOM (GDCM) entry points used by volume_io.cpp. Private to the io module.
#include <filesystem>
#include <vector>

#include "vellum/io/volume_io.hpp"

namespace vellum::io::detail {

/// Scans `path` (a folder, recursively, or one file), groups files by SeriesInstanceUID,
/// picks options.seriesUid or the largest CT series, sorts slices along the slice normal,
/// applies rescale, returns int16 HU (background -1000) with geometry and warnings.
LoadedVolume loadDicom(const std::filesystem::path& path, const LoadOptions& options);

/// Writes `volume` as one CT Image Storage series (one file per slice) into folder `dir`
/// (created; written atomically as a whole folder).
void saveDicomSeries(const AnyVolume& volume, const std::filesystem::path& dir,
                     const SaveOptions& options);

/// True when the file starts with a DICOM preamble ("DICM" at byte 128) or parses as DICOM.
bool looksLikeDicom(const std::filesystem::path& file);

}  // namespace vellum::io::detail
