// NRRD reader and writer (http://teem.sourceforge.net/nrrd/format.html), written here because
// VTK's reader has no writer and few encodings. Supports attached (.nrrd) and detached
// (.nhdr + data file) headers, raw / gzip / ascii encodings, LPS/RAS/LAS spaces, 3-D images
// (and 4-D with a leading axis of size 1, as Slicer writes single-layer segmentations).
#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <cstring>
#include <sstream>

#include "io_detail.hpp"
#include "vellum/io/compression.hpp"
#include "vellum/io/nrrd_reader.hpp"
#include "vellum/io/nrrd_writer.hpp"
#include "label_fields.hpp"
#include "vellum/io/atomic_file.hpp"

namespace vellum::io::detail {

namespace {

constexpr uint64_t kMaxHeaderBytes = 16u << 20;

SampleType parseNrrdType(const fs::path& path, const std::string& t) {
  static const std::map<std::string, SampleType> types = {
      {"signed char", SampleType::Int8},       {"int8", SampleType::Int8},
      {"int8_t", SampleType::Int8},            {"uchar", SampleType::UInt8},
      {"unsigned char", SampleType::UInt8},    {"uint8", SampleType::UInt8},
      {"uint8_t", SampleType::UInt8},          {"short", SampleType::Int16},
      {"short int", SampleType::Int16},        {"signed short", SampleType::Int16},
      {"signed short int", SampleType::Int16}, {"int16", SampleType::Int16},
      {"int16_t", SampleType::Int16},          {"ushort", SampleType::UInt16},
      {"unsigned short", SampleType::UInt16},  {"unsigned short int", SampleType::UInt16},
      {"uint16", SampleType::UInt16},          {"uint16_t", SampleType::UInt16},
      {"int", SampleType::Int32},              {"signed int", SampleType::Int32},
      {"int32", SampleType::Int32},            {"int32_t", SampleType::Int32},
      {"uint", SampleType::UInt32},            {"unsigned int", SampleType::UInt32},
      {"uint32", SampleType::UInt32},          {"uint32_t", SampleType::UInt32},
      {"float", SampleType::Float32},          {"double", SampleType::Float64}};
  const auto it = types.find(lower(t));
  if (it == types.end())
    throw FileError(path, "unsupported NRRD type '" + t +
                              "' (supported: int8, uint8, int16, uint16, int32, uint32, float, double)");
  return it->second;
}

const char* nrrdTypeName(SampleType t) {
  switch (t) {
    case SampleType::Int16: return "short";
    case SampleType::UInt8: return "uchar";
    case SampleType::UInt16: return "ushort";
    case SampleType::Float32: return "float";
    default: return "?";
  }
}

/// "(a,b,c) none (d,e,f)" -> vectors; "none" entries become empty vectors.
std::vector<std::vector<double>> parseVectors(const fs::path& path, const std::string& text,
                                              const std::string& field) {
  std::vector<std::vector<double>> out;
  size_t i = 0;
  while (i < text.size()) {
    while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
    if (i >= text.size()) break;
    if (text.compare(i, 4, "none") == 0) {
      out.emplace_back();
      i += 4;
      continue;
    }
    if (text[i] != '(') throw FileError(path, "field '" + field + "': expected '(' or 'none'");
    const size_t close = text.find(')', i);
    if (close == std::string::npos) throw FileError(path, "field '" + field + "': missing ')'");
    out.push_back(parseNumbers(path, std::string_view(text).substr(i + 1, close - i - 1), field, 3));
    i = close + 1;
    if (out.size() > 8) throw FileError(path, "field '" + field + "': too many vectors");
  }
  return out;
}

struct NrrdHeader {
  std::map<std::string, std::string> fields;     // lower-case field name -> value
  std::map<std::string, std::string> keyValues;  // key -> value
  uint64_t dataOffset = 0;                       // attached data: first byte after the header
  bool terminated = false;                       // blank line seen
};

NrrdHeader parseHeader(const fs::path& path) {
  const uint64_t size = fileSize(path);
  const uint64_t n = std::min(size, kMaxHeaderBytes);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError(path, "cannot open for reading");
  std::string head(static_cast<size_t>(n), '\0');
  in.read(head.data(), static_cast<std::streamsize>(n));
  if (head.compare(0, 4, "NRRD") != 0) throw FileError(path, "not a NRRD file (no 'NRRD000x' magic)");

  NrrdHeader h;
  size_t pos = 0;
  int lineNo = 0;
  while (pos < head.size()) {
    size_t eol = head.find('\n', pos);
    const bool lastLine = eol == std::string::npos;
    if (lastLine) {
      if (n < size) break;  // header longer than we are willing to read
      eol = head.size();
    }
    std::string line = head.substr(pos, eol - pos);
    pos = lastLine ? eol : eol + 1;
    ++lineNo;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (lineNo == 1) continue;  // magic
    if (line.empty()) {
      h.terminated = true;
      break;
    }
    if (line[0] == '#') continue;
    const size_t colon = line.find(':');
    if (colon == std::string::npos || colon == 0)
      throw FileError(path, "header line " + std::to_string(lineNo) + " has no ':' separator: '" +
                                line.substr(0, 60) + "'");
    if (colon + 1 < line.size() && line[colon + 1] == '=') {
      h.keyValues[line.substr(0, colon)] = line.substr(colon + 2);
    } else {
      if (colon + 1 >= line.size() || line[colon + 1] != ' ')
        throw FileError(path, "header line " + std::to_string(lineNo) + ": expected ': ' after '" +
                                  line.substr(0, colon) + "'");
      h.fields[lower(trim(line.substr(0, colon)))] = trim(line.substr(colon + 2));
    }
  }
  if (!h.terminated && pos < head.size() && n < size)
    throw FileError(path, "header is longer than 16 MiB or not terminated by a blank line");
  h.dataOffset = pos;
  return h;
}

const std::string* field(const NrrdHeader& h, std::initializer_list<const char*> names) {
  for (const char* name : names) {
    const auto it = h.fields.find(name);
    if (it != h.fields.end()) return &it->second;
  }
  return nullptr;
}

const std::string& required(const fs::path& path, const NrrdHeader& h,
                            std::initializer_list<const char*> names) {
  if (const std::string* v = field(h, names)) return *v;
  throw FileError(path, std::string("missing required NRRD field '") + *names.begin() + "'");
}

int64_t parseInteger(const fs::path& path, const std::string& text, const std::string& name) {
  const auto v = parseNumbers(path, text, name, 1)[0];
  if (v != std::floor(v) || std::abs(v) > 9e15)
    throw FileError(path, "field '" + name + "': '" + text + "' is not an integer");
  return static_cast<int64_t>(v);
}

/// Offset just past `lines` newlines from `offset`; bounded by the file size.
uint64_t skipLines(const fs::path& path, uint64_t offset, int64_t lines) {
  if (lines <= 0) return offset;
  std::ifstream in(path, std::ios::binary);
  in.seekg(static_cast<std::streamoff>(offset));
  char buf[65536];
  int64_t seen = 0;
  while (in) {
    in.read(buf, sizeof buf);
    const auto got = in.gcount();
    for (std::streamsize i = 0; i < got; ++i) {
      if (buf[i] == '\n' && ++seen == lines) return offset + static_cast<uint64_t>(i) + 1;
    }
    offset += static_cast<uint64_t>(got);
    if (got == 0) break;
  }
  throw FileError(path, "truncated: fewer lines than 'line skip' asks to skip");
}

std::vector<uint8_t> readAscii(const fs::path& path, uint64_t offset, uint64_t count,
                               SampleType type) {
  const uint64_t size = fileSize(path);
  std::vector<uint8_t> raw = readBytes(path, offset, size - offset, nullptr);
  try {
    checkMemoryBudget(count * sampleSize(type), "ascii voxel data");
  } catch (const Error& e) {
    throw FileError(path, e.what());
  }
  std::vector<uint8_t> out(static_cast<size_t>(count * sampleSize(type)));
  std::string text(raw.begin(), raw.end());
  raw.clear();
  const char* p = text.c_str();
  const char* end = p + text.size();
  for (uint64_t i = 0; i < count; ++i) {
    while (p < end && (std::isspace(static_cast<unsigned char>(*p)) || *p == ',')) ++p;
    char* next = nullptr;
    const double v = std::strtod(p, &next);
    if (next == p) throw FileError(path, "ascii data: value " + std::to_string(i) + " missing or not a number");
    p = next;
    uint8_t* dst = out.data() + i * sampleSize(type);
    auto put = [&](auto x) { std::memcpy(dst, &x, sizeof x); };
    switch (type) {
      case SampleType::Int8: put(static_cast<int8_t>(v)); break;
      case SampleType::UInt8: put(static_cast<uint8_t>(v)); break;
      case SampleType::Int16: put(static_cast<int16_t>(v)); break;
      case SampleType::UInt16: put(static_cast<uint16_t>(v)); break;
      case SampleType::Int32: put(static_cast<int32_t>(v)); break;
      case SampleType::UInt32: put(static_cast<uint32_t>(v)); break;
      case SampleType::Float32: put(static_cast<float>(v)); break;
      case SampleType::Float64: put(v); break;
    }
  }
  return out;
}

}  // namespace

namespace {

/// What a header says about the samples and where they are.
struct NrrdDescription {
  SampleType type = SampleType::UInt8;
  std::vector<int64_t> leadingSizes;     ///< non-spatial axes before x (at most one)
  std::vector<std::string> leadingKinds;
  Geometry g;
  fs::path dataPath;
  uint64_t offset = 0;  ///< first data byte (after 'line skip'; before 'byte skip')
  int64_t byteSkip = 0;
  std::string encoding;
  Endian endian = Endian::Little;
  uint64_t sampleCount() const {
    uint64_t n = static_cast<uint64_t>(g.dims.voxelCount());
    for (int64_t s : leadingSizes) n *= static_cast<uint64_t>(s);
    return n;
  }
};

/// Spacing and direction ('space directions' or 'spacings'), origin and space of the three
/// spatial axes, which follow `first` leading axes.
void parseNrrdGeometry(const fs::path& path, const NrrdHeader& h, int64_t dimension, int first, Geometry& g) {
  if (const std::string* dirs = field(h, {"space directions"})) {
    auto vecs = parseVectors(path, *dirs, "space directions");
    if (vecs.size() != static_cast<size_t>(dimension))
      throw FileError(path, "field 'space directions': expected " + std::to_string(dimension) + " entries");
    for (int a = 0; a < 3; ++a) {
      const auto& v = vecs[static_cast<size_t>(first + a)];
      if (v.empty()) throw FileError(path, "field 'space directions': spatial axis is 'none'");
      const Vec3 col{v[0], v[1], v[2]};
      g.spacing[a] = norm(col);
      const Vec3 unit = g.spacing[a] > 0 ? col / g.spacing[a] : col;
      for (int r = 0; r < 3; ++r) g.direction(r, a) = unit[r];
    }
  } else if (const std::string* sp = field(h, {"spacings"})) {
    const auto s = parseNumbers(path, *sp, "spacings", size_t(dimension));
    g.spacing = {s[size_t(first)], s[size_t(first) + 1], s[size_t(first) + 2]};
  }
  if (const std::string* o = field(h, {"space origin"})) {
    const auto v = parseVectors(path, *o, "space origin");
    if (v.size() != 1 || v[0].size() != 3) throw FileError(path, "field 'space origin': expected (x,y,z)");
    g.origin = {v[0][0], v[0][1], v[0][2]};
  }
  if (const std::string* space = field(h, {"space"})) {
    const std::string s = lower(*space);
    Vec3 flip{1, 1, 1};
    if (s == "left-posterior-superior" || s == "lps" || s == "3d-right-handed") {
    } else if (s == "right-anterior-superior" || s == "ras") {
      flip = {-1, -1, 1};
    } else if (s == "left-anterior-superior" || s == "las") {
      flip = {1, -1, 1};
    } else {
      throw FileError(path, "unsupported NRRD space '" + *space + "' (LPS, RAS or LAS)");
    }
    g.origin = mul(g.origin, flip);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) g.direction(r, c) *= flip[r];
  }
  checkGeometry(path, g);
}

}  // namespace

