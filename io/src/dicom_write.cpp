// saveDicomSeries: one CT Image Storage file per slice (Secondary Capture for non-CT
// modalities), explicit VR little endian, signed 16-bit pixels with a rescale that keeps the
// values: int16/uint8 are stored as they are (slope 1, intercept 0); uint16 above 32767 is
// stored shifted (slope 1, intercept 32768, exact); float is stored exactly when every value
// is an integer in the int16 range, else with slope = range/65534 and intercept = mid-range
// (precision: half a slope step). The folder appears atomically (io::writeAtomically).
#include <gdcmDataElement.h>
#include <gdcmDataSet.h>
#include <gdcmFile.h>
#include <gdcmTransferSyntax.h>
#include <gdcmUIDGenerator.h>
#include <gdcmWriter.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <limits>
#include <sstream>
#include <tuple>
#include <type_traits>

#include "dicom.hpp"
#include "dicom_gdcm.hpp"
#include "dicom_internal.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"
#include "io_detail.hpp"
#include "vellum/io/output_policy.hpp"

namespace vellum::io::detail {

namespace {

constexpr const char* kCtImageStorage = "1.2.840.10008.5.1.4.1.1.2";
constexpr const char* kSecondaryCapture = "1.2.840.10008.5.1.4.1.1.7";

/// Shortest-faithful decimal string of at most 16 characters (the DS limit).
std::string formatDS(double v) {
  if (v == 0 || std::abs(v) < 1e-300) return "0";
  char buf[64];
  for (int precision = 16; precision >= 1; --precision) {
    std::snprintf(buf, sizeof buf, "%.*g", precision, v);
    if (std::strlen(buf) <= 16) return buf;
  }
  return "0";
}

double parseDS(const std::string& s) {
  double v = 0;
  std::from_chars(s.data(), s.data() + s.size(), v);
  return v;
}

/// Printable ASCII only, at most `maxLen` characters, no backslash (the value separator).
std::string cleanText(const std::string& s, size_t maxLen) {
  std::string out;
  for (char c : s)
    if (c >= 32 && c < 127 && c != '\\') out.push_back(c);
  if (out.size() > maxLen) out.resize(maxLen);
  return out;
}

void put(gdcm::DataSet& ds, uint16_t group, uint16_t element, gdcm::VR vr, std::string value) {
  if (value.size() % 2) value.push_back(vr == gdcm::VR::UI ? '\0' : ' ');
  gdcm::DataElement de(gdcm::Tag(group, element));
  de.SetVR(vr);
  de.SetByteValue(value.data(), static_cast<uint32_t>(value.size()));
  ds.Replace(de);
}

void putUS(gdcm::DataSet& ds, uint16_t group, uint16_t element, uint16_t v) {
  const char bytes[2] = {static_cast<char>(v & 0xff), static_cast<char>(v >> 8)};
  gdcm::DataElement de(gdcm::Tag(group, element));
  de.SetVR(gdcm::VR::US);
  de.SetByteValue(bytes, 2);
  ds.Replace(de);
}

std::string join(std::initializer_list<double> values) {
  std::string s;
  for (double v : values) {
    if (!s.empty()) s += '\\';
    s += formatDS(v);
  }
  return s;
}

/// Stored = round((value - intercept) / slope), saturated to int16.
struct Encoding {
  double slope = 1, intercept = 0;
  bool exact = true;  ///< integers stored unchanged up to the intercept shift
};

template <class T>
Encoding chooseEncoding(const Volume<T>& v) {
  Encoding e;
  if constexpr (std::is_same_v<T, int16_t> || std::is_same_v<T, uint8_t>) {
    return e;
  } else {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    bool integral = true;
    for (T x : v.voxels()) {
      const double d = static_cast<double>(x);
      if (!std::isfinite(d)) continue;
      lo = std::min(lo, d);
      hi = std::max(hi, d);
      if (d != std::round(d)) integral = false;
    }
    if (!(lo <= hi)) return e;  // empty or all NaN
    if (integral && lo >= -32768 && hi <= 32767) return e;
    if (integral && hi - lo <= 65535) {
      // Shift into int16 with slope 1: still exact.
      e.intercept = std::floor(lo) + 32768;
      return e;
    }
    e.exact = false;
    // Slope and intercept as they will read back from their DS text, so stored values decode
    // consistently.
    e.intercept = parseDS(formatDS(0.5 * (lo + hi)));
    e.slope = parseDS(formatDS(hi > lo ? (hi - lo) / 65534.0 : 1.0));
    if (!(e.slope > 0)) e.slope = 1;
    return e;
  }
}

template <class T>
void encodeSlice(const Volume<T>& v, int64_t k, const Encoding& e, int16_t* dst) {
  const int64_t plane = v.dims().x * v.dims().y;
  const T* src = v.data() + k * plane;
  for (int64_t i = 0; i < plane; ++i) {
    double d = static_cast<double>(src[i]);
    if (!std::isfinite(d)) d = v.background();
    const double s = std::round((d - e.intercept) / e.slope);
    dst[i] = static_cast<int16_t>(std::clamp(s, -32768.0, 32767.0));
  }
}

/// The UTC time `t` formatted with strftime `format` ("%Y%m%d" for DA, "%H%M%S" for TM).
std::string formatUtc(std::time_t t, const char* format) {
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, format, &tm);
  return buf;
}

/// What every slice of one series shares.
struct SeriesTags {
  std::string modality, description, studyUid, seriesUid, frameUid, date, time;
  bool ct = false;
  Encoding enc;
  double lo = 0, hi = 0;  ///< value range in real units (the display window)
  Vec3 row, col, axis, normal;
  std::vector<std::string> sopUids;  ///< per slice
};

/// The header of slice k: SOP common, patient, study, series, equipment, frame of reference,
/// image plane and the image pixel module (signed 16-bit monochrome).
void fillSliceHeader(gdcm::DataSet& ds, const SeriesTags& s, const Geometry& g, int64_t k) {
  const Vec3 ipp = g.origin + s.axis * (static_cast<double>(k) * g.spacing.z);
  using gdcm::VR;
  // SOP common, patient, study, series, equipment, frame of reference.
  put(ds, 0x0008, 0x0008, VR::CS, "DERIVED\\SECONDARY\\AXIAL");
  put(ds, 0x0008, 0x0016, VR::UI, s.ct ? kCtImageStorage : kSecondaryCapture);
  put(ds, 0x0008, 0x0018, VR::UI, s.sopUids[static_cast<size_t>(k)]);
  put(ds, 0x0008, 0x0020, VR::DA, s.date);
  put(ds, 0x0008, 0x0030, VR::TM, s.time);
  put(ds, 0x0008, 0x0050, VR::SH, "");
  put(ds, 0x0008, 0x0060, VR::CS, s.modality);
  if (!s.ct) put(ds, 0x0008, 0x0064, VR::CS, "WSD");  // SC conversion type
  put(ds, 0x0008, 0x0070, VR::LO, "Vellum");
  put(ds, 0x0008, 0x0090, VR::PN, "");
  put(ds, 0x0008, 0x103e, VR::LO, s.description);
  put(ds, 0x0010, 0x0010, VR::PN, "Vellum^Phantom");
  put(ds, 0x0010, 0x0020, VR::LO, "VELLUM");
  put(ds, 0x0010, 0x0030, VR::DA, "");
  put(ds, 0x0010, 0x0040, VR::CS, "O");
  if (s.ct) put(ds, 0x0018, 0x0060, VR::DS, "");  // KVP (type 2)
  // Patient Position (type 2C for CT): the series is written in LPS as a supine, head-first scan.
  put(ds, 0x0018, 0x5100, VR::CS, "HFS");
  put(ds, 0x0018, 0x0050, VR::DS, formatDS(g.spacing.z));
  put(ds, 0x0018, 0x0088, VR::DS, formatDS(g.spacing.z));
  put(ds, 0x0020, 0x000d, VR::UI, s.studyUid);
  put(ds, 0x0020, 0x000e, VR::UI, s.seriesUid);
  put(ds, 0x0020, 0x0010, VR::SH, "1");
  put(ds, 0x0020, 0x0011, VR::IS, "1");
  put(ds, 0x0020, 0x0012, VR::IS, "1");
  put(ds, 0x0020, 0x0013, VR::IS, std::to_string(k + 1));
  put(ds, 0x0020, 0x0032, VR::DS, join({ipp.x, ipp.y, ipp.z}));
  put(ds, 0x0020, 0x0037, VR::DS, join({s.row.x, s.row.y, s.row.z, s.col.x, s.col.y, s.col.z}));
  put(ds, 0x0020, 0x0052, VR::UI, s.frameUid);
  put(ds, 0x0020, 0x1040, VR::LO, "");
  put(ds, 0x0020, 0x1041, VR::DS, formatDS(dot(ipp, s.normal)));
  // Image pixel: signed 16-bit monochrome.
  putUS(ds, 0x0028, 0x0002, 1);
  put(ds, 0x0028, 0x0004, VR::CS, "MONOCHROME2");
  putUS(ds, 0x0028, 0x0010, static_cast<uint16_t>(g.dims.y));
  putUS(ds, 0x0028, 0x0011, static_cast<uint16_t>(g.dims.x));
  put(ds, 0x0028, 0x0030, VR::DS, join({g.spacing.y, g.spacing.x}));  // row, column
  putUS(ds, 0x0028, 0x0100, 16);
  putUS(ds, 0x0028, 0x0101, 16);
  putUS(ds, 0x0028, 0x0102, 15);
  putUS(ds, 0x0028, 0x0103, 1);
  put(ds, 0x0028, 0x1050, VR::DS, formatDS(0.5 * (s.lo + s.hi)));
  put(ds, 0x0028, 0x1051, VR::DS, formatDS(std::max(1.0, s.hi - s.lo)));
  put(ds, 0x0028, 0x1052, VR::DS, formatDS(s.enc.intercept));
  put(ds, 0x0028, 0x1053, VR::DS, formatDS(s.enc.slope));
  put(ds, 0x0028, 0x1054, VR::LO, s.ct ? "HU" : "US");
}

}  // namespace

