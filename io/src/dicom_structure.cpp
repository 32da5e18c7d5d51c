// Structural pre-check of a DICOM file before GDCM sees it. GDCM as packaged aborts the
// process (assert) on many truncated or corrupt files, so every element header, length,
// sequence and item is walked here first; GDCM only reads files that pass.
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>

#include "dicom_internal.hpp"

namespace vellum::io::detail::dicom {

namespace {

constexpr uint32_t kUndefined = 0xffffffffu;
constexpr int kMaxDepth = 64;

struct Bad {
  std::string why;
};

/// Random access to the file through a small window (values are skipped, not read).
class Bytes {
 public:
  explicit Bytes(const fs::path& file) : in_(file, std::ios::binary) {
    std::error_code ec;
    size_ = fs::file_size(file, ec);
    if (ec || !in_) throw Bad{"cannot open"};
  }
  uint64_t size() const { return size_; }

  /// Copies n bytes at pos; false when the file ends first.
  bool get(uint64_t pos, size_t n, uint8_t* out) {
    if (pos + n > size_) return false;
    if (pos < start_ || pos + n > start_ + window_.size()) {
      window_.resize(static_cast<size_t>(std::min<uint64_t>(kWindow, size_ - pos)));
      in_.clear();
      in_.seekg(static_cast<std::streamoff>(pos));
      if (!in_.read(reinterpret_cast<char*>(window_.data()), static_cast<std::streamsize>(window_.size())))
        throw Bad{"read error"};
      start_ = pos;
    }
    std::memcpy(out, window_.data() + (pos - start_), n);
    return true;
  }

 private:
  static constexpr uint64_t kWindow = 64 * 1024;
  std::ifstream in_;
  uint64_t size_ = 0;
  uint64_t start_ = 0;
  std::vector<uint8_t> window_;
};

struct Syntax {
  bool explicitVr = true;
  bool bigEndian = false;
};

class Walker {
 public:
  explicit Walker(Bytes& b, std::string* seriesUid = nullptr) : b_(b), seriesUid_(seriesUid) {}

  uint16_t u16(const uint8_t* p, bool be) const {
    return be ? static_cast<uint16_t>(p[0] << 8 | p[1]) : static_cast<uint16_t>(p[1] << 8 | p[0]);
  }
  uint32_t u32(const uint8_t* p, bool be) const {
    return be ? (uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | p[3])
              : (uint32_t(p[3]) << 24 | uint32_t(p[2]) << 16 | uint32_t(p[1]) << 8 | p[0]);
  }

  /// One of the VRs of PS3.5 (GDCM aborts on unknown ones).
  static bool isVr(const uint8_t* p) {
    static const char* kAll[] = {"AE", "AS", "AT", "CS", "DA", "DS", "DT", "FL", "FD", "IS", "LO",
                                 "LT", "OB", "OD", "OF", "OL", "OV", "OW", "PN", "SH", "SL", "SQ",
                                 "SS", "ST", "SV", "TM", "UC", "UI", "UL", "UN", "UR", "US", "UT",
                                 "UV"};
    for (const char* v : kAll)
      if (p[0] == v[0] && p[1] == v[1]) return true;
    return false;
  }

