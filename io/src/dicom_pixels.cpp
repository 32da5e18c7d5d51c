// Decoding the pixels of one DICOM file through GDCM (every transfer syntax GDCM supports:
// uncompressed, RLE, JPEG baseline/lossless, JPEG-LS, JPEG 2000) and applying the rescale.
// The image description (size, pixel format) comes from our own validated header, not from
// gdcm::ImageReader, whose attribute parsing aborts the process on some invalid values.
#include <gdcmImage.h>
#include <gdcmPhotometricInterpretation.h>
#include <gdcmPixelFormat.h>
#include <gdcmReader.h>
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

}  // namespace

int64_t decodeFile(const FileHeader& h,
                   const std::function<void(int64_t frame, const int16_t* values)>& sink) {
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

  gdcm::Image image;
  image.SetNumberOfDimensions(h.frameCount > 1 ? 3 : 2);
  image.SetDimension(0, static_cast<unsigned int>(h.columns));
  image.SetDimension(1, static_cast<unsigned int>(h.rows));
  if (h.frameCount > 1) image.SetDimension(2, static_cast<unsigned int>(h.frameCount));
  image.SetPixelFormat(gdcm::PixelFormat(1, static_cast<unsigned short>(h.bitsAllocated),
                                         static_cast<unsigned short>(h.bitsStored),
                                         // GDCM insists on HighBit = BitsStored - 1; any
                                         // other layout is shifted below (BitField).
                                         static_cast<unsigned short>(h.bitsStored - 1),
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

  // Codecs may report the stream's own pixel format (e.g. 16 bits stored where the header
  // says 14); the header's bit field is applied either way.
  BitField field;
  field.bits = h.bitsStored;
  field.shift = h.highBit + 1 - h.bitsStored;
  field.isSigned = h.signedPixels;
  std::vector<int16_t> values(plane);
  int64_t saturated = 0;
  const auto n = static_cast<int64_t>(plane);
  for (int64_t f = 0; f < h.frameCount; ++f) {
    const char* src = buffer.data() + static_cast<uint64_t>(f) * plane * bytesPerSample;
    const Frame& fr = h.frames[static_cast<size_t>(f)];
    const double s = fr.slope, b = fr.intercept;
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

}  // namespace vellum::io::detail::dicom
