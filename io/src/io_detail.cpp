#include "io_detail.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <optional>

#include "vellum/core/memory_budget.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum::io::detail {

uint64_t sampleSize(SampleType t) {
  switch (t) {
    case SampleType::Int8:
    case SampleType::UInt8: return 1;
    case SampleType::Int16:
    case SampleType::UInt16: return 2;
    case SampleType::Int32:
    case SampleType::UInt32:
    case SampleType::Float32: return 4;
    case SampleType::Float64: return 8;
  }
  return 1;
}

const char* sampleTypeName(SampleType t) {
  switch (t) {
    case SampleType::Int8: return "int8";
    case SampleType::UInt8: return "uint8";
    case SampleType::Int16: return "int16";
    case SampleType::UInt16: return "uint16";
    case SampleType::Int32: return "int32";
    case SampleType::UInt32: return "uint32";
    case SampleType::Float32: return "float32";
    case SampleType::Float64: return "float64";
  }
  return "?";
}

SampleType sampleTypeFor(VoxelType t) {
  switch (t) {
    case VoxelType::Int16: return SampleType::Int16;
    case VoxelType::UInt8: return SampleType::UInt8;
    case VoxelType::UInt16: return SampleType::UInt16;
    case VoxelType::Float32: return SampleType::Float32;
  }
  return SampleType::UInt8;
}

uint64_t fileSize(const fs::path& path) {
  std::error_code ec;
  const auto st = fs::status(path, ec);
  if (!fs::exists(st)) throw FileError(path, "no such file");
  if (!fs::is_regular_file(st)) throw FileError(path, "not a regular file");
  const auto n = fs::file_size(path, ec);
  if (ec) throw FileError(path, "cannot read file size: " + ec.message());
  return n;
}

std::string readSmallFile(const fs::path& path, uint64_t maxBytes) {
  const uint64_t n = fileSize(path);
  if (n > maxBytes)
    throw FileError(path, "file is " + formatBytes(n) + ", more than the " + formatBytes(maxBytes) +
                              " expected for a header");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError(path, "cannot open for reading");
  std::string s(static_cast<size_t>(n), '\0');
  in.read(s.data(), static_cast<std::streamsize>(n));
  if (static_cast<uint64_t>(in.gcount()) != n) throw FileError(path, "read error");
  return s;
}

fs::path headerDataFile(const fs::path& header, const std::string& name, bool allowOutside) {
  const fs::path named(name);
  const fs::path file = named.is_absolute() ? named : header.parent_path() / named;
  if (allowOutside) return file;
  const std::string refusal = "data file '" + oneLine(name) + "' ";
  const std::string permit = " (--allow-outside-data reads it)";
  if (named.is_absolute()) throw FileError(header, refusal + "is an absolute path" + permit);
  std::error_code ec, fileEc;
  const fs::path folder = fs::weakly_canonical(fs::absolute(header, ec).parent_path(), ec);
  const fs::path real = fs::weakly_canonical(fs::absolute(file, fileEc), fileEc);
  if (ec || fileEc) throw FileError(header, refusal + "cannot be resolved: " + (ec ? ec : fileEc).message());
  if (std::mismatch(folder.begin(), folder.end(), real.begin(), real.end()).first != folder.end())
    throw FileError(header, refusal + "lies outside the header's folder" + permit);
  return file;
}

void checkFileHolds(const fs::path& path, uint64_t offset, uint64_t count) {
  const uint64_t size = fileSize(path);
  if (offset > size || count > size - offset)
    throw FileError(path, "truncated: needs " + std::to_string(count) + " bytes of data at offset " +
                              std::to_string(offset) + ", file has " + std::to_string(size) +
                              " bytes");
}