  /// Elements whose VR GDCM relies on when it interprets them: the VR must match.
  static bool vrAllowed(uint16_t group, uint16_t elem, const uint8_t* vr) {
    struct Rule {
      uint16_t group, elem;
      const char* vrs;  // alternatives, e.g. "USSS"
    };
    static const Rule kRules[] = {
        {0x0002, 0x0000, "UL"}, {0x0002, 0x0001, "OB"}, {0x0002, 0x0002, "UI"},
        {0x0002, 0x0003, "UI"}, {0x0002, 0x0010, "UI"}, {0x0002, 0x0012, "UI"},
        {0x0002, 0x0013, "SH"}, {0x0008, 0x0016, "UI"}, {0x0008, 0x0018, "UI"},
        {0x0008, 0x0060, "CS"}, {0x0020, 0x000d, "UI"}, {0x0020, 0x000e, "UI"},
        {0x0020, 0x0013, "IS"}, {0x0020, 0x0032, "DS"}, {0x0020, 0x0037, "DS"},
        {0x0028, 0x0002, "US"}, {0x0028, 0x0004, "CS"}, {0x0028, 0x0006, "US"},
        {0x0028, 0x0008, "IS"}, {0x0028, 0x0010, "US"}, {0x0028, 0x0011, "US"},
        {0x0028, 0x0030, "DS"}, {0x0028, 0x0034, "IS"}, {0x0028, 0x0100, "US"},
        {0x0028, 0x0101, "US"}, {0x0028, 0x0102, "US"}, {0x0028, 0x0103, "US"},
        {0x0028, 0x0120, "USSS"}, {0x0028, 0x1050, "DS"}, {0x0028, 0x1051, "DS"},
        {0x0028, 0x1052, "DS"}, {0x0028, 0x1053, "DS"}, {0x0028, 0x1054, "LO"},
        {0x0018, 0x0050, "DS"}, {0x0018, 0x0088, "DS"}, {0x7fe0, 0x0010, "OBOW"},
        {0x5200, 0x9229, "SQ"}, {0x5200, 0x9230, "SQ"}, {0x0020, 0x9113, "SQ"},
        {0x0020, 0x9116, "SQ"}, {0x0028, 0x9110, "SQ"}, {0x0028, 0x9145, "SQ"},
        {0x0028, 0x1101, "USSS"}, {0x0028, 0x1102, "USSS"}, {0x0028, 0x1103, "USSS"},
        {0x0028, 0x3002, "USSS"}, {0x0028, 0x3010, "SQ"}};
    for (const Rule& r : kRules) {
      if (r.group != group || r.elem != elem) continue;
      for (const char* v = r.vrs; *v; v += 2)
        if (vr[0] == v[0] && vr[1] == v[1]) return true;
      return false;
    }
    return true;
  }
  static bool longVr(const uint8_t* p) {
    static const char* kLong[] = {"OB", "OD", "OF", "OL", "OV", "OW", "SQ", "SV", "UC", "UN", "UR", "UT", "UV"};
    for (const char* v : kLong)
      if (p[0] == v[0] && p[1] == v[1]) return true;
    return false;
  }

  /// Walks elements from pos until `end` (defined length) or an item delimiter (end == 0).
  /// Returns the position after the data set (after the delimiter when undelimited).
  uint64_t dataset(uint64_t pos, uint64_t end, Syntax sx, int depth) {
    if (depth > kMaxDepth) throw Bad{"sequences nested too deeply"};
    for (;;) {
      if (end != 0 && pos == end) return pos;
      if (end == 0 && pos >= b_.size()) throw Bad{"truncated inside a sequence item"};
      if (end != 0 && pos > end) throw Bad{"element overruns its sequence item"};
      uint8_t h[12];
      if (!b_.get(pos, 8, h)) throw Bad{"truncated element header at byte " + std::to_string(pos)};
      const uint16_t group = u16(h, sx.bigEndian), elem = u16(h + 2, sx.bigEndian);
      if (group == 0xfffe) {  // delimiters carry no VR
        const uint32_t len = u32(h + 4, sx.bigEndian);
        if (elem == 0xe00d && end == 0) return pos + 8;
        (void)len;
        throw Bad{"unexpected delimiter at byte " + std::to_string(pos)};
      }
      const uint64_t start = pos;
      pos = element(pos, h, sx, depth);
      if (depth == 0 && seriesUid_ && group == 0x0020 && elem == 0x000e && pos - start <= 8 + 64) {
        // Remember the series, so damage further on can be attributed to it.
        char uid[72] = {};
        b_.get(start + 8, static_cast<size_t>(pos - start - 8), reinterpret_cast<uint8_t*>(uid));
        *seriesUid_ = uid;
        while (!seriesUid_->empty() && (seriesUid_->back() == '\0' || seriesUid_->back() == ' '))
          seriesUid_->pop_back();
      }
    }
  }

