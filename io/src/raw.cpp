// Headerless .raw volumes: geometry from the JSON sidecar "<file>.raw.json" or, without one,
// from LoadOptions::raw. Sidecar fields (docs/formats.md):
//   dims [x,y,z] (required), type "int16"|"uint8"|"uint16"|"float32" (required; also "int8",
//   "int32", "uint32", "float64" when reading), endianness "little"|"big" (default little),
//   spacing [3] (default 1), origin [3] (default 0), direction [9] COLUMN-major: the unit
//   physical direction of the i axis, then j, then k (default identity; same order as
//   vtk.js index.json and MetaImage TransformMatrix), modality "CT"|... (optional),
//   headerBytes (default 0).
#include <nlohmann/json.hpp>


#include "io_detail.hpp"
#include "vellum/core/json_input.hpp"
#include "vellum/io/atomic_file.hpp"

namespace vellum::io::detail {

namespace {

using json = nlohmann::json;

SampleType parseRawType(const fs::path& path, const std::string& t) {
  const std::string l = lower(t);
  if (l == "int8") return SampleType::Int8;
  if (l == "uint8" || l == "uchar") return SampleType::UInt8;
  if (l == "int16" || l == "short") return SampleType::Int16;
  if (l == "uint16" || l == "ushort") return SampleType::UInt16;
  if (l == "int32") return SampleType::Int32;
  if (l == "uint32") return SampleType::UInt32;
  if (l == "float32" || l == "float") return SampleType::Float32;
  if (l == "float64" || l == "double") return SampleType::Float64;
  throw FileError(path, "unsupported type '" + t + "' (int16, uint8, uint16, float32)");
}

std::vector<double> numbers(const fs::path& path, const json& j, const char* key, size_t n) {
  if (!j.contains(key)) return {};
  const json& a = j.at(key);
  if (!a.is_array() || a.size() != n)
    throw FileError(path, std::string("'") + key + "' must be an array of " + std::to_string(n) + " numbers");
  std::vector<double> out;
  for (const json& x : a) {
    if (!x.is_number()) throw FileError(path, std::string("'") + key + "' holds a non-number");
    out.push_back(x.get<double>());
  }
  return out;
}

struct RawMeta {
  Geometry geometry;
  SampleType type = SampleType::Int16;
  Endian endian = Endian::Little;
  uint64_t headerBytes = 0;
  std::string modality;
};

RawMeta readSidecar(const fs::path& side) {
  const json j = readJsonFile(side, 1u << 20, "raw sidecar");  // a sidecar is a few hundred bytes
  if (!j.is_object()) throw FileError(side, "sidecar must be a JSON object");
  RawMeta m;
  const auto dims = numbers(side, j, "dims", 3);
  if (dims.empty()) throw FileError(side, "missing required field 'dims'");
  for (double d : dims)
    if (d != std::floor(d) || d < 1 || d > 1e9) throw FileError(side, "invalid 'dims' (positive integers)");
  m.geometry.dims = {int64_t(dims[0]), int64_t(dims[1]), int64_t(dims[2])};
  if (!j.contains("type") || !j["type"].is_string()) throw FileError(side, "missing required field 'type'");
  m.type = parseRawType(side, j["type"].get<std::string>());
  if (j.contains("endianness")) {
    if (!j["endianness"].is_string()) throw FileError(side, "'endianness' must be \"little\" or \"big\"");
    const std::string e = lower(j["endianness"].get<std::string>());
    if (e == "big") m.endian = Endian::Big;
    else if (e != "little") throw FileError(side, "'endianness' must be \"little\" or \"big\"");
  }
  if (auto s = numbers(side, j, "spacing", 3); !s.empty()) m.geometry.spacing = {s[0], s[1], s[2]};
  if (auto o = numbers(side, j, "origin", 3); !o.empty()) m.geometry.origin = {o[0], o[1], o[2]};
  if (auto d = numbers(side, j, "direction", 9); !d.empty())
    m.geometry.direction = Mat3::fromColumns({d[0], d[1], d[2]}, {d[3], d[4], d[5]}, {d[6], d[7], d[8]});
  if (j.contains("modality")) {
    if (!j["modality"].is_string()) throw FileError(side, "'modality' must be a string");
    m.modality = j["modality"].get<std::string>();
  }
  if (j.contains("headerBytes")) {
    if (!j["headerBytes"].is_number_unsigned()) throw FileError(side, "'headerBytes' must be a non-negative integer");
    m.headerBytes = j["headerBytes"].get<uint64_t>();
  }
  return m;
}

}  // namespace

fs::path sidecarPath(const fs::path& raw) { return fs::path(raw.string() + ".json"); }

LoadedVolume loadRaw(const fs::path& path, const LoadOptions& options) {
  const uint64_t size = fileSize(path);
  const fs::path side = sidecarPath(path);
  RawMeta m;
  fs::path described = side;  // the file whose layout is wrong, for messages
  if (fs::exists(side)) {
    m = readSidecar(side);
  } else if (options.raw) {
    const RawLayout& r = *options.raw;
    m.geometry = {r.dims, r.spacing, r.origin, r.direction};
    m.type = sampleTypeFor(r.type);
    m.endian = r.endian;
    m.headerBytes = r.headerBytes;
    described = path;
  } else {
    throw FileError(path, "no sidecar " + side.filename().string() +
                              " and no raw layout given (dims, type, spacing: --raw-dims ...)");
  }
  checkAllocation(described, m.geometry.dims, sampleSize(m.type));
  const std::string warning = normalizeDirection(m.geometry);
  checkGeometry(described, m.geometry);
  const uint64_t bytes = static_cast<uint64_t>(m.geometry.dims.voxelCount()) * sampleSize(m.type);
  if (m.headerBytes > size || size - m.headerBytes != bytes)
    throw FileError(path, "size mismatch: expected " + std::to_string(m.headerBytes + bytes) + " bytes (" +
                              std::to_string(m.headerBytes) + " header + " + m.geometry.dims.str() + " " +
                              sampleTypeName(m.type) + "), file has " + std::to_string(size));
  AnyVolume vol = readVoxels(path, m.type, m.endian, m.geometry, [&](uint8_t* dst, uint64_t n) {
    readInto(path, m.headerBytes, n, dst, options.progress);
  });
  LoadedVolume out = makeLoaded(std::move(vol), "raw", m.modality);
  if (!warning.empty()) out.warnings.push_back(warning);
  return out;
}

void saveRaw(const AnyVolume& v, const fs::path& path, const std::string& modality, Progress* progress) {
  const Geometry& g = geometryOf(v);
  json j;
  j["dims"] = {g.dims.x, g.dims.y, g.dims.z};
  j["type"] = voxelTypeName(voxelTypeOf(v));
  j["endianness"] = hostEndian() == Endian::Little ? "little" : "big";
  j["spacing"] = {g.spacing.x, g.spacing.y, g.spacing.z};
  j["origin"] = {g.origin.x, g.origin.y, g.origin.z};
  json dir = json::array();
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) dir.push_back(g.direction(r, c));
  j["direction"] = dir;
  if (!modality.empty()) j["modality"] = modality;
  const std::string text = j.dump(2) + "\n";
  writeAtomically(path, [&](const fs::path& tmp) { writeBinaryFile(tmp, "", voxelBytes(v), progress); });
  writeAtomically(sidecarPath(path), [&](const fs::path& tmp) { writeBinaryFile(tmp, text, {}); });
}

}  // namespace vellum::io::detail
