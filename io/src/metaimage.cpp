// MetaImage (.mha with LOCAL data, .mhd + separate data file), written here because VTK's
// reader drops the direction. TransformMatrix lists the physical direction of the i axis,
// then j, then k (ITK's convention: column-major in terms of Mat3).
#include <fstream>
#include <map>
#include <sstream>

#include "io_detail.hpp"
#include "vellum/io/compression.hpp"
#include "vellum/io/atomic_file.hpp"

namespace vellum::io::detail {

namespace {

SampleType parseMetType(const fs::path& path, const std::string& t) {
  static const std::map<std::string, SampleType> types = {
      {"MET_CHAR", SampleType::Int8},    {"MET_UCHAR", SampleType::UInt8},
      {"MET_SHORT", SampleType::Int16},  {"MET_USHORT", SampleType::UInt16},
      {"MET_INT", SampleType::Int32},    {"MET_UINT", SampleType::UInt32},
      {"MET_FLOAT", SampleType::Float32}, {"MET_DOUBLE", SampleType::Float64}};
  const auto it = types.find(t);
  if (it == types.end()) throw FileError(path, "unsupported ElementType '" + t + "'");
  return it->second;
}

const char* metTypeName(VoxelType t) {
  switch (t) {
    case VoxelType::Int16: return "MET_SHORT";
    case VoxelType::UInt8: return "MET_UCHAR";
    case VoxelType::UInt16: return "MET_USHORT";
    case VoxelType::Float32: return "MET_FLOAT";
  }
  return "?";
}

bool parseBool(const fs::path& path, const std::string& key, const std::string& v) {
  const std::string l = lower(v);
  if (l == "true" || l == "1") return true;
  if (l == "false" || l == "0") return false;
  throw FileError(path, "field '" + key + "': '" + v + "' is not True/False");
}

}  // namespace

namespace {

/// The header's fields (text up to and including the ElementDataFile line) and where the
/// bytes after it start.
struct MetaHeader {
  fs::path path;
  std::map<std::string, std::string> fields;
  uint64_t dataOffset = 0;

