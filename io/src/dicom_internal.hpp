#pragma once
// Internals of the DICOM reader shared by dicom_*.cpp (private to io/src). No GDCM here: the
// scan (dicom_scan.cpp) and pixel decoding (dicom_pixels.cpp) hide GDCM; slice ordering and
// resampling (dicom_slices.cpp) are plain geometry, testable without files.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "vellum/core/progress.hpp"
#include "vellum/core/vec.hpp"
#include "vellum/core/volume.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::io::detail::dicom {

namespace fs = std::filesystem;

/// One 2D image: a single-frame file, or one frame of an enhanced multi-frame file.
struct Frame {
  fs::path file;
  int64_t frameIndex = 0;           ///< frame number inside the file (0 for single-frame)
  std::optional<Vec3> position;     ///< ImagePositionPatient (mm)
  std::optional<Vec3> rowCosine;    ///< IOP[0..2]: direction of increasing column index (i)
  std::optional<Vec3> colCosine;    ///< IOP[3..5]: direction of increasing row index (j)
  std::optional<double> rowSpacing; ///< PixelSpacing[0]: between rows (along j, "y")
  std::optional<double> colSpacing; ///< PixelSpacing[1]: between columns (along i, "x")
  double slope = 1.0, intercept = 0.0;
  double sliceThickness = 0.0;      ///< informational only; spacing is measured
  double spacingBetweenSlices = 0.0;
  int64_t instanceNumber = 0;
};

/// Header facts of one DICOM file (read without pixel data).
struct FileHeader {
  fs::path file;
  std::string seriesUid, modality, description, sopClassUid, sopInstanceUid;
  int64_t rows = 0, columns = 0, frameCount = 1;
  // Image pixel module, validated by the scan (GDCM asserts on some invalid values).
  int bitsAllocated = 16, bitsStored = 16, highBit = 15;
  bool signedPixels = false;       ///< PixelRepresentation 1
  bool monochrome1 = false;        ///< PhotometricInterpretation MONOCHROME1 (display only)
  std::vector<Frame> frames;  ///< one per frame (enhanced) or exactly one
};

/// A file that looks like DICOM but cannot be read (truncated, corrupt).
struct Unreadable {
  fs::path file;
  std::string problem;
  std::string seriesUid;  ///< when it could be recovered before the damage, else empty
};

/// Everything found under a path.
struct ScanResult {
  std::vector<FileHeader> images;     ///< DICOM image files with a SeriesInstanceUID
  int64_t skippedNonDicom = 0;        ///< files that are not DICOM at all
  int64_t skippedNonImage = 0;        ///< DICOM without pixel rows/columns (DICOMDIR, SR...)
  std::vector<Unreadable> unreadable; ///< DICOM-looking files that cannot be read
};

/// Result of the structural pre-check (dicom_structure.cpp).
struct StructureCheck {
  bool ok = false;         ///< every element, sequence and item fits in the file
  bool dicomLike = false;  ///< has the "DICM" preamble or a file meta group
  std::string problem;     ///< why not ok
  std::string seriesUid;   ///< SeriesInstanceUID when met before any damage
};

/// Walks the element structure of a file without GDCM (which aborts on some damaged files):
/// preamble, meta group, every element length, sequences and items, to the end of the file.
StructureCheck checkStructure(const fs::path& file);

/// Scans a folder recursively (or one file). A single file that is not readable DICOM throws
/// FileError; in a folder such files are counted and skipped. Reports progress per file.
ScanResult scan(const fs::path& path, Progress* progress);

/// One SeriesInfo per SeriesInstanceUID, largest (most frames) first.
std::vector<SeriesInfo> summarize(const ScanResult& scan);

/// Slices of one series in physical order, plus the regular output grid.
struct SlicePlan {
  std::vector<Frame> slices;  ///< unique positions, sorted along the normal (ascending)
  /// For each slice, frames at the same position (exact duplicates are dropped after their
  /// pixels are compared; conflicting ones are refused).
  std::vector<std::vector<Frame>> duplicates;
  std::vector<double> offsets;      ///< slice position along the normal, relative to slice 0 (mm)
  std::vector<Vec3> inPlaneShift;   ///< slice origin minus slice 0 origin, in pixels (i, j, 0)
  Geometry geometry;                ///< output grid (origin = IPP of slice 0)
  bool resample = false;            ///< output slices differ from the input ones
  std::vector<std::string> warnings;
};

/// Validates one series' frames (sizes, orientations, spacings; FileError naming a file) and
/// sorts them along the slice normal; detects uneven spacing, gaps and gantry tilt.
SlicePlan planSlices(std::vector<Frame> frames, int64_t rows, int64_t columns);

/// Decodes every frame of a scanned file through GDCM (any transfer syntax GDCM supports),
/// applies each frame's rescale, rounds and saturates to int16, and calls
/// sink(frameIndex, values) with rows*columns values (i fastest) per frame. Returns how many
/// values were saturated. Throws FileError naming the file on missing or truncated pixel data,
/// size mismatches and undecodable data. With `storedValues` the rescale is skipped (the
/// caller applies one fractional slope itself, to keep non-integer values).
int64_t decodeFile(const FileHeader& header,
                   const std::function<void(int64_t frame, const int16_t* values)>& sink,
                   bool storedValues = false);

/// Resamples the stack (one input slice per plan slice, i fastest) onto plan.geometry:
/// linear along the normal between neighbouring slices, bilinear in-plane for shifted
/// (tilted) slices, background outside.
void resampleStack(const SlicePlan& plan, const std::vector<int16_t>& stack, VolumeI16& out,
                   double background, Progress* progress);

/// Repairs single mis-registered slices of the decoded stack (one slice per plan slice, i
/// fastest) in place: a slice whose correlation with both neighbours drops far below theirs
/// with each other, and that an in-plane shift brings back into line, is replaced by
/// interpolating its neighbours (linear along the normal). One warning per repaired slice,
/// naming its file, the shift and the correlations. Returns how many slices were replaced.
int64_t repairMisregisteredSlices(const SlicePlan& plan, int16_t* stack, int64_t columns, int64_t rows,
                                  std::vector<std::string>& warnings);

/// "1.234" style short number for messages.
std::string num(double v, int decimals = 3);

}  // namespace vellum::io::detail::dicom
