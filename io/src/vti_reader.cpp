// Reading VTK XML image data (.vti) ourselves. VTK's vtkXMLImageDataReader trusts the counts
// a file states (fuzzing found eight ways to crash it: huge block counts, zero block sizes, a
// missing type, byte counts of 2^64 ...), and a pre-check in front of it could never parse
// exactly as VTK does. So one parser reads the file and checks every count against the file
// before allocating; VTK still writes .vti (vti.cpp) and the tests read VTK's output in every
// mode it writes (ascii, inline base64, appended raw/base64, zlib or none, UInt32/UInt64
// headers, both byte orders).
//
// Layout read here (VTK's XML file format): <VTKFile type="ImageData" byte_order header_type
// compressor> <ImageData WholeExtent Origin Spacing Direction> <FieldData>? <Piece Extent>
// <PointData Scalars> <DataArray type Name NumberOfComponents format offset>. A binary array is
// a header of UInt32/UInt64 integers then the data: uncompressed, [byte count]; zlib, [block
// count, block size, last block size, compressed size of each block], each block a zlib stream.
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <limits>
#include <cstring>
#include <fstream>
#include <map>
#include <optional>
#include <string_view>

#include "io_detail.hpp"
#include "vellum/core/memory_budget.hpp"

namespace vellum::io::detail {

namespace {

using Attributes = std::map<std::string, std::string, std::less<>>;

struct XmlTag {
  std::string name;  ///< without '<' / '</'
  Attributes attributes;
  bool closing = false, selfClosing = false;
  size_t begin = 0, end = 0;  ///< '<' and one past '>'
};

/// The next tag at or after `pos` (skipping text, comments, the prolog); nullopt at the end.
std::optional<XmlTag> nextTag(const fs::path& path, std::string_view text, size_t pos) {
  for (;;) {
    const size_t lt = text.find('<', pos);
    if (lt == std::string_view::npos) return std::nullopt;
    if (text.compare(lt, 4, "<!--") == 0) {
      const size_t e = text.find("-->", lt + 4);
      if (e == std::string_view::npos) throw FileError(path, "unterminated XML comment");
      pos = e + 3;
      continue;
    }
    if (text.compare(lt, 2, "<?") == 0 || text.compare(lt, 2, "<!") == 0) {
      const size_t e = text.find('>', lt);
      if (e == std::string_view::npos) throw FileError(path, "unterminated XML declaration");
      pos = e + 1;
      continue;
    }
    XmlTag tag;
    tag.begin = lt;
    size_t p = lt + 1;
    if (p < text.size() && text[p] == '/') tag.closing = true, ++p;
    const auto isNameChar = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == ':' || c == '-' || c == '.'; };
    const size_t nameBegin = p;
    while (p < text.size() && isNameChar(text[p])) ++p;
    tag.name = std::string(text.substr(nameBegin, p - nameBegin));
    if (tag.name.empty()) throw FileError(path, "malformed XML tag at byte " + std::to_string(lt));
    for (;;) {
      while (p < text.size() && std::isspace(static_cast<unsigned char>(text[p]))) ++p;
      if (p >= text.size()) throw FileError(path, "unterminated XML tag <" + tag.name + ">");
      if (text[p] == '>') break;
      if (text[p] == '/' && p + 1 < text.size() && text[p + 1] == '>') {
        tag.selfClosing = true;
        ++p;
        break;
      }
      const size_t keyBegin = p;
      while (p < text.size() && isNameChar(text[p])) ++p;
      const std::string key(text.substr(keyBegin, p - keyBegin));
      while (p < text.size() && std::isspace(static_cast<unsigned char>(text[p]))) ++p;
      if (key.empty() || p + 1 >= text.size() || text[p] != '=')
        throw FileError(path, "malformed attribute in XML tag <" + tag.name + ">");
      ++p;
      while (p < text.size() && std::isspace(static_cast<unsigned char>(text[p]))) ++p;
      const char quote = p < text.size() ? text[p] : '\0';
      if (quote != '"' && quote != '\'') throw FileError(path, "unquoted attribute " + key + " in <" + tag.name + ">");
      const size_t close = text.find(quote, p + 1);
      if (close == std::string_view::npos) throw FileError(path, "unterminated attribute " + key + " in <" + tag.name + ">");
      tag.attributes[key] = std::string(text.substr(p + 1, close - p - 1));
      p = close + 1;
    }
    tag.end = p + 1;
    return tag;
  }
}

const std::string* attribute(const XmlTag& tag, std::string_view key) {
  const auto it = tag.attributes.find(key);
  return it == tag.attributes.end() ? nullptr : &it->second;
}

/// A <DataArray> or <Array>: its attributes and, for inline formats, its text.
struct ArrayElement {
  XmlTag tag;
  std::string_view content;
};

/// What the XML part of the file says.
struct VtiStructure {
  XmlTag file, image;
  std::optional<XmlTag> piece, pointData;
  int pieces = 0;
  std::vector<ArrayElement> pointArrays, fieldArrays;
  std::optional<XmlTag> appended;
  uint64_t appendedBase = 0;  ///< file offset of the byte after '_'
};

/// Walks the tags up to <AppendedData> (after which the bytes are binary), checking nesting.
VtiStructure parseStructure(const fs::path& path, std::string_view text, uint64_t textOffset) {
  VtiStructure s;
  std::vector<std::string> open;
  std::optional<XmlTag> pendingArray;
  for (size_t pos = 0;;) {
    auto tag = nextTag(path, text, pos);
    if (!tag) break;
    pos = tag->end;
    if (tag->closing) {
      if (open.empty() || open.back() != tag->name)
        throw FileError(path, "XML end tag </" + tag->name + "> does not match " +
                                  (open.empty() ? std::string("any open element") : "<" + open.back() + ">"));
      if (pendingArray && (tag->name == "DataArray" || tag->name == "Array")) {
        const std::string_view content = text.substr(pendingArray->end, tag->begin - pendingArray->end);
        const bool inPointData = std::find(open.begin(), open.end(), "PointData") != open.end();
        (inPointData ? s.pointArrays : s.fieldArrays).push_back({*pendingArray, content});
        pendingArray.reset();
      }
      open.pop_back();
      continue;
    }
    const std::string& parent = open.empty() ? std::string() : open.back();
    if (open.empty() && tag->name != "VTKFile") throw FileError(path, "not a VTK XML file (no <VTKFile> element)");
    if (tag->name == "VTKFile") s.file = *tag;
    else if (tag->name == "ImageData" && parent == "VTKFile") s.image = *tag;
    else if (tag->name == "Piece") s.piece = *tag, ++s.pieces;
    else if (tag->name == "PointData" && parent == "Piece") s.pointData = *tag;
    else if (tag->name == "DataArray" || tag->name == "Array") {
      const bool inPointData = parent == "PointData", inFieldData = parent == "FieldData";
      if (tag->selfClosing && (inPointData || inFieldData))
        (inPointData ? s.pointArrays : s.fieldArrays).push_back({*tag, {}});
      else if (!tag->selfClosing && (inPointData || inFieldData))
        pendingArray = *tag;
    } else if (tag->name == "AppendedData") {
      // Binary data follows: whitespace, '_', then the arrays' bytes at their offsets.
      size_t p = tag->end;
      while (p < text.size() && std::isspace(static_cast<unsigned char>(text[p]))) ++p;
      if (p >= text.size() || text[p] != '_')
        throw FileError(path, "<AppendedData> does not start with '_' after its tag");
      s.appended = *tag;
      s.appendedBase = textOffset + p + 1;
      return s;
    }
    if (!tag->selfClosing) open.push_back(tag->name);
  }
  if (!open.empty()) throw FileError(path, "truncated: XML element <" + open.back() + "> is not closed");
  return s;
}

// ---- numbers in attributes ----

template <size_t N>
std::array<double, N> numbersOf(const fs::path& path, const XmlTag& tag, const char* key, std::optional<std::array<double, N>> fallback = std::nullopt) {
  const std::string* text = attribute(tag, key);
  if (!text) {
    if (fallback) return *fallback;
    throw FileError(path, "<" + tag.name + "> has no " + key + " attribute");
  }
  const auto v = parseNumbers(path, *text, key, N);
  std::array<double, N> out{};
  for (size_t i = 0; i < N; ++i) {
    if (!std::isfinite(v[i])) throw FileError(path, std::string(key) + " is not finite");
    out[i] = v[i];
  }
  return out;
}

std::array<int64_t, 6> extentOf(const fs::path& path, const XmlTag& tag, const char* key) {
  const auto e = numbersOf<6>(path, tag, key);
  std::array<int64_t, 6> out{};
  for (int i = 0; i < 6; ++i) {
    if (e[i] != std::floor(e[i]) || std::abs(e[i]) > 1e9) throw FileError(path, std::string(key) + " is not a list of 6 integers");
    out[i] = static_cast<int64_t>(e[i]);
  }
  for (int a = 0; a < 3; ++a)
    if (out[2 * a + 1] < out[2 * a]) throw FileError(path, std::string(key) + " is empty along axis " + std::to_string(a));
  return out;
}

// ---- array bytes ----

struct Encoding {
  uint64_t headerBytes = 4;  ///< UInt32 or UInt64 header integers
  bool compressed = false;   ///< vtkZLibDataCompressor
  Endian endian = Endian::Little;
};

uint64_t headerValue(const uint8_t* p, const Encoding& e) {
  uint64_t v = 0;
  for (uint64_t b = 0; b < e.headerBytes; ++b) {
    const uint64_t byte = p[e.endian == Endian::Little ? b : e.headerBytes - 1 - b];
    v |= byte << (8 * b);
  }
  return v;
}

/// Reads bytes of an array as a sequence of "chunks": raw bytes, or base64 text where VTK
/// encodes each chunk (the compressed header, then the data) as its own base64 run.
class ChunkReader {
 public:
  virtual ~ChunkReader() = default;
  /// The next `n` bytes of the current chunk.
  virtual std::vector<uint8_t> read(uint64_t n) = 0;
  /// Ends the current chunk (base64: the next chunk starts at a fresh 4-character group).
  virtual void endChunk() {}
};

class RawFileReader final : public ChunkReader {
 public:
  RawFileReader(const fs::path& path, uint64_t offset, Progress* progress) : path_(path), offset_(offset), progress_(progress) {}
  std::vector<uint8_t> read(uint64_t n) override {
    auto bytes = readBytes(path_, offset_, n, n > (1u << 20) ? progress_ : nullptr);
    offset_ += n;
    return bytes;
  }