void readInto(const fs::path& path, uint64_t offset, uint64_t count, uint8_t* dst, Progress* progress) {
  struct Fd {  // closed on every exit, also when progress cancels
    int fd;
    ~Fd() { if (fd >= 0) ::close(fd); }
  } f{::open(path.c_str(), O_RDONLY | O_CLOEXEC)};
  if (f.fd < 0) throw FileError(path, "cannot open for reading");
  constexpr uint64_t kChunk = 16u << 20;  // large reads straight into the destination
  if (progress) progress->begin("reading " + path.filename().string(), (count + kChunk - 1) / kChunk);
  for (uint64_t done = 0; done < count;) {
    const uint64_t want = std::min(kChunk, count - done);
    const ssize_t got = ::pread(f.fd, dst + done, static_cast<size_t>(want), static_cast<off_t>(offset + done));
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) throw FileError(path, got == 0 ? "read error (truncated?)" : "read error");
    done += static_cast<uint64_t>(got);
    if (progress && (static_cast<uint64_t>(got) == want || done == count)) progress->advance();
  }
  if (progress) progress->end();
}

std::vector<uint8_t> readBytes(const fs::path& path, uint64_t offset, uint64_t count,
                               Progress* progress) {
  checkFileHolds(path, offset, count);
  try {
    checkMemoryBudget(count, "file data");
  } catch (const FileError&) {
    throw;
  } catch (const Error& e) {
    throw FileError(path, e.what());
  }
  std::vector<uint8_t> out(static_cast<size_t>(count));
  readInto(path, offset, count, out.data(), progress);
  return out;
}

namespace {

void swapInPlace(uint8_t* p, uint64_t count, uint64_t size) {
  if (size == 1) return;
  parallelFor(static_cast<int64_t>(count), [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) std::reverse(p + i * size, p + (i + 1) * size);
  }, 1 << 16);
}

template <class S>
S sampleAt(const uint8_t* bytes, int64_t i) {
  S v;
  std::memcpy(&v, bytes + i * static_cast<int64_t>(sizeof(S)), sizeof(S));
  return v;
}

template <class S, class T>
Volume<T> convertSamples(const std::vector<uint8_t>& bytes, const Geometry& g) {
  Volume<T> vol(g);
  T* out = vol.data();
  parallelFor(g.dims.voxelCount(), [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) out[i] = static_cast<T>(sampleAt<S>(bytes.data(), i));
  }, 1 << 16);
  return vol;
}

template <class S>
std::pair<double, double> sampleRange(const std::vector<uint8_t>& bytes, int64_t n) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (int64_t i = 0; i < n; ++i) {
    const double v = static_cast<double>(sampleAt<S>(bytes.data(), i));
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  return {lo, hi};
}

template <class S>
AnyVolume fromInt32(const std::vector<uint8_t>& bytes, const Geometry& g) {
  const auto [lo, hi] = sampleRange<S>(bytes, g.dims.voxelCount());
  if (lo >= std::numeric_limits<int16_t>::min() && hi <= std::numeric_limits<int16_t>::max())
    return convertSamples<S, int16_t>(bytes, g);
  if (lo >= 0 && hi <= std::numeric_limits<uint16_t>::max()) return convertSamples<S, uint16_t>(bytes, g);
  return convertSamples<S, float>(bytes, g);
}

}  // namespace

