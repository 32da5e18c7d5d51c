// NIfTI-1 reader (.nii, .nii.gz). Own reader rather than vtkNIFTIImageReader: VTK reorders
// slices when qfac < 0 and reports its matrices relative to its own flipped grid, and reports
// bad files through its error output instead of exceptions. Geometry: sform when
// sform_code > 0, else qform when qform_code > 0, else pixdim only; NIfTI world is RAS and is
// converted to LPS by negating the first two rows. scl_slope/scl_inter are applied.
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "io_detail.hpp"
#include "vellum/core/memory_budget.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum::io::detail {

namespace {

struct GzFile {
  gzFile f = nullptr;
  ~GzFile() {
    if (f) gzclose(f);
  }
};

/// Reads exactly n bytes (decompressing .gz transparently); FileError when short or corrupt.
void readExact(const fs::path& path, gzFile f, void* dst, uint64_t n, const char* what) {
  auto* p = static_cast<uint8_t*>(dst);
  while (n > 0) {
    const unsigned chunk = static_cast<unsigned>(std::min<uint64_t>(n, 1u << 30));
    const int got = gzread(f, p, chunk);
    if (got < 0) {
      int err = 0;
      std::string msg = gzerror(f, &err);
      if (const size_t p = msg.rfind(": "); p != std::string::npos) msg = msg.substr(p + 2);  // drop path
      throw FileError(path, "corrupt compressed data (" + msg + ")");
    }
    if (got == 0) throw FileError(path, std::string("truncated ") + what);
    p += got;
    n -= static_cast<uint64_t>(got);
  }
}

template <class T>
T get(const uint8_t* h, size_t off, bool swap) {
  uint8_t b[sizeof(T)];
  std::memcpy(b, h + off, sizeof(T));
  if (swap) std::reverse(b, b + sizeof(T));
  T v;
  std::memcpy(&v, b, sizeof(T));
  return v;
}

/// The 348-byte header, its byte order, and what it says about the grid and the samples.
struct NiftiHeader {
  uint8_t bytes[348];
  bool swap = false;
  SampleType type{};
  Geometry geometry;  ///< dims only, until niftiOrientation()
  template <class T>
  T at(size_t offset) const { return get<T>(bytes, offset, swap); }
};

SampleType niftiSampleType(const fs::path& path, int16_t datatype) {
  switch (datatype) {
    case 2: return SampleType::UInt8;
    case 4: return SampleType::Int16;
    case 8: return SampleType::Int32;
    case 16: return SampleType::Float32;
    case 64: return SampleType::Float64;
    case 256: return SampleType::Int8;
    case 512: return SampleType::UInt16;
    case 768: return SampleType::UInt32;
    default: throw FileError(path, "unsupported NIfTI datatype " + std::to_string(datatype));
  }
}

/// Reads and checks the header: magic, byte order, a 3-D grid, a supported sample type, and
/// an allocation that would fit.
NiftiHeader readNiftiHeader(const fs::path& path, gzFile f) {
  NiftiHeader n;
  uint8_t* h = n.bytes;
  readExact(path, f, h, sizeof n.bytes, "header (shorter than 348 bytes)");
  if (get<int32_t>(h, 0, false) != 348) {
    if (get<int32_t>(h, 0, true) != 348) throw FileError(path, "not a NIfTI-1 file (sizeof_hdr is not 348)");
    n.swap = true;
  }
  if (std::memcmp(h + 344, "n+1", 4) != 0) {
    if (std::memcmp(h + 344, "ni1", 4) == 0)
      throw FileError(path, "two-file NIfTI (.hdr/.img) is not supported; convert to .nii");
    throw FileError(path, "not a NIfTI-1 file (magic is not 'n+1')");
  }
  int16_t dim[8];
  for (int i = 0; i < 8; ++i) dim[i] = n.at<int16_t>(40 + 2 * size_t(i));
  if (dim[0] < 1 || dim[0] > 7) throw FileError(path, "invalid dim[0] = " + std::to_string(dim[0]));
  for (int i = 4; i <= dim[0]; ++i)
    if (dim[i] > 1) throw FileError(path, "4-D or higher NIfTI (dim[" + std::to_string(i) + "] = " +
                                              std::to_string(dim[i]) + ") is not supported");
  n.geometry.dims = {dim[1], dim[0] >= 2 ? dim[2] : 1, dim[0] >= 3 ? dim[3] : 1};
  n.type = niftiSampleType(path, n.at<int16_t>(70));
  checkAllocation(path, n.geometry.dims, sampleSize(n.type));
  return n;
}

/// Spacing, origin and direction (LPS) from the sform, else the qform, else pixdim alone.
void niftiOrientation(const fs::path& path, NiftiHeader& n) {
  float pixdim[8];
  for (int i = 0; i < 8; ++i) pixdim[i] = n.at<float>(76 + 4 * size_t(i));
  const int16_t qformCode = n.at<int16_t>(252), sformCode = n.at<int16_t>(254);
  Mat3 m;  // RAS, columns = axis vectors including spacing
  Vec3 origin;
  if (sformCode > 0) {
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) m(r, c) = n.at<float>(280 + 16 * size_t(r) + 4 * size_t(c));
      origin[r] = n.at<float>(280 + 16 * size_t(r) + 12);
    }
  } else if (qformCode > 0) {
    const double b = n.at<float>(256), c = n.at<float>(260), d = n.at<float>(264);
    const double a = std::sqrt(std::max(0.0, 1.0 - (b * b + c * c + d * d)));
    const Mat3 rot = Mat3::fromColumns({a * a + b * b - c * c - d * d, 2 * (b * c + a * d), 2 * (b * d - a * c)},
                                       {2 * (b * c - a * d), a * a + c * c - b * b - d * d, 2 * (c * d + a * b)},
                                       {2 * (b * d + a * c), 2 * (c * d - a * b), a * a + d * d - c * c - b * b});
    const double qfac = pixdim[0] < 0 ? -1.0 : 1.0;
    for (int r = 0; r < 3; ++r) {
      m(r, 0) = rot(r, 0) * pixdim[1];
      m(r, 1) = rot(r, 1) * pixdim[2];
      m(r, 2) = rot(r, 2) * pixdim[3] * qfac;
    }
    origin = {n.at<float>(268), n.at<float>(272), n.at<float>(276)};
  } else {
    m = Mat3::fromColumns({pixdim[1], 0, 0}, {0, pixdim[2], 0}, {0, 0, pixdim[3]});
  }
  Geometry& g = n.geometry;
  for (int a = 0; a < 3; ++a) {
    const Vec3 col = m.column(a);
    g.spacing[a] = norm(col);
    const Vec3 unit = g.spacing[a] > 0 ? col / g.spacing[a] : col;
    // RAS -> LPS: negate x and y.
    g.direction(0, a) = -unit.x;
    g.direction(1, a) = -unit.y;
    g.direction(2, a) = unit.z;
  }
  g.origin = {-origin.x, -origin.y, origin.z};
  checkGeometry(path, g);
}

