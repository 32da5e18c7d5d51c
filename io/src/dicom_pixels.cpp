// Decoding the pixels of one DICOM file through GDCM (every transfer syntax GDCM supports:
// uncompressed, RLE, JPEG baseline/lossless, JPEG-LS, JPEG 2000) and applying the rescale.
// The image description (size, pixel format) comes from our own validated header, not from
// gdcm::ImageReader, whose attribute parsing aborts the process on some invalid values.
#include <gdcmImage.h>
#include <gdcmPhotometricInterpretation.h>
#include <gdcmPixelFormat.h>
#include <gdcmReader.h>
#include <gdcmSequenceOfFragments.h>
#include <gdcmTransferSyntax.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "dicom_gdcm.hpp"
#include "dicom_internal.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/memory_budget.hpp"

namespace vellum::io::detail::dicom {

namespace {

/// Stored sample -> integer value: keeps the BitsStored bits below HighBit and sign-extends
/// them for signed data (bits above are unused or overlay bits).
struct BitField {
  int shift = 0;
  int bits = 16;
  bool isSigned = false;
  int64_t operator()(int64_t raw) const {
    const uint64_t mask = bits >= 64 ? ~uint64_t{0} : ((uint64_t{1} << bits) - 1);
    uint64_t v = (static_cast<uint64_t>(raw) >> shift) & mask;
    if (isSigned && bits < 64 && (v >> (bits - 1)) & 1) v |= ~mask;
    return static_cast<int64_t>(v);
  }
};

template <class T>
int64_t rescaleFrame(const char* src, int64_t count, const BitField& field, double slope,
                     double intercept, int16_t* dst) {
  int64_t saturated = 0;
  const bool integral = slope == 1.0 && intercept == std::round(intercept);
  const bool fullWidth = field.shift == 0 && field.bits == static_cast<int>(8 * sizeof(T));
  for (int64_t i = 0; i < count; ++i) {
    T raw;
    std::memcpy(&raw, src + i * static_cast<int64_t>(sizeof(T)), sizeof(T));
    const double stored = fullWidth ? static_cast<double>(raw)
                                    : static_cast<double>(field(static_cast<int64_t>(raw)));
    double v = integral ? stored + intercept : std::round(stored * slope + intercept);
    if (!(v >= -32768.0 && v <= 32767.0)) {
      ++saturated;
      v = std::isnan(v) ? 0.0 : std::clamp(v, -32768.0, 32767.0);
    }
    dst[i] = static_cast<int16_t>(v);
  }
  return saturated;
}

uint32_t be32(const uint8_t* p) {
  return uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | p[3];
}
uint16_t be16(const uint8_t* p) { return static_cast<uint16_t>(p[0] << 8 | p[1]); }

/// Checks the SIZ marker of every JPEG 2000 codestream fragment against the image size: GDCM's
/// JPEG 2000 codec crashes (instead of failing) on some inconsistent headers. Returns the
/// problem, "" when fine.
std::string checkJpeg2000(const gdcm::DataElement& pixelData, int64_t rows, int64_t columns) {
  const gdcm::SequenceOfFragments* fragments = pixelData.GetSequenceOfFragments();
  if (!fragments || fragments->GetNumberOfFragments() == 0) return "no compressed fragments";
  int streams = 0;
  for (size_t i = 0; i < fragments->GetNumberOfFragments(); ++i) {
    const gdcm::ByteValue* bv = fragments->GetFragment(static_cast<unsigned int>(i)).GetByteValue();
    if (!bv || bv->GetLength() < 4) continue;
    const auto* p = reinterpret_cast<const uint8_t*>(bv->GetPointer());
    const size_t n = bv->GetLength();
    // A raw codestream starts with SOC; a JP2 file wraps one a little further in.
    size_t soc = n;
    for (size_t k = 0; k + 4 <= std::min<size_t>(n, 4096); ++k)
      if (p[k] == 0xff && p[k + 1] == 0x4f && p[k + 2] == 0xff && p[k + 3] == 0x51) {
        soc = k;
        break;
      }
    if (soc == n) continue;  // a continuation fragment
    ++streams;
    const uint8_t* siz = p + soc + 4;
    if (soc + 4 + 38 > n) return "JPEG 2000 header truncated";
    const uint16_t lsiz = be16(siz), csiz = be16(siz + 36);
    const uint32_t xsiz = be32(siz + 4), ysiz = be32(siz + 8), xo = be32(siz + 12), yo = be32(siz + 16);
    const uint32_t xt = be32(siz + 20), yt = be32(siz + 24), xto = be32(siz + 28), yto = be32(siz + 32);
    if (csiz != 1 || lsiz != 38 + 3 * csiz || soc + 4 + lsiz > n)
      return "JPEG 2000 header: " + std::to_string(csiz) + " components (greyscale expected)";
    const uint8_t ssiz = siz[38], xr = siz[39], yr = siz[40];
    if (xsiz <= xo || ysiz <= yo || xsiz - xo != columns || ysiz - yo != rows)
      return "JPEG 2000 image size does not match Rows/Columns";
    if (xt == 0 || yt == 0 || xto > xo || yto > yo || xr == 0 || yr == 0 || (ssiz & 0x7f) + 1 > 32)
      return "invalid JPEG 2000 header";
    const uint64_t tiles = ((uint64_t{xsiz} - xto + xt - 1) / xt) * ((uint64_t{ysiz} - yto + yt - 1) / yt);
    if (tiles > 65535) return "invalid JPEG 2000 tiling";
  }
  return streams > 0 ? "" : "no JPEG 2000 codestream";
}

/// The pixel data of all frames as stored samples (uncompressed: whole words, their bits
/// extracted later; compressed: decoded by the codec), `expected` bytes.
std::vector<char> decodePixels(const FileHeader& h, const gdcm::DataElement& pixelData,
                               const gdcm::TransferSyntax& ts, uint64_t expected) {
  const fs::path& file = h.file;
  gdcm::Image image;
  image.SetNumberOfDimensions(h.frameCount > 1 ? 3 : 2);
  image.SetDimension(0, static_cast<unsigned int>(h.columns));
  image.SetDimension(1, static_cast<unsigned int>(h.rows));
  if (h.frameCount > 1) image.SetDimension(2, static_cast<unsigned int>(h.frameCount));
  // Uncompressed: GDCM gets the full word (it would mask to BitsStored assuming HighBit =
  // BitsStored - 1) and rescaleFrames extracts the stored bits. Compressed: the codec
  // returns the values themselves.
  const bool encapsulated = ts.IsEncapsulated();
  const auto ba = static_cast<unsigned short>(h.bitsAllocated);
  const auto bs = static_cast<unsigned short>(encapsulated ? h.bitsStored : h.bitsAllocated);
  image.SetPixelFormat(gdcm::PixelFormat(1, ba, bs, static_cast<unsigned short>(bs - 1),
                                         h.signedPixels ? 1 : 0));
  image.SetPhotometricInterpretation(h.monochrome1 ? gdcm::PhotometricInterpretation::MONOCHROME1
                                                   : gdcm::PhotometricInterpretation::MONOCHROME2);
  image.SetTransferSyntax(ts);
  image.SetDataElement(pixelData);
  if (image.GetBufferLength() != expected)
    throw FileError(file, "unsupported pixel layout");

  try {
    checkMemoryBudget(expected, "decoded pixel data");
  } catch (const FileError&) {
    throw;
  } catch (const Error& e) {
    throw FileError(file, e.what());
  }
  std::vector<char> buffer(expected);
  bool decoded = false;
  try {
    decoded = image.GetBuffer(buffer.data());
  } catch (const std::exception& e) {
    throw FileError(file, std::string("cannot decode pixel data: ") + e.what());
  }
  if (!decoded)
    throw FileError(file, std::string("cannot decode pixel data (transfer syntax ") +
                              ts.GetString() + ")");

  return buffer;
}

/// Real values per frame (stored bits extracted, rescale slope and intercept, rounded and
/// saturated to int16) to `sink`; returns how many values saturated.
int64_t rescaleFrames(const FileHeader& h, const std::vector<char>& buffer, bool encapsulated,
                      const std::function<void(int64_t frame, const int16_t* values)>& sink, bool storedValues) {
  const fs::path& file = h.file;
  const int bytesPerSample = h.bitsAllocated / 8;
  const uint64_t plane = static_cast<uint64_t>(h.rows * h.columns);
  BitField field;
  field.bits = encapsulated ? h.bitsAllocated : h.bitsStored;
  field.shift = encapsulated ? 0 : h.highBit + 1 - h.bitsStored;
  field.isSigned = h.signedPixels;
  std::vector<int16_t> values(plane);
  int64_t saturated = 0;
  const auto n = static_cast<int64_t>(plane);
  for (int64_t f = 0; f < h.frameCount; ++f) {
    const char* src = buffer.data() + static_cast<uint64_t>(f) * plane * bytesPerSample;
    const Frame& fr = h.frames[static_cast<size_t>(f)];
    const double s = storedValues ? 1.0 : fr.slope, b = storedValues ? 0.0 : fr.intercept;
    switch (h.bitsAllocated) {
      case 8:
        saturated += h.signedPixels ? rescaleFrame<int8_t>(src, n, field, s, b, values.data())
                                    : rescaleFrame<uint8_t>(src, n, field, s, b, values.data());
        break;
      case 16:
        saturated += h.signedPixels ? rescaleFrame<int16_t>(src, n, field, s, b, values.data())
                                    : rescaleFrame<uint16_t>(src, n, field, s, b, values.data());
        break;
      case 32:
        saturated += h.signedPixels ? rescaleFrame<int32_t>(src, n, field, s, b, values.data())
                                    : rescaleFrame<uint32_t>(src, n, field, s, b, values.data());
        break;
      default: throw FileError(file, "unsupported BitsAllocated " + std::to_string(h.bitsAllocated));
    }
    sink(f, values.data());
  }
  return saturated;
}

}  // namespace

int64_t decodeFile(const FileHeader& h,
                   const std::function<void(int64_t frame, const int16_t* values)>& sink, bool storedValues) {
  quietGdcm();
  const fs::path& file = h.file;
  gdcm::Reader reader;
  reader.SetFileName(file.string().c_str());
  bool ok = false;
  try {
    ok = reader.Read();
  } catch (const std::exception& e) {
    throw FileError(file, std::string("cannot read DICOM file: ") + e.what());
  }
  if (!ok) throw FileError(file, "cannot read DICOM file (truncated or corrupt)");
  const gdcm::DataSet& ds = reader.GetFile().GetDataSet();
  const gdcm::Tag pixelTag(0x7fe0, 0x0010);
  if (!ds.FindDataElement(pixelTag) || ds.GetDataElement(pixelTag).IsEmpty())
    throw FileError(file, "no pixel data");
  const gdcm::DataElement& pixelData = ds.GetDataElement(pixelTag);
  const gdcm::TransferSyntax ts = reader.GetFile().GetHeader().GetDataSetTransferSyntax();

  const int bytesPerSample = h.bitsAllocated / 8;
  const uint64_t plane = static_cast<uint64_t>(h.rows * h.columns);
  const uint64_t expected = plane * static_cast<uint64_t>(h.frameCount) * bytesPerSample;
  if (!ts.IsEncapsulated()) {
    const gdcm::ByteValue* bv = pixelData.GetByteValue();
    if (!bv || bv->GetLength() < expected)
      throw FileError(file, "pixel data holds " +
                                std::to_string(bv ? static_cast<uint64_t>(bv->GetLength()) : uint64_t{0}) +
                                " bytes; " + std::to_string(h.columns) + "x" +
                                std::to_string(h.rows) + "x" + std::to_string(h.frameCount) +
                                " pixels need " + std::to_string(expected));
  }

  if (ts == gdcm::TransferSyntax::JPEG2000Lossless || ts == gdcm::TransferSyntax::JPEG2000 ||
      ts == gdcm::TransferSyntax::JPEG2000Part2Lossless || ts == gdcm::TransferSyntax::JPEG2000Part2)
    if (std::string why = checkJpeg2000(pixelData, h.rows, h.columns); !why.empty())
      throw FileError(file, why);

  const std::vector<char> buffer = decodePixels(h, pixelData, ts, expected);
  return rescaleFrames(h, buffer, ts.IsEncapsulated(), sink, storedValues);
}

}  // namespace vellum::io::detail::dicom