AnyVolume decodeVoxels(const fs::path& path, std::vector<uint8_t>&& bytes, SampleType type,
                       Endian endian, const Geometry& geometry) {
  const uint64_t n = static_cast<uint64_t>(geometry.dims.voxelCount());
  if (bytes.size() != n * sampleSize(type))
    throw FileError(path, "voxel data has " + std::to_string(bytes.size()) + " bytes, expected " +
                              std::to_string(n * sampleSize(type)));
  if (endian != hostEndian()) swapInPlace(bytes.data(), n, sampleSize(type));
  std::vector<uint8_t> local = std::move(bytes);
  try {
    switch (type) {
      case SampleType::UInt8: return convertSamples<uint8_t, uint8_t>(local, geometry);
      case SampleType::Int16: return convertSamples<int16_t, int16_t>(local, geometry);
      case SampleType::UInt16: return convertSamples<uint16_t, uint16_t>(local, geometry);
      case SampleType::Float32: return convertSamples<float, float>(local, geometry);
      case SampleType::Int8: return convertSamples<int8_t, int16_t>(local, geometry);
      case SampleType::Int32: return fromInt32<int32_t>(local, geometry);
      case SampleType::UInt32: return fromInt32<uint32_t>(local, geometry);
      case SampleType::Float64: {
        const auto [lo, hi] = sampleRange<double>(local, static_cast<int64_t>(n));
        const double fmax = std::numeric_limits<float>::max();
        if (std::isfinite(lo) && std::isfinite(hi) && (lo < -fmax || hi > fmax))
          throw FileError(path, "float64 values exceed the float32 range");
        return convertSamples<double, float>(local, geometry);
      }
    }
  } catch (const FileError&) {
    throw;
  } catch (const Error& e) {  // memory budget
    throw FileError(path, e.what());
  }
  throw FileError(path, "unsupported sample type");
}

AnyVolume readVoxels(const fs::path& path, SampleType type, Endian endian, const Geometry& geometry,
                     const std::function<void(uint8_t* dst, uint64_t bytes)>& fill) {
  const uint64_t n = static_cast<uint64_t>(geometry.dims.voxelCount());
  const uint64_t bytes = n * sampleSize(type);
  const auto inPlace = [&](auto zero) -> AnyVolume {
    using T = decltype(zero);
    std::optional<Volume<T>> vol;
    try {
      vol.emplace(geometry);
    } catch (const Error& e) {  // memory budget
      throw FileError(path, e.what());
    }
    auto* dst = reinterpret_cast<uint8_t*>(vol->data());
    fill(dst, bytes);
    if (endian != hostEndian()) swapInPlace(dst, n, sizeof(T));
    return std::move(*vol);
  };
  switch (type) {
    case SampleType::UInt8: return inPlace(uint8_t{});
    case SampleType::Int16: return inPlace(int16_t{});
    case SampleType::UInt16: return inPlace(uint16_t{});
    case SampleType::Float32: return inPlace(float{});
    default: break;
  }
  try {
    checkMemoryBudget(bytes, "file data");
  } catch (const Error& e) {
    throw FileError(path, e.what());
  }
  std::vector<uint8_t> raw(static_cast<size_t>(bytes));
  fill(raw.data(), bytes);
  return decodeVoxels(path, std::move(raw), type, endian, geometry);
}

ByteView voxelBytes(const AnyVolume& v) {
  return std::visit(
      [](const auto& vol) {
        using T = typename std::decay_t<decltype(vol)>::value_type;
        return ByteView{reinterpret_cast<const uint8_t*>(vol.data()), vol.size() * sizeof(T)};
      },
      v);
}

void writeBinaryFile(const fs::path& tmp, const std::string& prefix, ByteView body,
                     Progress* progress) {
  std::ofstream out(tmp, std::ios::binary);
  if (!out) throw FileError(tmp, "cannot open for writing");
  out.write(prefix.data(), static_cast<std::streamsize>(prefix.size()));
  constexpr size_t kChunk = size_t{16} << 20;
  if (progress) progress->begin("writing " + tmp.filename().string(), (body.size + kChunk - 1) / kChunk);
  for (size_t done = 0; done < body.size && out; done += kChunk) {
    out.write(reinterpret_cast<const char*>(body.data + done),
              static_cast<std::streamsize>(std::min(kChunk, body.size - done)));
    if (progress) progress->advance();
  }
  if (progress) progress->end();
  out.close();
  if (!out) throw FileError(tmp, "write failed (disk full?)");
}

