#pragma once
// Loading and saving volumes and label maps in every supported format.
//
// Format is chosen from the path:
//   folder or *.dcm         DICOM (read: a folder is scanned recursively for series;
//                                 write: a folder receives one CT Image Storage series)
//   *.nrrd, *.nhdr          NRRD (raw or gzip encoding)
//   *.raw                   headerless raw + JSON sidecar "<name>.raw.json"; or, without a
//                           sidecar, the layout given in LoadOptions::raw
//   *.mhd, *.mha            MetaImage
//   *.nii, *.nii.gz         NIfTI-1 (read only)
//   *.vti                   VTK XML image data
// Every loader validates what it reads and throws vellum::FileError naming the file and the
// problem (truncated, wrong magic, absurd dims, zero/NaN spacing ...). Writers write to a
// temporary file next to the target and rename it into place (atomic); what they may replace
// is the output policy's (output_policy.hpp: never an input, never a folder Vellum did not write).
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "vellum/core/label_volume.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/core/region.hpp"
#include "vellum/core/volume.hpp"

namespace vellum::io {

enum class Endian { Little, Big };

/// Layout of a bare .raw file with no sidecar (CLI: --raw-dims/--raw-type/--raw-spacing/--raw-endian).
struct RawLayout {
  Dims dims;
  VoxelType type = VoxelType::Int16;
  Endian endian = Endian::Little;
  Vec3 spacing{1, 1, 1};
  Vec3 origin{0, 0, 0};
  Mat3 direction;
  uint64_t headerBytes = 0;  ///< bytes to skip at the start of the file
};

/// One DICOM series found while scanning a folder.
struct SeriesInfo {
  std::string uid;
  std::string modality;
  std::string description;
  std::string sopClassUid;
  int64_t fileCount = 0;
  int64_t rows = 0, columns = 0;
  int64_t frames = 0;  ///< slices (single-frame files) or frames (enhanced multi-frame)
};

struct LoadOptions {
  std::string seriesUid;            ///< DICOM: load this series (default: largest CT series)
  std::optional<RawLayout> raw;     ///< bare .raw without sidecar
  Progress* progress = nullptr;     ///< optional progress/cancellation
  /// Keep only this part (crop, then downsample: block mean for volumes, block mode for
  /// label maps), applied right after decoding; the file is read whole once.
  Region region;
  /// {slope, intercept}: stored value * slope + intercept, applied first, makes the volume CT
  /// (int16 HU, rounded and saturated, background -1000). For data that is not in HU, e.g.
  /// CT numbers 0..4095 from a bare RAW: {1, -1024}.
  std::optional<std::pair<double, double>> rescale;
  /// NRRD (.nhdr "data file") and MetaImage (.mhd "ElementDataFile"): read a data file that is
  /// absolute or lies outside the header's folder ("..", a symlink leading out). Off by default:
  /// a downloaded header must not be a way to read any file the user can (CLI:
  /// --allow-outside-data).
  bool allowOutsideData = false;
  /// DICOM: repair single bad slices (a missing slice: a gap of about two spacings; a
  /// mis-registered one: shifted in-plane against both neighbours) by interpolating its
  /// neighbours, with a load warning naming the slice (CLI: --no-slice-repair turns it off).
  bool repairSlices = true;
};

struct LoadedVolume {
  AnyVolume volume;
  std::string format;                 ///< "dicom", "nrrd", "raw", "metaimage", "nifti", "vti"
  std::string modality;               ///< "CT", "MR", ... ("" when the format does not say)
  std::vector<std::string> warnings;  ///< e.g. "uneven slice spacing 2.5..5.0 mm: resampled to 2.5 mm"
  std::vector<SeriesInfo> series;     ///< DICOM: every series found (the loaded one included)
  std::string seriesUid;              ///< DICOM: the series that was loaded
};

/// Loads a volume. CT data is returned as int16 HU with background -1000; other data keep
/// their stored type with background 0.
LoadedVolume loadVolume(const std::filesystem::path& path, const LoadOptions& options = {});

/// Lists the DICOM series under a folder (or in one file) without loading pixel data.
std::vector<SeriesInfo> listDicomSeries(const std::filesystem::path& path);

struct SaveOptions {
  std::string format;          ///< override the extension-based choice: "dicom", "nrrd", ...
  bool gzip = true;            ///< NRRD: gzip encoding (raw otherwise)
  std::string modality = "CT"; ///< DICOM: written as CT Image Storage when "CT"
  std::string seriesDescription = "Vellum";
  Progress* progress = nullptr;
  /// DICOM: replace a folder Vellum wrote as another kind of output (output_policy.hpp); a
  /// folder Vellum did not write is never replaced.
  bool force = false;
};

/// Saves a volume (format from the extension, or options.format). Atomic: a reader never
/// sees a half-written file.
void saveVolume(const AnyVolume& volume, const std::filesystem::path& path,
                const SaveOptions& options = {});

/// Label maps: NRRD with the label table in the header ("vellum_label_<id>:=name r g b"
/// key/value pairs, plus Slicer-style segment fields) — readable as a plain label NRRD by
/// other tools. Stored as uint8 when every id fits, uint16 otherwise. Other formats carry
/// the ids only.
LabelVolume loadLabels(const std::filesystem::path& path, const LoadOptions& options = {});
void saveLabels(const LabelVolume& labels, const std::filesystem::path& path,
                const SaveOptions& options = {});

/// Lower-case format name for a path, as used above; throws vellum::FileError when unknown.
std::string formatForPath(const std::filesystem::path& path);

}  // namespace vellum::io