 private:
  fs::path path_;
  uint64_t offset_;
  Progress* progress_;
};

class Base64Reader final : public ChunkReader {
 public:
  Base64Reader(const fs::path& path, std::string_view text) : path_(path), text_(text) {}
  std::vector<uint8_t> read(uint64_t n) override {
    // Every 4 characters give 3 bytes; the remainder of the group is kept for the next read.
    if (n > 3 * (text_.size() / 4) + 3) throw truncated(n);
    std::vector<uint8_t> out;
    out.reserve(static_cast<size_t>(n));
    while (out.size() < n) {
      if (pending_.empty()) decodeGroup();
      const size_t take = std::min<size_t>(pending_.size(), static_cast<size_t>(n) - out.size());
      out.insert(out.end(), pending_.begin(), pending_.begin() + take);
      pending_.erase(pending_.begin(), pending_.begin() + take);
    }
    return out;
  }
  void endChunk() override { pending_.clear(); }

 private:
  FileError truncated(uint64_t n) const {
    return FileError(path_, "truncated: base64 data holds fewer than the " + std::to_string(n) + " bytes the array needs");
  }
  int nextChar() {
    while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
    if (pos_ >= text_.size()) throw truncated(0);
    return static_cast<unsigned char>(text_[pos_++]);
  }
  void decodeGroup() {
    uint32_t bits = 0;
    int valid = 0;
    for (int i = 0; i < 4; ++i) {
      const int c = nextChar();
      int v;
      if (c >= 'A' && c <= 'Z') v = c - 'A';
      else if (c >= 'a' && c <= 'z') v = c - 'a' + 26;
      else if (c >= '0' && c <= '9') v = c - '0' + 52;
      else if (c == '+') v = 62;
      else if (c == '/') v = 63;
      else if (c == '=' && i >= 2) v = -1;
      else throw FileError(path_, "invalid base64 character in array data");
      bits = bits << 6 | static_cast<uint32_t>(v < 0 ? 0 : v);
      if (v >= 0 && valid == i) ++valid;
    }
    const int bytes = valid == 4 ? 3 : valid - 1;
    if (bytes <= 0) throw FileError(path_, "invalid base64 padding in array data");
    for (int b = 0; b < bytes; ++b) pending_.push_back(static_cast<uint8_t>(bits >> (16 - 8 * b)));
  }
  fs::path path_;
  std::string_view text_;
  size_t pos_ = 0;
  std::vector<uint8_t> pending_;
};

/// The array's data bytes (file byte order) from a binary chunk reader. `exact`: the bytes the
/// array must hold (0 = unknown, then at most `cap`).
std::vector<uint8_t> binaryArrayBytes(const fs::path& path, ChunkReader& in, const Encoding& e, uint64_t exact, uint64_t cap,
                                      uint64_t fileBytes) {
  const auto expectSize = [&](uint64_t total) {
    if (exact && total != exact)
      throw FileError(path, "array holds " + std::to_string(total) + " bytes, expected " + std::to_string(exact) + " (truncated?)");
    if (!exact && total > cap) throw FileError(path, "array of " + std::to_string(total) + " bytes is implausibly large");
  };
  if (!e.compressed) {
    const uint64_t bytes = headerValue(in.read(e.headerBytes).data(), e);
    expectSize(bytes);
    return in.read(bytes);
  }
  const uint64_t blocks = headerValue(in.read(e.headerBytes).data(), e);
  if (blocks > fileBytes / e.headerBytes)
    throw FileError(path, "corrupt compressed array header: " + std::to_string(blocks) + " blocks in a file of " +
                              std::to_string(fileBytes) + " bytes");
  const auto rest = in.read((2 + blocks) * e.headerBytes);
  in.endChunk();
  const uint64_t blockSize = headerValue(rest.data(), e), lastSize = headerValue(rest.data() + e.headerBytes, e);
  if (blocks == 0) {
    expectSize(0);
    return {};
  }
  if (blockSize == 0 || lastSize > blockSize)
    throw FileError(path, "corrupt compressed array header (block size " + std::to_string(blockSize) + ", last block " +
                              std::to_string(lastSize) + ")");
  const uint64_t last = lastSize ? lastSize : blockSize;
  if (blockSize > (uint64_t{1} << 40)) throw FileError(path, "corrupt compressed array header (block size " + std::to_string(blockSize) + ")");
  expectSize((blocks - 1) * blockSize + last);
  std::vector<uint64_t> sizes(static_cast<size_t>(blocks)), starts(static_cast<size_t>(blocks) + 1, 0);
  for (uint64_t b = 0; b < blocks; ++b) {
    sizes[b] = headerValue(rest.data() + (2 + b) * e.headerBytes, e);
    if (sizes[b] > fileBytes) throw FileError(path, "corrupt compressed array header (block of " + std::to_string(sizes[b]) + " bytes)");
    starts[b + 1] = starts[b] + sizes[b];
  }
  if (starts.back() > fileBytes) throw FileError(path, "truncated: compressed blocks larger than the file");
  const std::vector<uint8_t> packed = in.read(starts.back());
  const uint64_t total = (blocks - 1) * blockSize + last;
  checkMemoryBudget(total, "decompressed data");
  std::vector<uint8_t> out(static_cast<size_t>(total));
  // Blocks are independent zlib streams: inflate them in parallel.
  tbb::parallel_for(uint64_t{0}, blocks, [&](uint64_t b) {
    const uint64_t want = b + 1 == blocks ? last : blockSize;
    const auto block = inflateExact(path, packed.data() + starts[b], static_cast<size_t>(sizes[b]), want);
    std::memcpy(out.data() + b * blockSize, block.data(), block.size());
  });
  return out;
}

std::optional<SampleType> sampleTypeOf(std::string_view name) {
  static const std::map<std::string, SampleType, std::less<>> kTypes{
      {"Int8", SampleType::Int8},     {"UInt8", SampleType::UInt8},     {"Int16", SampleType::Int16},
      {"UInt16", SampleType::UInt16}, {"Int32", SampleType::Int32},     {"UInt32", SampleType::UInt32},
      {"Float32", SampleType::Float32}, {"Float64", SampleType::Float64}};
  const auto it = kTypes.find(name);
  return it == kTypes.end() ? std::nullopt : std::optional(it->second);
}

/// ASCII array values as `type` bytes in host order.
std::vector<uint8_t> asciiArrayBytes(const fs::path& path, std::string_view text, SampleType type, uint64_t count) {
  const uint64_t size = sampleSize(type);
  checkMemoryBudget(count * size, "array data");
  std::vector<uint8_t> out(static_cast<size_t>(count * size));
  const char* p = text.data();
  const char* end = text.data() + text.size();
  for (uint64_t i = 0; i < count; ++i) {
    while (p < end && std::isspace(static_cast<unsigned char>(*p))) ++p;
    double v = 0;
    const auto r = std::from_chars(p, end, v);
    if (r.ec != std::errc() || !std::isfinite(v))
      throw FileError(path, "ascii array: value " + std::to_string(i) + " of " + std::to_string(count) +
                                (p >= end ? " is missing (truncated?)" : " is not a number"));
    p = r.ptr;
    uint8_t* dst = out.data() + i * size;
    const auto put = [&](auto typed) {
      using T = decltype(typed);
      if constexpr (std::is_integral_v<T>) {
        if (v < double(std::numeric_limits<T>::min()) || v > double(std::numeric_limits<T>::max()) || v != std::floor(v))
          throw FileError(path, "ascii array: value " + std::to_string(i) + " does not fit " + sampleTypeName(type));
      }
      const T t = static_cast<T>(v);
      std::memcpy(dst, &t, sizeof t);
    };
    switch (type) {
      case SampleType::Int8: put(int8_t{}); break;
      case SampleType::UInt8: put(uint8_t{}); break;
      case SampleType::Int16: put(int16_t{}); break;
      case SampleType::UInt16: put(uint16_t{}); break;
      case SampleType::Int32: put(int32_t{}); break;
      case SampleType::UInt32: put(uint32_t{}); break;
      case SampleType::Float32: put(float{}); break;
      case SampleType::Float64: put(double{}); break;
    }
  }
  return out;
}

struct FileContext {
  fs::path path;
  uint64_t fileBytes = 0;
  Encoding encoding;
  const VtiStructure* structure = nullptr;
  std::string_view appendedText;  ///< base64 appended data (empty for raw)
  bool appendedBase64 = false;
  Progress* progress = nullptr;
};

/// The bytes of one array (file byte order for binary formats, host order for ascii).
std::vector<uint8_t> arrayBytes(const FileContext& cx, const ArrayElement& a, SampleType type, uint64_t exactBytes, uint64_t cap,
                                Endian& byteOrder) {
  const std::string* format = attribute(a.tag, "format");
  if (!format) throw FileError(cx.path, "<" + a.tag.name + "> without a format attribute");
  byteOrder = cx.encoding.endian;
  if (*format == "ascii") {
    byteOrder = hostEndian();
    // Without a known count (string arrays: one character code per value), every value.
    uint64_t count = exactBytes / sampleSize(type);
    if (!exactBytes) {
      const auto values = parseNumbers(cx.path, a.content, "ascii array");
      if (values.size() > cap) throw FileError(cx.path, "ascii array of " + std::to_string(values.size()) + " values is implausibly large");
      count = values.size();
    }
    return asciiArrayBytes(cx.path, a.content, type, count);
  }
  if (*format == "binary") {
    Base64Reader in(cx.path, a.content);
    return binaryArrayBytes(cx.path, in, cx.encoding, exactBytes, cap, cx.fileBytes);
  }
  if (*format != "appended") throw FileError(cx.path, "unknown array format '" + *format + "'");
  if (!cx.structure->appended) throw FileError(cx.path, "appended array but no <AppendedData>");
  const std::string* offsetText = attribute(a.tag, "offset");
  uint64_t offset = 0;
  if (!offsetText || std::from_chars(offsetText->data(), offsetText->data() + offsetText->size(), offset).ec != std::errc())
    throw FileError(cx.path, "appended array without a valid offset");
  if (cx.appendedBase64) {
    if (offset > cx.appendedText.size()) throw FileError(cx.path, "appended data offset " + std::to_string(offset) + " lies beyond the end of the file");
    Base64Reader in(cx.path, cx.appendedText.substr(static_cast<size_t>(offset)));
    return binaryArrayBytes(cx.path, in, cx.encoding, exactBytes, cap, cx.fileBytes);
  }
  const uint64_t at = cx.structure->appendedBase + offset;
  if (offset > cx.fileBytes || at > cx.fileBytes)
    throw FileError(cx.path, "appended data offset " + std::to_string(offset) + " lies beyond the end of the file");
  RawFileReader in(cx.path, at, cx.progress);
  return binaryArrayBytes(cx.path, in, cx.encoding, exactBytes, cap, cx.fileBytes);
}

Encoding encodingOf(const fs::path& path, const XmlTag& file) {
  Encoding e;
  if (const auto* t = attribute(file, "type"); !t || *t != "ImageData")
    throw FileError(path, "not VTK image data (VTKFile type '" + (t ? *t : std::string()) + "')");
  if (const auto* h = attribute(file, "header_type")) {
    if (*h == "UInt64") e.headerBytes = 8;
    else if (*h != "UInt32") throw FileError(path, "unknown header_type '" + *h + "'");
  }
  if (const auto* b = attribute(file, "byte_order")) {
    if (*b == "BigEndian") e.endian = Endian::Big;
    else if (*b != "LittleEndian") throw FileError(path, "unknown byte_order '" + *b + "'");
  }
  if (const auto* c = attribute(file, "compressor"); c && !c->empty()) {
    if (*c != "vtkZLibDataCompressor")
      throw FileError(path, "compressor " + *c + " is not supported (zlib or none; re-save the file with zlib)");
    e.compressed = true;
  }
  return e;
}

Geometry geometryOf(const fs::path& path, const VtiStructure& s, std::array<int64_t, 6>& extent) {
  extent = extentOf(path, s.image, "WholeExtent");
  if (s.pieces != 1) throw FileError(path, std::to_string(s.pieces) + " pieces (one piece expected)");
  if (extentOf(path, *s.piece, "Extent") != extent) throw FileError(path, "the piece's Extent differs from the WholeExtent");
  Geometry g;
  g.dims = {extent[1] - extent[0] + 1, extent[3] - extent[2] + 1, extent[5] - extent[4] + 1};
  const auto sp = numbersOf<3>(path, s.image, "Spacing", std::array<double, 3>{1, 1, 1});
  const auto org = numbersOf<3>(path, s.image, "Origin", std::array<double, 3>{0, 0, 0});
  const auto dir = numbersOf<9>(path, s.image, "Direction", std::array<double, 9>{1, 0, 0, 0, 1, 0, 0, 0, 1});
  g.spacing = {sp[0], sp[1], sp[2]};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) g.direction(r, c) = dir[3 * r + c];  // row-major, like Mat3
  // VTK's origin belongs to structured index (0,0,0); ours to the first voxel of the extent.
  g.origin = Vec3{org[0], org[1], org[2]} +
             g.direction * mul(Vec3{double(extent[0]), double(extent[2]), double(extent[4])}, g.spacing);
  return g;
}

