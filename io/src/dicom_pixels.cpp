// Decoding the pixels of one DICOM file through GDCM (every transfer syntax GDCM supports:
// uncompressed, RLE, JPEG baseline/lossless, JPEG-LS, JPEG 2000) and applying the rescale.
#include <gdcmImage.h>
#include <gdcmImageReader.h>
#include <gdcmPixelFormat.h>
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

template <class T>
int64_t rescaleFrame(const char* src, int64_t count, double slope, double intercept, int16_t* dst) {
  int64_t saturated = 0;
  const bool identity = slope == 1.0 && intercept == std::round(intercept);
  for (int64_t i = 0; i < count; ++i) {
    T raw;
    std::memcpy(&raw, src + i * static_cast<int64_t>(sizeof(T)), sizeof(T));
    double v = identity ? static_cast<double>(raw) + intercept
                        : std::round(static_cast<double>(raw) * slope + intercept);
    if (v < -32768.0 || v > 32767.0 || std::isnan(v)) {
      ++saturated;
      v = std::isnan(v) ? 0.0 : std::clamp(v, -32768.0, 32767.0);
    }
    dst[i] = static_cast<int16_t>(v);
  }
  return saturated;
}

}  // namespace

int64_t decodeFile(const fs::path& file, int64_t rows, int64_t columns, int64_t frames,
                   const std::vector<double>& slopes, const std::vector<double>& intercepts,
                   const std::function<void(int64_t frame, const int16_t* values)>& sink) {
  quietGdcm();
  gdcm::ImageReader reader;
  reader.SetFileName(file.string().c_str());
  bool ok = false;
  try {
    ok = reader.Read();
  } catch (const std::exception& e) {
    throw FileError(file, std::string("cannot read DICOM image: ") + e.what());
  }
  if (!ok)
    throw FileError(file, "cannot read DICOM image (missing pixel data, truncated file or "
                          "unsupported encoding)");
  const gdcm::Image& image = reader.GetImage();
  const unsigned int* dims = image.GetDimensions();
  const int64_t fileFrames = image.GetNumberOfDimensions() > 2 ? dims[2] : 1;
  if (dims[0] != columns || dims[1] != rows || fileFrames != frames)
    throw FileError(file, "pixel data is " + std::to_string(dims[0]) + "x" +
                              std::to_string(dims[1]) + "x" + std::to_string(fileFrames) +
                              " but the header says " + std::to_string(columns) + "x" +
                              std::to_string(rows) + "x" + std::to_string(frames));
  const gdcm::PixelFormat pf = image.GetPixelFormat();
  if (pf.GetSamplesPerPixel() != 1)
    throw FileError(file, "colour images (" + std::to_string(pf.GetSamplesPerPixel()) +
                              " samples per pixel) are not supported");
  const uint64_t pixelBytes = pf.GetPixelSize();
  const uint64_t plane = static_cast<uint64_t>(rows * columns);
  const uint64_t expected = plane * static_cast<uint64_t>(frames) * pixelBytes;
  const uint64_t length = image.GetBufferLength();
  if (length != expected || pixelBytes == 0)
    throw FileError(file, "unsupported pixel format (" + std::to_string(pf.GetBitsAllocated()) +
                              " bits allocated)");

  // Uncompressed pixel data shorter than the image: the file is truncated.
  const gdcm::DataElement& pixelData = image.GetDataElement();
  if (pixelData.IsEmpty())
    throw FileError(file, "no pixel data");
  if (!image.GetTransferSyntax().IsEncapsulated()) {
    const gdcm::ByteValue* bv = pixelData.GetByteValue();
    if (!bv || bv->GetLength() < expected)
      throw FileError(file, "truncated pixel data: " +
                                std::to_string(bv ? static_cast<uint64_t>(bv->GetLength()) : uint64_t{0}) + " of " +
                                std::to_string(expected) + " bytes");
  }

  checkMemoryBudget(length, "decoded pixel data of " + file.string());
  std::vector<char> buffer(length);
  if (!image.GetBuffer(buffer.data()))
    throw FileError(file, std::string("cannot decode pixel data (transfer syntax ") +
                              image.GetTransferSyntax().GetString() + ")");

  std::vector<int16_t> values(plane);
  int64_t saturated = 0;
  for (int64_t f = 0; f < frames; ++f) {
    const char* src = buffer.data() + static_cast<uint64_t>(f) * plane * pixelBytes;
    const double slope = slopes[static_cast<size_t>(f)], intercept = intercepts[static_cast<size_t>(f)];
    const auto n = static_cast<int64_t>(plane);
    switch (pf.GetScalarType()) {
      case gdcm::PixelFormat::UINT8: saturated += rescaleFrame<uint8_t>(src, n, slope, intercept, values.data()); break;
      case gdcm::PixelFormat::INT8: saturated += rescaleFrame<int8_t>(src, n, slope, intercept, values.data()); break;
      case gdcm::PixelFormat::UINT16: saturated += rescaleFrame<uint16_t>(src, n, slope, intercept, values.data()); break;
      case gdcm::PixelFormat::INT16: saturated += rescaleFrame<int16_t>(src, n, slope, intercept, values.data()); break;
      case gdcm::PixelFormat::UINT32: saturated += rescaleFrame<uint32_t>(src, n, slope, intercept, values.data()); break;
      case gdcm::PixelFormat::INT32: saturated += rescaleFrame<int32_t>(src, n, slope, intercept, values.data()); break;
      case gdcm::PixelFormat::FLOAT32: saturated += rescaleFrame<float>(src, n, slope, intercept, values.data()); break;
      case gdcm::PixelFormat::FLOAT64: saturated += rescaleFrame<double>(src, n, slope, intercept, values.data()); break;
      default:
        throw FileError(file, std::string("unsupported pixel type ") + pf.GetScalarTypeAsString());
    }
    sink(f, values.data());
  }
  return saturated;
}

}  // namespace vellum::io::detail::dicom