std::string nrrdDataFileName(const fs::path& header) {
  try {
    const NrrdHeader h = parseHeader(header);  // `field` points into it
    const std::string* df = field(h, {"data file", "datafile"});
    return df ? *df : std::string();
  } catch (const FileError&) {
    return {};  // not a readable NRRD header: it names no data file
  }
}

namespace {

/// The data file, offset, encoding and byte order the header names.
void locateNrrdData(const fs::path& path, const NrrdHeader& h, NrrdDescription& d, bool allowOutsideData) {
  d.dataPath = path;
  d.offset = h.dataOffset;
  if (const std::string* df = field(h, {"data file", "datafile"})) {
    if (df->rfind("LIST", 0) == 0 || df->find('%') != std::string::npos)
      throw FileError(path, "multi-file NRRD data ('" + *df + "') is not supported");
    d.dataPath = headerDataFile(path, *df, allowOutsideData);
    d.offset = 0;
  } else if (!h.terminated) {
    throw FileError(path, "header has no blank line ending it and no 'data file' field");
  }
  if (d.dataPath != path && !fs::exists(d.dataPath))
    throw FileError(path, "data file " + d.dataPath.string() + " does not exist");

  d.encoding = lower(required(path, h, {"encoding"}));
  if (const std::string* e = field(h, {"endian"})) {
    const std::string el = lower(*e);
    if (el == "big") d.endian = Endian::Big;
    else if (el != "little") throw FileError(path, "field 'endian': '" + *e + "' (little or big)");
  } else if (sampleSize(d.type) > 1 && d.encoding != "ascii" && d.encoding != "text" && d.encoding != "txt") {
    throw FileError(path, "missing required NRRD field 'endian'");
  }
  int64_t lineSkip = 0;
  if (const std::string* ls = field(h, {"line skip", "lineskip"})) lineSkip = parseInteger(path, *ls, "line skip");
  if (const std::string* bs = field(h, {"byte skip", "byteskip"})) d.byteSkip = parseInteger(path, *bs, "byte skip");
  if (lineSkip < 0 || d.byteSkip < -1) throw FileError(path, "negative line skip or byte skip");
  d.offset = skipLines(d.dataPath, d.offset, lineSkip);
}

/// Parses everything but the samples. `maxLeading`: largest leading (non-spatial) axis
/// accepted (1 for scalar volumes: Slicer's 4-D single-layer segmentations).
NrrdDescription describeNrrd(const fs::path& path, const NrrdHeader& h, int64_t maxLeading, bool allowOutsideData) {
  NrrdDescription d;
  d.type = parseNrrdType(path, required(path, h, {"type"}));
  const int64_t dimension = parseInteger(path, required(path, h, {"dimension"}), "dimension");
  if (dimension != 3 && dimension != 4)
    throw FileError(path, "dimension " + std::to_string(dimension) + " not supported (3-D images only)");
  const auto sizes = parseNumbers(path, required(path, h, {"sizes"}), "sizes", size_t(dimension));
  for (double s : sizes)
    if (s != std::floor(s) || s < 1 || s > 1e9)
      throw FileError(path, "invalid sizes '" + required(path, h, {"sizes"}) + "'");
  const int first = dimension == 4 ? 1 : 0;  // 4-D: one leading non-spatial axis
  if (dimension == 4 && sizes[0] > static_cast<double>(maxLeading))
    throw FileError(path, "4-D NRRD with " + fmt(sizes[0]) + " components per voxel is not supported");
  if (first) {
    d.leadingSizes = {static_cast<int64_t>(sizes[0])};
    const std::string* kinds = field(h, {"kinds"});
    std::istringstream ks(kinds ? *kinds : std::string());
    std::string kind;
    d.leadingKinds = {ks >> kind ? kind : "???"};
  }
  d.g.dims = {static_cast<int64_t>(sizes[first]), static_cast<int64_t>(sizes[first + 1]),
              static_cast<int64_t>(sizes[first + 2])};
  checkAllocation(path, d.g.dims, sampleSize(d.type) * static_cast<uint64_t>(first ? sizes[0] : 1));
  parseNrrdGeometry(path, h, dimension, first, d.g);
  locateNrrdData(path, h, d, allowOutsideData);
  return d;
}

/// First byte of raw samples (after 'byte skip'; -1: the data end the file).
uint64_t rawOffset(const NrrdDescription& d, uint64_t bytes) {
  if (d.byteSkip != -1) return d.offset + static_cast<uint64_t>(d.byteSkip);
  const uint64_t size = fileSize(d.dataPath);
  if (size < bytes + d.offset) throw FileError(d.dataPath, "truncated: file smaller than the voxel data");
  return size - bytes;
}

/// The whole gzip stream after the header (and line skips).
std::vector<uint8_t> readPacked(const NrrdDescription& d, const fs::path& path, Progress* progress) {
  if (d.byteSkip < 0) throw FileError(path, "'byte skip: -1' is not allowed with gzip encoding");
  const uint64_t size = fileSize(d.dataPath);
  if (d.offset > size) throw FileError(d.dataPath, "truncated: no compressed data");
  return readBytes(d.dataPath, d.offset, size - d.offset, progress);
}

bool isGzip(const std::string& encoding) { return encoding == "gzip" || encoding == "gz"; }

/// The samples as stored (byte order d.endian; ascii text becomes host order and d.endian says so).
std::vector<uint8_t> readNrrdSamples(NrrdDescription& d, const fs::path& path, Progress* progress) {
  const uint64_t count = d.sampleCount();
  const uint64_t bytes = count * sampleSize(d.type);
  std::vector<uint8_t> data;
  if (d.encoding == "raw") {
    data = readBytes(d.dataPath, rawOffset(d, bytes), bytes, progress);
  } else if (isGzip(d.encoding)) {
    const std::vector<uint8_t> packed = readPacked(d, path, progress);
    data = inflateExact(d.dataPath, packed.data(), packed.size(), bytes + static_cast<uint64_t>(d.byteSkip));
    if (d.byteSkip > 0) data.erase(data.begin(), data.begin() + d.byteSkip);
  } else if (d.encoding == "ascii" || d.encoding == "text" || d.encoding == "txt") {
    data = readAscii(d.dataPath, d.offset + static_cast<uint64_t>(std::max<int64_t>(d.byteSkip, 0)), count, d.type);
    d.endian = hostEndian();
  } else {
    throw FileError(path, "unsupported NRRD encoding '" + d.encoding + "' (raw, gzip or ascii)");
  }
  return data;
}

/// A scalar volume: raw and gzip samples go straight into the volume's buffer (no staging
/// copy); ascii and gzip with a byte skip through readNrrdSamples.
AnyVolume readNrrdVolume(NrrdDescription& d, const fs::path& path, Progress* progress) {
  const uint64_t bytes = d.sampleCount() * sampleSize(d.type);
  if (d.encoding == "raw") {
    const uint64_t offset = rawOffset(d, bytes);
    checkFileHolds(d.dataPath, offset, bytes);
    return readVoxels(d.dataPath, d.type, d.endian, d.g,
                      [&](uint8_t* dst, uint64_t n) { readInto(d.dataPath, offset, n, dst, progress); });
  }
  if (isGzip(d.encoding) && d.byteSkip == 0) {
    const std::vector<uint8_t> packed = readPacked(d, path, progress);
    checkInflatedSize(d.dataPath, packed.size(), bytes);
    return readVoxels(d.dataPath, d.type, d.endian, d.g, [&](uint8_t* dst, uint64_t n) {
      inflateExactInto(d.dataPath, packed.data(), packed.size(), dst, n);
    });
  }
  std::vector<uint8_t> data = readNrrdSamples(d, path, progress);
  return decodeVoxels(d.dataPath, std::move(data), d.type, d.endian, d.g);
}

const char* canonicalTypeName(SampleType t) {
  switch (t) {
    case SampleType::Int8: return "signed char";
    case SampleType::UInt8: return "uchar";
    case SampleType::Int16: return "short";
    case SampleType::UInt16: return "ushort";
    case SampleType::Int32: return "int";
    case SampleType::UInt32: return "uint";
    case SampleType::Float32: return "float";
    case SampleType::Float64: return "double";
  }
  return "?";
}

NrrdLayout layoutOf(const NrrdDescription& d) {
  NrrdLayout l;
  l.type = canonicalTypeName(d.type);
  l.leadingSizes = d.leadingSizes;
  l.leadingKinds = d.leadingKinds;
  l.geometry = d.g;
  return l;
}

}  // namespace