void saveDicomSeries(const AnyVolume& volume, const std::filesystem::path& dir,
                     const SaveOptions& options) {
  dicom::quietGdcm();
  const Geometry& g = geometryOf(volume);
  try {
    g.validate(dir.string());
  } catch (const FileError&) {
    throw;
  } catch (const Error& e) {
    throw FileError(dir, e.what());
  }
  if (g.dims.x > 65535 || g.dims.y > 65535)
    throw FileError(dir, "slices of " + g.dims.str() + " exceed the DICOM limit of 65535 pixels");

  SeriesTags series;
  series.modality = options.modality.empty() ? "OT" : cleanText(options.modality, 16);
  series.description = cleanText(options.seriesDescription, 64);
  series.ct = series.modality == "CT";
  series.enc = std::visit([](const auto& v) { return chooseEncoding(v); }, volume);
  std::tie(series.lo, series.hi) = std::visit([](const auto& v) { return v.valueRange(); }, volume);
  gdcm::UIDGenerator uidGen;
  series.studyUid = uidGen.Generate();
  series.seriesUid = uidGen.Generate();
  series.frameUid = uidGen.Generate();
  for (int64_t k = 0; k < g.dims.z; ++k) series.sopUids.emplace_back(uidGen.Generate());
  series.row = normalized(g.direction.column(0));
  series.col = normalized(g.direction.column(1));
  series.axis = normalized(g.direction.column(2));
  series.normal = normalized(cross(series.row, series.col));
  // One clock reading for both tags, so date and time cannot straddle midnight.
  const std::time_t now = std::time(nullptr);
  series.date = formatUtc(now, "%Y%m%d");
  series.time = formatUtc(now, "%H%M%S");
  const int digits = std::max<int>(4, static_cast<int>(std::to_string(g.dims.z).size()));
  Progress* progress = options.progress;

  writeFolderAtomically(dir, FolderKind::DicomSeries, [&](const std::filesystem::path& tmp) {
    if (progress) progress->begin("writing DICOM slices", static_cast<uint64_t>(g.dims.z));
    parallelFor(g.dims.z, [&](int64_t k0, int64_t k1) {
      std::vector<int16_t> pixels(static_cast<size_t>(g.dims.x * g.dims.y));
      for (int64_t k = k0; k < k1; ++k) {
        std::visit([&](const auto& v) { encodeSlice(v, k, series.enc, pixels.data()); }, volume);
        gdcm::Writer writer;
        char name[64];
        std::snprintf(name, sizeof name, "IMG%0*lld.dcm", digits, static_cast<long long>(k + 1));
        const std::filesystem::path file = tmp / name;
        // GDCM encodes into memory and we write the bytes: its own file stream asserts (and
        // aborts) when the disk fills; ours throws a FileError and the folder is removed.
        std::ostringstream encoded;
        writer.SetStream(encoded);
        gdcm::File& f = writer.GetFile();
        f.GetHeader().SetDataSetTransferSyntax(gdcm::TransferSyntax::ExplicitVRLittleEndian);
        gdcm::DataSet& ds = f.GetDataSet();
        fillSliceHeader(ds, series, g, k);
        gdcm::DataElement pixelData(gdcm::Tag(0x7fe0, 0x0010));
        pixelData.SetVR(gdcm::VR::OW);
        pixelData.SetByteValue(reinterpret_cast<const char*>(pixels.data()),
                               static_cast<uint32_t>(pixels.size() * sizeof(int16_t)));
        ds.Replace(pixelData);
        if (!writer.Write()) throw FileError(file, "cannot encode DICOM file");
        detail::writeBinaryFile(file, encoded.str(), {});
        if (progress) progress->advance();
      }
    });
    if (progress) progress->end();
  }, options.force);
}

}  // namespace vellum::io::detail