void checkAllocation(const fs::path& path, const Dims& d, uint64_t bytesPerSample) {
  if (d.x <= 0 || d.y <= 0 || d.z <= 0) throw FileError(path, "invalid dimensions " + d.str());
  constexpr int64_t kMaxDim = 1 << 16;
  if (d.x > kMaxDim || d.y > kMaxDim || d.z > kMaxDim)
    throw FileError(path, "absurd dimensions " + d.str() + " (each axis must be <= 65536)");
  try {
    checkMemoryBudget(d, bytesPerSample, std::to_string(bytesPerSample) + "-byte samples");
  } catch (const Error& e) {
    throw FileError(path, e.what());
  }
}

std::string normalizeDirection(Geometry& g) {
  std::string warning;
  for (int c = 0; c < 3; ++c) {
    const Vec3 col = g.direction.column(c);
    const double n = norm(col);
    if (!(n > 0) || !std::isfinite(n)) continue;  // validate() reports it
    if (std::abs(n - 1) > 1e-3)
      warning = "direction column " + std::to_string(c) + " had length " + fmt(n) + "; normalised to 1";
    for (int r = 0; r < 3; ++r) g.direction(r, c) = col[r] / n;
  }
  return warning;
}

void checkGeometry(const fs::path& path, const Geometry& g) {
  try {
    g.validate("geometry");
  } catch (const Error& e) {
    throw FileError(path, e.what());
  }
}

std::string applyModality(AnyVolume& v, std::string modality) {
  const bool isInt16 = std::holds_alternative<VolumeI16>(v);
  if (modality.empty() && isInt16 && std::get<VolumeI16>(v).valueRange().first <= kCtAirHu)
    modality = "CT";
  if (lower(modality) == "ct") {
    modality = "CT";
    if (!isInt16) v = toInt16(v);
    std::get<VolumeI16>(v).setBackground(kCtAirHu);
  } else {
    std::visit([](auto& vol) { vol.setBackground(0.0); }, v);
  }
  return modality;
}

std::string modalityToStore(const AnyVolume& v, const std::string& requested) {
  if (lower(requested) != "ct") return oneLine(requested);
  return std::holds_alternative<VolumeI16>(v) && backgroundOf(v) == kCtAirHu ? "CT" : "";
}

LoadedVolume makeLoaded(AnyVolume v, const std::string& format, std::string modality) {
  LoadedVolume out;
  out.modality = applyModality(v, std::move(modality));
  out.volume = std::move(v);
  out.format = format;
  return out;
}

std::string trim(std::string_view s) {
  size_t b = 0, e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  return std::string(s.substr(b, e - b));
}

std::string lower(std::string_view s) {
  std::string r(s);
  for (char& c : r) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return r;
}

std::vector<double> parseNumbers(const fs::path& path, std::string_view text,
                                 const std::string& field, size_t expected) {
  std::vector<double> out;
  size_t i = 0;
  auto isSep = [](char c) {
    return std::isspace(static_cast<unsigned char>(c)) || c == ',' || c == '(' || c == ')';
  };
  while (i < text.size()) {
    while (i < text.size() && isSep(text[i])) ++i;
    if (i >= text.size()) break;
    size_t j = i;
    while (j < text.size() && !isSep(text[j])) ++j;
    const std::string tok(text.substr(i, j - i));
    char* end = nullptr;
    const double v = std::strtod(tok.c_str(), &end);
    if (end != tok.c_str() + tok.size())
      throw FileError(path, "field '" + field + "': '" + tok + "' is not a number");
    out.push_back(v);
    i = j;
    if (out.size() > 64) throw FileError(path, "field '" + field + "': too many numbers");
  }
  if (expected && out.size() != expected)
    throw FileError(path, "field '" + field + "': expected " + std::to_string(expected) +
                              " numbers, found " + std::to_string(out.size()));
  return out;
}

std::string fmt(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

std::string oneLine(std::string_view s) {
  std::string r(s);
  for (char& c : r)
    if (static_cast<unsigned char>(c) < 32) c = ' ';
  return trim(r);
}

}  // namespace vellum::io::detail