LoadedVolume loadNrrd(const fs::path& path, const LoadOptions& options, ExtraFields* extra) {
  const NrrdHeader h = parseHeader(path);
  NrrdDescription d = describeNrrd(path, h, 1, options.allowOutsideData);
  AnyVolume vol = readNrrdVolume(d, path, options.progress);

  std::string modality;
  if (const auto it = h.keyValues.find("vellum_modality"); it != h.keyValues.end()) modality = trim(it->second);
  LoadedVolume out = makeLoaded(std::move(vol), "nrrd", modality);
  if (extra) {
    extra->modality = out.modality;
    extra->labels = parseLabelFields(path, h.keyValues, &extra->hasLabels);
  }
  return out;
}

void saveNrrd(const AnyVolume& v, const fs::path& path, bool gzip, const std::string& modality,
              const std::vector<Label>* labels, Progress* progress) {
  const Geometry& g = geometryOf(v);
  NrrdLayout layout;
  layout.type = nrrdTypeName(sampleTypeFor(voxelTypeOf(v)));
  layout.geometry = g;
  layout.comments = {"Written by Vellum. Format: http://teem.sourceforge.net/nrrd/format.html"};
  std::ostringstream extra;
  if (!modality.empty()) extra << "vellum_modality:=" << oneLine(modality) << "\n";
  if (labels) writeLabelFields(extra, *labels, g.dims);
  layout.extraFields = extra.str();
  const ByteView body = voxelBytes(v);
  writeNrrd(path, layout, body.data, body.size, gzip, progress);
}

}  // namespace vellum::io::detail

namespace vellum::io {

NrrdContents readNrrd(const std::filesystem::path& path, Progress* progress) {
  using namespace detail;
  const NrrdHeader h = parseHeader(path);
  NrrdDescription d = describeNrrd(path, h, 1 << 16, false);
  NrrdContents c;
  c.bytes = readNrrdSamples(d, path, progress);
  if (d.endian != hostEndian()) {  // samples to host order
    const size_t w = static_cast<size_t>(sampleSize(d.type));
    for (size_t i = 0; i + w <= c.bytes.size(); i += w) std::reverse(c.bytes.begin() + i, c.bytes.begin() + i + w);
  }
  c.layout = layoutOf(d);
  return c;
}

NrrdLayout readNrrdHeader(const std::filesystem::path& path) {
  using namespace detail;
  return layoutOf(describeNrrd(path, parseHeader(path), 1 << 16, false));
}

}  // namespace vellum::io