  const std::string& required(const char* key) const {
    const auto it = fields.find(key);
    if (it == fields.end()) throw FileError(path, std::string("missing required field '") + key + "'");
    return it->second;
  }
  /// The first of `keys` present (MetaImage has synonyms), or null.
  const std::string* optional(std::initializer_list<const char*> keys) const {
    for (const char* k : keys)
      if (auto it = fields.find(k); it != fields.end()) return &it->second;
    return nullptr;
  }
  double number(const char* key, const std::string& text) const { return parseNumbers(path, text, key, 1)[0]; }
};

MetaHeader readMetaHeader(const fs::path& path) {
  const uint64_t size = fileSize(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError(path, "cannot open for reading");
  MetaHeader h{path, {}, 0};
  std::string line;
  for (int lineNo = 1; lineNo <= 1000; ++lineNo) {
    // Bounded line read: headers never have kilobyte-long lines.
    line.clear();
    char c;
    while (line.size() < 4096 && in.get(c) && c != '\n') line += c;
    if (line.size() >= 4096) throw FileError(path, "header line " + std::to_string(lineNo) + " is too long (not a MetaImage?)");
    if (!in && line.empty()) break;
    h.dataOffset = static_cast<uint64_t>(in.tellg() == std::streampos(-1) ? std::streamoff(size) : std::streamoff(in.tellg()));
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (trim(line).empty()) continue;
    const size_t eq = line.find('=');
    if (eq == std::string::npos)
      throw FileError(path, "header line " + std::to_string(lineNo) + " has no '=': '" + line.substr(0, 60) + "'");
    const std::string key = trim(line.substr(0, eq));
    h.fields[key] = trim(line.substr(eq + 1));
    if (lineNo == 1 && key != "ObjectType" && key != "NDims")
      throw FileError(path, "not a MetaImage file (first field '" + key + "')");
    if (key == "ElementDataFile") return h;
  }
  throw FileError(path, "missing required field 'ElementDataFile'");
}

}  // namespace

std::string metaDataFileName(const fs::path& header) {
  try {
    const std::string name = readMetaHeader(header).required("ElementDataFile");
    return name == "LOCAL" ? std::string() : name;
  } catch (const FileError&) {
    return {};  // not a readable MetaImage header: it names no data file
  }
}

namespace {

/// Dims, sample type, spacing, origin and direction; refuses non-3-D, multi-channel and
/// oversized images before anything is allocated. `warning`: the direction normalisation's
/// note, if any.
Geometry metaGeometry(const MetaHeader& h, SampleType& type, std::string& warning) {
  const fs::path& path = h.path;
  if (const auto* ot = h.optional({"ObjectType"}); ot && lower(*ot) != "image")
    throw FileError(path, "ObjectType '" + *ot + "' is not Image");
  const double ndims = h.number("NDims", h.required("NDims"));
  if (ndims != 3) throw FileError(path, "NDims = " + fmt(ndims) + " (only 3-D images are supported)");
  if (const auto* ch = h.optional({"ElementNumberOfChannels"}); ch && h.number("ElementNumberOfChannels", *ch) != 1)
    throw FileError(path, "multi-channel images are not supported");
  const auto ds = parseNumbers(path, h.required("DimSize"), "DimSize", 3);
  for (double d : ds)
    if (d != std::floor(d) || d < 1 || d > 1e9) throw FileError(path, "invalid DimSize '" + h.required("DimSize") + "'");
  Geometry g;
  g.dims = {int64_t(ds[0]), int64_t(ds[1]), int64_t(ds[2])};
  type = parseMetType(path, h.required("ElementType"));
  checkAllocation(path, g.dims, sampleSize(type));
  if (const auto* sp = h.optional({"ElementSpacing", "ElementSize"})) {
    const auto s = parseNumbers(path, *sp, "ElementSpacing", 3);
    g.spacing = {s[0], s[1], s[2]};
  }
  if (const auto* o = h.optional({"Offset", "Origin", "Position"})) {
    const auto s = parseNumbers(path, *o, "Offset", 3);
    g.origin = {s[0], s[1], s[2]};
  }
  if (const auto* m = h.optional({"TransformMatrix", "Rotation", "Orientation"})) {
    const auto d = parseNumbers(path, *m, "TransformMatrix", 9);
    g.direction = Mat3::fromColumns({d[0], d[1], d[2]}, {d[3], d[4], d[5]}, {d[6], d[7], d[8]});
  }
  warning = normalizeDirection(g);
  checkGeometry(path, g);
  return g;
}

/// Where and how the voxels are stored.
struct MetaData {
  fs::path file;
  int64_t headerSize = 0;  ///< bytes to skip; -1: the data are the file's last bytes
  Endian endian = Endian::Little;
  bool compressed = false;
};

MetaData metaDataLocation(const MetaHeader& h, bool allowOutsideData) {
  const fs::path& path = h.path;
  if (const auto* b = h.optional({"BinaryData"}); b && !parseBool(path, "BinaryData", *b))
    throw FileError(path, "ASCII MetaImage data (BinaryData = False) is not supported");
  MetaData d;
  d.file = path;
  if (const auto* msb = h.optional({"BinaryDataByteOrderMSB", "ElementByteOrderMSB"}))
    d.endian = parseBool(path, "BinaryDataByteOrderMSB", *msb) ? Endian::Big : Endian::Little;
  if (const auto* c = h.optional({"CompressedData"})) d.compressed = parseBool(path, "CompressedData", *c);
  const std::string& dataFile = h.required("ElementDataFile");
  if (dataFile == "LOCAL") {
    d.headerSize = static_cast<int64_t>(h.dataOffset);
    return d;
  }
  if (dataFile.rfind("LIST", 0) == 0 || dataFile.find('%') != std::string::npos)
    throw FileError(path, "multi-file MetaImage data ('" + dataFile + "') is not supported");
  d.file = headerDataFile(path, dataFile, allowOutsideData);
  if (!fs::exists(d.file)) throw FileError(path, "data file " + d.file.string() + " does not exist");
  if (const auto* hs = h.optional({"HeaderSize"})) {
    const double v = h.number("HeaderSize", *hs);
    if (v != std::floor(v) || v < -1) throw FileError(path, "invalid HeaderSize");
    d.headerSize = static_cast<int64_t>(v);
  }
  return d;
}

AnyVolume readMetaVoxels(const MetaHeader& h, const MetaData& d, SampleType type, const Geometry& g,
                         const LoadOptions& options) {
  const uint64_t bytes = static_cast<uint64_t>(g.dims.voxelCount()) * sampleSize(type);
  const uint64_t dataSize = fileSize(d.file);
  if (!d.compressed) {
    const uint64_t off = d.headerSize < 0 ? (dataSize >= bytes ? dataSize - bytes : 0) : uint64_t(d.headerSize);
    checkFileHolds(d.file, off, bytes);
    return readVoxels(d.file, type, d.endian, g, [&](uint8_t* dst, uint64_t n) {
      readInto(d.file, off, n, dst, options.progress);
    });
  }
  if (d.headerSize < 0) throw FileError(h.path, "HeaderSize = -1 with compressed data");
  const uint64_t off = static_cast<uint64_t>(d.headerSize);
  if (off > dataSize) throw FileError(d.file, "truncated: no compressed data");
  uint64_t packedSize = dataSize - off;
  if (const auto* cs = h.optional({"CompressedDataSize"})) {
    const double v = h.number("CompressedDataSize", *cs);
    if (v >= 1 && v <= double(packedSize)) packedSize = static_cast<uint64_t>(v);
  }
  const auto packed = readBytes(d.file, off, packedSize, options.progress);
  checkInflatedSize(d.file, packed.size(), bytes);
  return readVoxels(d.file, type, d.endian, g, [&](uint8_t* dst, uint64_t n) {
    inflateExactInto(d.file, packed.data(), packed.size(), dst, n);
  });
}

}  // namespace

LoadedVolume loadMetaImage(const fs::path& path, const LoadOptions& options) {
  const MetaHeader header = readMetaHeader(path);
  SampleType type{};
  std::string warning;
  const Geometry g = metaGeometry(header, type, warning);
  const MetaData data = metaDataLocation(header, options.allowOutsideData);
  AnyVolume vol = readMetaVoxels(header, data, type, g, options);
  std::string modality;
  if (const auto* m = header.optional({"Modality"})) {
    modality = *m;
    if (modality.rfind("MET_MOD_", 0) == 0) modality = modality.substr(8);
    if (modality == "UNKNOWN") modality.clear();
  }
  LoadedVolume out = makeLoaded(std::move(vol), "metaimage", modality);
  if (!warning.empty()) out.warnings.push_back(warning);
  return out;
}

void saveMetaImage(const AnyVolume& v, const fs::path& path, const std::string& modality,
                   Progress* progress) {
  const Geometry& g = geometryOf(v);
  const bool local = lower(path.extension().string()) == ".mha";
  const std::string dataName = path.stem().string() + ".raw";
  std::ostringstream h;
  h << "ObjectType = Image\nNDims = 3\nBinaryData = True\n"
    << "BinaryDataByteOrderMSB = " << (hostEndian() == Endian::Big ? "True" : "False") << "\n"
    << "CompressedData = False\nTransformMatrix =";
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) h << " " << fmt(g.direction(r, c));
  h << "\nOffset = " << fmt(g.origin.x) << " " << fmt(g.origin.y) << " " << fmt(g.origin.z) << "\n"
    << "CenterOfRotation = 0 0 0\nAnatomicalOrientation = RAI\n"
    << "ElementSpacing = " << fmt(g.spacing.x) << " " << fmt(g.spacing.y) << " " << fmt(g.spacing.z) << "\n"
    << "DimSize = " << g.dims.x << " " << g.dims.y << " " << g.dims.z << "\n";
  if (!modality.empty()) h << "Modality = MET_MOD_" << oneLine(modality) << "\n";
  h << "ElementType = " << metTypeName(voxelTypeOf(v)) << "\n"
    << "ElementDataFile = " << (local ? "LOCAL" : dataName) << "\n";
  const std::string header = h.str();
  if (local) {
    writeAtomically(path, [&](const fs::path& tmp) { writeBinaryFile(tmp, header, voxelBytes(v), progress); });
  } else {
    writeAtomically(path.parent_path() / dataName, [&](const fs::path& tmp) { writeBinaryFile(tmp, "", voxelBytes(v), progress); });
    writeAtomically(path, [&](const fs::path& tmp) { writeBinaryFile(tmp, header, {}); });
  }
}

}  // namespace vellum::io::detail
