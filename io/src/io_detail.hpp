#pragma once
// Shared helpers of the io module's format readers and writers (private to io/src).
#include <bit>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "vellum/core/error.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::io::detail {

namespace fs = std::filesystem;

/// Sample types found in files; loaders convert them to one of the four Volume types.
enum class SampleType { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

uint64_t sampleSize(SampleType t);
const char* sampleTypeName(SampleType t);
SampleType sampleTypeFor(VoxelType t);
constexpr Endian hostEndian() {
  return std::endian::native == std::endian::little ? Endian::Little : Endian::Big;
}

/// Size of a regular file; FileError "no such file" / "not a regular file".
uint64_t fileSize(const fs::path& path);
/// Whole small text/binary file (header); refuses files above `maxBytes`.
std::string readSmallFile(const fs::path& path, uint64_t maxBytes = 64u << 20);
/// The data file `name` that the detached header `header` names, relative to the header's
/// folder. FileError naming the header when it is absolute or lies outside that folder (after
/// "..", symlinks), unless `allowOutside` (LoadOptions::allowOutsideData).
fs::path headerDataFile(const fs::path& header, const std::string& name, bool allowOutside);
/// The name of the detached data file a NRRD header ("data file") or MetaImage header
/// ("ElementDataFile") gives, as written, read with the format's own header parser; "" when
/// the data are attached (LOCAL), the header is not one of these or cannot be read.
std::string nrrdDataFileName(const fs::path& header);
std::string metaDataFileName(const fs::path& header);
/// FileError "truncated: ..." unless the file holds `count` bytes from `offset`.
void checkFileHolds(const fs::path& path, uint64_t offset, uint64_t count);
/// Exactly `count` bytes from `offset` into `dst` (large pread calls, no staging copy);
/// FileError when the file ends early. Progress per 16 MiB.
void readInto(const fs::path& path, uint64_t offset, uint64_t count, uint8_t* dst, Progress* progress);
/// Exactly `count` bytes from `offset`; FileError when the file is shorter (truncated).
/// Checks the memory budget before allocating and reports progress per 16 MiB chunk.
std::vector<uint8_t> readBytes(const fs::path& path, uint64_t offset, uint64_t count,
                               Progress* progress);
/// Inflates a zlib or gzip stream (one or more members) that must decode to exactly
/// `expected` bytes (io::inflateExactInto into a new buffer; compression.cpp).
std::vector<uint8_t> inflateExact(const fs::path& path, const uint8_t* src, size_t n,
                                  uint64_t expected);

/// The voxels of `v` as bytes in host order (writers store host order and say so), no copy.
struct ByteView {
  const uint8_t* data = nullptr;
  size_t size = 0;
};
ByteView voxelBytes(const AnyVolume& v);
/// Writes prefix + body to `tmp` in 16 MiB chunks, reporting to `progress` (which may cancel:
/// vellum::Cancelled propagates and writeAtomically removes the temporary); FileError on
/// failure (disk full ...).
void writeBinaryFile(const fs::path& tmp, const std::string& prefix, ByteView body,
                     Progress* progress = nullptr);

/// A free hidden name next to `target` (".vellum-TAG-<pid>-<n>-<name>"): same folder, so the
/// final rename stays on one file system (atomic_file.cpp).
fs::path temporarySibling(const fs::path& target, const char* tag);
/// Removes a temporary file or folder, ignoring errors.
void removeTemporary(const fs::path& path);
/// Runs write(tmp); on any exception removes `tmp` and rethrows, a FileError about `tmp` (or
/// a file inside it) renamed to name `target`.
void writeTemporary(const fs::path& target, const fs::path& tmp, const std::function<void(const fs::path&)>& write);

/// Turns `bytes` (geometry.dims.voxelCount() samples of `type`, byte order `endian`) into a
/// volume. int8 -> int16; int32/uint32 -> int16 or uint16 when every value fits, else float32;
/// float64 -> float32 (FileError when a value exceeds the float range). Consumes `bytes`.
AnyVolume decodeVoxels(const fs::path& path, std::vector<uint8_t>&& bytes, SampleType type,
                       Endian endian, const Geometry& geometry);

/// The volume for `type` samples: fill(dst, bytes) writes the file's samples straight into the
/// volume's buffer when they are a Volume type (uint8, int16, uint16, float32; byte-swapped in
/// place if needed), else into a staging buffer that decodeVoxels converts. Memory budget
/// errors are FileErrors naming `path`.
AnyVolume readVoxels(const fs::path& path, SampleType type, Endian endian, const Geometry& geometry,
                     const std::function<void(uint8_t* dst, uint64_t bytes)>& fill);

/// Scales direction columns to unit length (files such as vtk.js index.json round cos 30 to
/// 0.866); returns a warning when a column was more than 1e-3 away from unit length.
std::string normalizeDirection(Geometry& g);
/// Geometry::validate, rethrown as FileError naming `path`.
void checkGeometry(const fs::path& path, const Geometry& g);
/// Dims and memory check for `dims` samples of `bytesPerSample` before anything is allocated.
void checkAllocation(const fs::path& path, const Dims& dims, uint64_t bytesPerSample);

/// Applies the CT convention: modality "CT" (or, when empty, int16 data with minimum
/// <= -1000) -> int16 HU with background -1000; anything else keeps its type with background 0.
/// Returns the modality ("CT" when inferred).
std::string applyModality(AnyVolume& v, std::string modality);
/// Modality to record when saving: "CT" only for int16 volumes whose background is -1000
/// (so a uint8 phantom saved with default options does not come back as CT); other
/// non-empty modalities are recorded as given.
std::string modalityToStore(const AnyVolume& v, const std::string& requested);

// ---- text helpers ----
std::string trim(std::string_view s);
std::string lower(std::string_view s);
/// Parses whitespace/comma/parenthesis separated numbers; FileError naming `field` when a
/// token is not a number or the count differs from `expected` (0: any count).
std::vector<double> parseNumbers(const fs::path& path, std::string_view text,
                                 const std::string& field, size_t expected = 0);
/// Round-trip exact decimal text for a double.
std::string fmt(double v);
/// Replaces control characters (newlines ...) with spaces so a value fits on one header line.
std::string oneLine(std::string_view s);

/// A LoadedVolume of `format`, after applyModality.
LoadedVolume makeLoaded(AnyVolume v, const std::string& format, std::string modality);

// ---- formats (each in its own .cpp) ----
struct ExtraFields {
  std::string modality;
  std::vector<Label> labels;
  bool hasLabels = false;  ///< the file carried a label table
};

LoadedVolume loadNrrd(const fs::path& path, const LoadOptions& options, ExtraFields* extra);
/// `labels`: write the label table (vellum_label_* and Slicer Segment*_ fields).
void saveNrrd(const AnyVolume& v, const fs::path& path, bool gzip, const std::string& modality,
              const std::vector<Label>* labels, Progress* progress);

LoadedVolume loadRaw(const fs::path& path, const LoadOptions& options);
void saveRaw(const AnyVolume& v, const fs::path& path, const std::string& modality, Progress* progress);
/// "<file>.raw.json"
fs::path sidecarPath(const fs::path& raw);

LoadedVolume loadMetaImage(const fs::path& path, const LoadOptions& options);
void saveMetaImage(const AnyVolume& v, const fs::path& path, const std::string& modality,
                   Progress* progress);

LoadedVolume loadNifti(const fs::path& path, const LoadOptions& options);

LoadedVolume loadVti(const fs::path& path, const LoadOptions& options);
void saveVti(const AnyVolume& v, const fs::path& path, const std::string& modality, Progress* progress);

}  // namespace vellum::io::detail