const ArrayElement& scalarArray(const fs::path& path, const VtiStructure& s) {
  if (s.pointArrays.empty()) throw FileError(path, "no point data array");
  const std::string* wanted = s.pointData ? attribute(*s.pointData, "Scalars") : nullptr;
  if (wanted)
    for (const auto& a : s.pointArrays)
      if (const auto* n = attribute(a.tag, "Name"); n && *n == *wanted) return a;
  return s.pointArrays.front();
}

}  // namespace

LoadedVolume loadVti(const fs::path& path, const LoadOptions& options) {
  const uint64_t fileBytes = fileSize(path);
  // Text before <AppendedData> is XML; read the first MiB, and the whole file only when the
  // data are inline (then the file is text anyway).
  std::string text;
  {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw FileError(path, "cannot open for reading");
    text.resize(static_cast<size_t>(std::min<uint64_t>(fileBytes, 1u << 20)));
    in.read(text.data(), static_cast<std::streamsize>(text.size()));
    text.resize(static_cast<size_t>(in.gcount()));
  }
  if (text.find("<VTKFile") == std::string::npos) throw FileError(path, "not a VTK XML image data file");
  const bool appendedInHead = text.find("<AppendedData") != std::string::npos;
  if (!appendedInHead && fileBytes > text.size()) {
    checkMemoryBudget(fileBytes, "file text");
    text = readSmallFile(path, fileBytes);
  }
  const VtiStructure s = parseStructure(path, text, 0);
  FileContext cx{path, fileBytes, encodingOf(path, s.file), &s, {}, false, options.progress};
  std::string appendedText;
  if (s.appended) {
    const std::string* enc = attribute(*s.appended, "encoding");
    if (enc && *enc == "base64") {
      cx.appendedBase64 = true;
      appendedText = std::string(text.substr(std::min<size_t>(text.size(), s.appendedBase)));
      if (fileBytes > text.size()) {
        checkMemoryBudget(fileBytes, "file text");
        appendedText = readSmallFile(path, fileBytes).substr(static_cast<size_t>(s.appendedBase));
      }
      cx.appendedText = appendedText;
    } else if (enc && *enc != "raw") {
      throw FileError(path, "unknown AppendedData encoding '" + *enc + "'");
    }
  }

  std::array<int64_t, 6> extent{};
  Geometry g = geometryOf(path, s, extent);
  checkAllocation(path, g.dims, 8);
  const std::string warning = normalizeDirection(g);
  checkGeometry(path, g);

  const ArrayElement& scalars = scalarArray(path, s);
  const std::string* typeName = attribute(scalars.tag, "type");
  if (!typeName) throw FileError(path, "DataArray without a type attribute");
  const auto type = sampleTypeOf(*typeName);
  if (!type) throw FileError(path, "unsupported DataArray type '" + *typeName + "'");
  if (const auto* comps = attribute(scalars.tag, "NumberOfComponents"); comps && trim(*comps) != "1")
    throw FileError(path, "array has " + *comps + " components (1 expected)");
  if (options.progress) options.progress->begin("reading " + path.filename().string(), 1);
  Endian order = Endian::Little;
  std::vector<uint8_t> data = arrayBytes(cx, scalars, *type, static_cast<uint64_t>(g.dims.voxelCount()) * sampleSize(*type), 0, order);
  if (options.progress) options.progress->end();

  std::string modality;
  for (const auto& a : s.fieldArrays)
    if (const auto* n = attribute(a.tag, "Name"); n && *n == "vellum_modality") {
      Endian ignored;
      const auto bytes = arrayBytes(cx, a, SampleType::UInt8, 0, 4096, ignored);
      modality = oneLine(std::string(bytes.begin(), std::find(bytes.begin(), bytes.end(), uint8_t{0})));
    }
  LoadedVolume out = makeLoaded(decodeVoxels(path, std::move(data), *type, order, g), "vti", modality);
  if (!warning.empty()) out.warnings.push_back(warning);
  return out;
}

}  // namespace vellum::io::detail
