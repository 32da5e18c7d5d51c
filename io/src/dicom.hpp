#pragma once
// DICOM (GDCM) entry points used by volume_io.cpp. Private to the io module.
//
// Reading (loadDicom):
//  - A folder is scanned recursively (or one file is read). Every file is first walked
//    structurally without GDCM (GDCM aborts on some damaged files); non-DICOM files are skipped
//    and counted in the warnings; a damaged DICOM file (truncated, corrupt, no image) that may
//    belong to the loaded series is a FileError naming it.
//  - Files are grouped by SeriesInstanceUID; options.seriesUid picks one, else the series with
//    the most images among CT series (else among all). LoadedVolume::series lists them all.
//  - Slices (single-frame files and frames of enhanced multi-frame files, whose geometry comes
//    from the shared and per-frame functional groups) are sorted along the slice normal
//    (row cosine x column cosine), never by file name or InstanceNumber.
//  - Geometry: origin = ImagePositionPatient of the first slice after sorting; direction
//    columns = row cosine, column cosine, normal; spacing = PixelSpacing[1] (between columns,
//    x), PixelSpacing[0] (between rows, y), and the MEASURED slice spacing along the normal
//    (SliceThickness is ignored; a single slice uses SpacingBetweenSlices, else
//    SliceThickness, else 1 mm).
//  - Values: stored value (BitsStored/HighBit/PixelRepresentation applied) * RescaleSlope +
//    RescaleIntercept, rounded and saturated to int16 (a warning counts saturated values).
//    Background -1000 for CT, 0 otherwise.
//  - Irregular stacks are never loaded silently wrong: uneven spacing or missing slices are
//    resampled onto a regular grid (spacing = the smallest gap, or the median gap when the
//    smallest is under half of it) by linear interpolation along the normal; slice origins
//    shifted in-plane (gantry tilt) are shear-corrected onto an orthogonal grid (bilinear
//    in-plane, background outside the acquired slices); both add a warning with the numbers.
//    Slices at the same position: identical pixels -> dropped with a warning; different
//    pixels -> FileError. Mixed image sizes, orientations or pixel spacings -> FileError.
//  - Progress: "scanning DICOM headers" per file, "decoding DICOM slices" per image,
//    "resampling DICOM slices" per output slice; cancellation throws vellum::Cancelled.
#include <filesystem>
#include <vector>

#include "vellum/io/volume_io.hpp"

namespace vellum::io::detail {

/// Scans `path` (a folder, recursively, or one file), groups files by SeriesInstanceUID,
/// picks options.seriesUid or the largest CT series, sorts slices along the slice normal,
/// applies rescale, returns int16 HU (background -1000) with geometry and warnings.
LoadedVolume loadDicom(const std::filesystem::path& path, const LoadOptions& options);

/// Writes `volume` as one series into folder `dir` (created; written atomically as a whole
/// folder through io::writeAtomically; an existing folder is replaced): one file per slice
/// named IMG0001.dcm..., explicit VR little endian, CT Image Storage when options.modality is
/// "CT" (Secondary Capture otherwise, with the given Modality), new Study/Series/Frame of
/// Reference UIDs and one SOPInstanceUID per slice, IPP per slice from the geometry, IOP from
/// the first two direction columns, PixelSpacing, SliceThickness = SpacingBetweenSlices = the
/// slice spacing, WindowCenter/Width covering the value range, PatientName "Vellum^Phantom".
/// Pixels are signed 16-bit: int16 and uint8 stored as is (slope 1, intercept 0); uint16 above
/// 32767 shifted exactly (slope 1, intercept 32768 + min); float stored exactly when integral
/// in the int16 range, else slope = range / 65534 and intercept = mid-range. A left-handed
/// direction is written faithfully (IPPs follow the third column); it reads back with the
/// slice axis reversed (same physical volume). Dims above 65535 per slice -> FileError.
void saveDicomSeries(const AnyVolume& volume, const std::filesystem::path& dir,
                     const SaveOptions& options);

/// True when the file has the DICOM preamble or meta header, or parses as a DICOM data set.
bool looksLikeDicom(const std::filesystem::path& file);

}  // namespace vellum::io::detail