  /// One element starting at pos (header bytes already in h[0..8)); returns the next position.
  uint64_t element(uint64_t pos, uint8_t* h, Syntax sx, int depth) {
    uint32_t len;
    uint64_t value;
    bool sq = false, un = false;
    if (sx.explicitVr) {
      if (!isVr(h + 4)) throw Bad{"invalid VR at byte " + std::to_string(pos)};
      if (!vrAllowed(u16(h, sx.bigEndian), u16(h + 2, sx.bigEndian), h + 4))
        throw Bad{"element (" + hex(u16(h, sx.bigEndian)) + "," + hex(u16(h + 2, sx.bigEndian)) +
                  ") has the wrong VR " + std::string(reinterpret_cast<const char*>(h + 4), 2)};
      if (longVr(h + 4)) {
        if (!b_.get(pos + 8, 4, h + 8)) throw Bad{"truncated element header at byte " + std::to_string(pos)};
        len = u32(h + 8, sx.bigEndian);
        value = pos + 12;
        sq = h[4] == 'S' && h[5] == 'Q';
        un = h[4] == 'U' && h[5] == 'N';
      } else {
        len = u16(h + 6, sx.bigEndian);
        value = pos + 8;
      }
    } else {
      len = u32(h + 4, sx.bigEndian);
      value = pos + 8;
    }
    const uint16_t group = u16(h, sx.bigEndian), elem = u16(h + 2, sx.bigEndian);
    const bool pixelData = group == 0x7fe0 && elem == 0x0010;
    if (len == kUndefined) {
      // Only sequences (SQ, UN, or any in implicit VR) and encapsulated pixel data may have
      // an undefined length; their items run to a delimiter.
      if (sx.explicitVr && !sq && !un && !pixelData)
        throw Bad{"element (" + hex(group) + "," + hex(elem) + ") has an undefined length"};
      Syntax inner = sx;
      if (un) inner = Syntax{false, false};  // UN of undefined length holds implicit VR LE
      return items(value, 0, inner, depth + 1, pixelData);
    }
    const uint64_t next = value + len;
    if (next > b_.size())
      throw Bad{"truncated: element (" + hex(group) + "," + hex(elem) + ") needs " +
                std::to_string(len) + " bytes at byte " + std::to_string(value) +
                ", file has " + std::to_string(b_.size())};
    // A defined-length sequence: explicit SQ, or (implicit VR) a value that starts with an
    // item tag, as GDCM would read it.
    bool looksLikeItems = sq;
    if (!sx.explicitVr && len >= 8 && !pixelData) {
      uint8_t first[4];
      looksLikeItems = b_.get(value, 4, first) && u16(first, sx.bigEndian) == 0xfffe &&
                       u16(first + 2, sx.bigEndian) == 0xe000;
    }
    if (looksLikeItems && len > 0) items(value, next, sx, depth + 1, false);
    return next;
  }