/// The voxel bytes after vox_offset (extensions skipped). A header may claim far more voxels
/// than the file holds: never allocate for them first. Plain files are checked against their
/// size; gzip streams grow the buffer as data arrive.
std::vector<uint8_t> readNiftiData(const fs::path& path, gzFile f, float voxOffset, uint64_t bytes,
                                   Progress* progress) {
  if (!std::isfinite(voxOffset) || voxOffset < 348 || voxOffset > 1e9)
    throw FileError(path, "invalid vox_offset " + fmt(voxOffset));
  const uint64_t skip = static_cast<uint64_t>(voxOffset) - 348;
  std::vector<uint8_t> scratch(static_cast<size_t>(std::min<uint64_t>(skip, 1u << 20)));
  for (uint64_t left = skip; left > 0;) {
    const uint64_t n = std::min<uint64_t>(left, scratch.size());
    readExact(path, f, scratch.data(), n, "file (ends before vox_offset)");
    left -= n;
  }
  try {
    checkMemoryBudget(bytes, "NIfTI voxel data");
  } catch (const Error& e) {
    throw FileError(path, e.what());
  }
  std::vector<uint8_t> data;
  const uint64_t dataStart = static_cast<uint64_t>(voxOffset);
  if (gzdirect(f)) {
    const uint64_t size = fileSize(path);
    if (size < dataStart || size - dataStart < bytes)
      throw FileError(path, "truncated voxel data: the header needs " + std::to_string(bytes) + " bytes after vox_offset, the file has " +
                                std::to_string(size > dataStart ? size - dataStart : 0));
    data.resize(static_cast<size_t>(bytes));
  }
  constexpr uint64_t kChunk = uint64_t{16} << 20;
  if (progress) progress->begin("reading " + path.filename().string(), (bytes + kChunk - 1) / kChunk);
  for (uint64_t done = 0; done < bytes;) {
    const uint64_t n = std::min(kChunk, bytes - done);
    if (data.size() < done + n) data.resize(static_cast<size_t>(done + n));
    readExact(path, f, data.data() + done, n, "voxel data");
    done += n;
    if (progress) progress->advance();
  }
  if (progress) progress->end();
  return data;
}

/// scl_slope / scl_inter applied; integer results that fit int16 (CT stored as uint16 with
/// inter -1024) stay integers.
AnyVolume applyNiftiScaling(AnyVolume vol, float slope, float inter) {
  const bool scaled = slope != 0 && std::isfinite(slope) && std::isfinite(inter) && !(slope == 1 && inter == 0);
  if (!scaled) return vol;
  VolumeF32 f = toFloat32(vol);
  float* p = f.data();
  parallelFor(static_cast<int64_t>(f.size()), [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) p[i] = p[i] * slope + inter;
  }, 1 << 16);
  bool integral = true;
  for (size_t i = 0; i < f.size() && integral; ++i)
    integral = p[i] == std::floor(p[i]) && p[i] >= -32768 && p[i] <= 32767;
  return integral ? AnyVolume(toInt16(f)) : AnyVolume(std::move(f));
}

}  // namespace

LoadedVolume loadNifti(const fs::path& path, const LoadOptions& options) {
  fileSize(path);  // existence and regular-file check
  GzFile gz;
  gz.f = gzopen(path.c_str(), "rb");
  if (!gz.f) throw FileError(path, "cannot open for reading");
  NiftiHeader header = readNiftiHeader(path, gz.f);
  niftiOrientation(path, header);
  const Geometry& g = header.geometry;
  const uint64_t bytes = static_cast<uint64_t>(g.dims.voxelCount()) * sampleSize(header.type);
  std::vector<uint8_t> data = readNiftiData(path, gz.f, header.at<float>(108), bytes, options.progress);
  const Endian fileEndian = header.swap ? (hostEndian() == Endian::Little ? Endian::Big : Endian::Little) : hostEndian();
  AnyVolume vol = decodeVoxels(path, std::move(data), header.type, fileEndian, g);
  return makeLoaded(applyNiftiScaling(std::move(vol), header.at<float>(112), header.at<float>(116)), "nifti", "");
}

}  // namespace vellum::io::detail