  /// Items of a sequence from pos, until `end` or a sequence delimiter (end == 0).
  /// `fragments`: encapsulated pixel data, whose items are opaque compressed bytes.
  uint64_t items(uint64_t pos, uint64_t end, Syntax sx, int depth, bool fragments) {
    if (depth > kMaxDepth) throw Bad{"sequences nested too deeply"};
    for (;;) {
      if (end != 0 && pos == end) return pos;
      uint8_t h[8];
      if (!b_.get(pos, 8, h)) throw Bad{"truncated inside a sequence at byte " + std::to_string(pos)};
      const uint16_t group = u16(h, sx.bigEndian), elem = u16(h + 2, sx.bigEndian);
      const uint32_t len = u32(h + 4, sx.bigEndian);
      if (group != 0xfffe) throw Bad{"corrupt sequence at byte " + std::to_string(pos)};
      if (elem == 0xe0dd) {
        if (end != 0) throw Bad{"sequence delimiter in a sequence of defined length"};
        return pos + 8;
      }
      if (elem != 0xe000) throw Bad{"corrupt sequence item at byte " + std::to_string(pos)};
      if (len == kUndefined) {
        if (fragments) throw Bad{"pixel data fragment of undefined length"};
        pos = dataset(pos + 8, 0, sx, depth + 1);
      } else {
        const uint64_t next = pos + 8 + len;
        if (next > b_.size() || (end != 0 && next > end))
          throw Bad{"truncated sequence item at byte " + std::to_string(pos)};
        if (!fragments && len > 0) dataset(pos + 8, next, sx, depth + 1);
        pos = next;
      }
    }
  }

  static std::string hex(uint16_t v) {
    char buf[8];
    std::snprintf(buf, sizeof buf, "%04x", v);
    return buf;
  }

 private:
  Bytes& b_;
  std::string* seriesUid_;
};

}  // namespace

StructureCheck checkStructure(const fs::path& file) {
  StructureCheck r;
  bool magic = false;
  try {
    Bytes b(file);
    Walker w(b, &r.seriesUid);
    uint64_t pos = 0;
    uint8_t h[12];
    if (b.size() >= 132 && b.get(128, 4, h) && std::memcmp(h, "DICM", 4) == 0) {
      magic = true;
      r.dicomLike = true;
      pos = 132;
    }
    // File meta information: group 0002, always explicit VR little endian.
    std::string transferSyntax;
    bool meta = false;
    while (b.get(pos, 8, h) && w.u16(h, false) == 0x0002) {
      meta = true;
      r.dicomLike = true;
      const uint16_t elem = w.u16(h + 2, false);
      const uint64_t next = w.element(pos, h, Syntax{}, 0);
      if (elem == 0x0010 && next - pos <= 8 + 64) {
        char ts[72] = {};
        b.get(pos + 8, static_cast<size_t>(next - pos - 8), reinterpret_cast<uint8_t*>(ts));
        transferSyntax = ts;
        while (!transferSyntax.empty() && (transferSyntax.back() == '\0' || transferSyntax.back() == ' '))
          transferSyntax.pop_back();
      }
      pos = next;
    }
    r.dicomLike = magic || meta;
    // A DICM prefix promises the file meta group; without it GDCM guesses the encoding and can
    // read a length from the wrong bytes (a DICOM fuzzer input made it allocate 1.4 GB).
    if (magic && !meta) throw Bad{"the DICM prefix is not followed by file meta information (group 0002)"};
    if (!r.dicomLike) {
      // No preamble and no meta: accept only a data set that starts like one (groups 0008..).
      if (!b.get(pos, 8, h)) throw Bad{"too short for DICOM"};
      const uint16_t group = w.u16(h, false);
      if (group < 0x0008 || group > 0x0010) throw Bad{"no DICOM preamble or header"};
    }
    Syntax sx;
    if (transferSyntax == "1.2.840.10008.1.2") sx.explicitVr = false;
    else if (transferSyntax == "1.2.840.10008.1.2.2") sx.bigEndian = true;
    else if (transferSyntax == "1.2.840.10008.1.2.1.99") {  // deflated: cannot walk; trust GDCM
      r.ok = true;
      return r;
    } else if (transferSyntax.empty()) {
      if (!b.get(pos, 8, h)) throw Bad{"no data set"};
      sx.explicitVr = Walker::isVr(h + 4);
    }
    if (pos >= b.size()) throw Bad{"no data set after the file meta information"};
    w.dataset(pos, b.size(), sx, 0);
    r.ok = true;
  } catch (const Bad& bad) {
    r.problem = bad.why;
  } catch (const std::exception& e) {
    r.problem = e.what();
  }
  return r;
}

}  // namespace vellum::io::detail::dicom
