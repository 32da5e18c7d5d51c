// Finding DICOM image files and reading their headers (no pixel data): a header-only GDCM
// read per file, in parallel, including the functional groups of enhanced multi-frame files.
#include <gdcmReader.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <mutex>
#include <system_error>

#include "dicom.hpp"
#include "dicom_gdcm.hpp"
#include "dicom_internal.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum::io::detail {

namespace dicom {
namespace {

const gdcm::Tag kPixelData(0x7fe0, 0x0010);
const gdcm::Tag kSopClass(0x0008, 0x0016), kSopInstance(0x0008, 0x0018);
const gdcm::Tag kModality(0x0008, 0x0060), kSeriesDescription(0x0008, 0x103e);
const gdcm::Tag kSeriesUid(0x0020, 0x000e), kInstanceNumber(0x0020, 0x0013);
const gdcm::Tag kPosition(0x0020, 0x0032), kOrientation(0x0020, 0x0037);
const gdcm::Tag kRows(0x0028, 0x0010), kColumns(0x0028, 0x0011), kFrames(0x0028, 0x0008);
const gdcm::Tag kPixelSpacing(0x0028, 0x0030), kSliceThickness(0x0018, 0x0050);
const gdcm::Tag kSpacingBetween(0x0018, 0x0088);
const gdcm::Tag kSlope(0x0028, 0x1053), kIntercept(0x0028, 0x1052);
// Enhanced multi-frame functional groups.
const gdcm::Tag kSharedGroups(0x5200, 0x9229), kPerFrameGroups(0x5200, 0x9230);
const gdcm::Tag kPlanePositionSeq(0x0020, 0x9113), kPlaneOrientationSeq(0x0020, 0x9116);
const gdcm::Tag kPixelMeasuresSeq(0x0028, 0x9110), kPixelValueTransformSeq(0x0028, 0x9145);

constexpr int64_t kMaxFrames = 100000;  // beyond this a file is treated as corrupt

/// Applies the geometry/rescale attributes present in `ds` to `f` (absent ones keep theirs).
void applyImageAttributes(const gdcm::DataSet& ds, Frame& f) {
  if (auto v = numbers(ds, kPosition); v && v->size() == 3) f.position = Vec3{(*v)[0], (*v)[1], (*v)[2]};
  if (auto v = numbers(ds, kOrientation); v && v->size() == 6) {
    f.rowCosine = Vec3{(*v)[0], (*v)[1], (*v)[2]};
    f.colCosine = Vec3{(*v)[3], (*v)[4], (*v)[5]};
  }
  if (auto v = numbers(ds, kPixelSpacing); v && v->size() == 2) {
    f.rowSpacing = (*v)[0];
    f.colSpacing = (*v)[1];
  } else if (v && v->size() == 1) {  // seen in the wild: one value for square pixels
    f.rowSpacing = f.colSpacing = (*v)[0];
  }
  if (auto v = number(ds, kSliceThickness)) f.sliceThickness = *v;
  if (auto v = number(ds, kSpacingBetween)) f.spacingBetweenSlices = *v;
  if (auto v = number(ds, kSlope)) f.slope = *v;
  if (auto v = number(ds, kIntercept)) f.intercept = *v;
}

/// Applies one functional-group item (shared or per-frame) to a frame.
void applyFunctionalGroup(const gdcm::DataSet& group, Frame& f) {
  for (const gdcm::Tag& seq : {kPlanePositionSeq, kPlaneOrientationSeq, kPixelMeasuresSeq,
                               kPixelValueTransformSeq})
    if (auto item = firstItem(group, seq)) applyImageAttributes(*item, f);
}

/// Reads and checks the image pixel module; returns the problem ("" when usable).
std::string readPixelModule(const gdcm::DataSet& ds, FileHeader& h) {
  const auto samples = ushortValue(ds, gdcm::Tag(0x0028, 0x0002));
  const auto allocated = ushortValue(ds, gdcm::Tag(0x0028, 0x0100));
  const auto stored = ushortValue(ds, gdcm::Tag(0x0028, 0x0101));
  const auto high = ushortValue(ds, gdcm::Tag(0x0028, 0x0102));
  const auto representation = ushortValue(ds, gdcm::Tag(0x0028, 0x0103));
  const std::string photometric = stringValue(ds, gdcm::Tag(0x0028, 0x0004));
  if (samples && *samples != 1)
    return "colour images (" + std::to_string(*samples) + " samples per pixel) are not supported";
  if (!photometric.empty() && photometric != "MONOCHROME2" && photometric != "MONOCHROME1")
    return "photometric interpretation " + photometric + " is not supported (greyscale only)";
  h.monochrome1 = photometric == "MONOCHROME1";
  if (!allocated) return "no BitsAllocated";
  h.bitsAllocated = *allocated;
  if (h.bitsAllocated != 8 && h.bitsAllocated != 16 && h.bitsAllocated != 32)
    return "unsupported BitsAllocated " + std::to_string(h.bitsAllocated);
  h.bitsStored = stored ? *stored : h.bitsAllocated;
  h.highBit = high ? *high : h.bitsStored - 1;
  if (h.bitsStored < 1 || h.bitsStored > h.bitsAllocated || h.highBit >= h.bitsAllocated ||
      h.highBit + 1 < h.bitsStored)
    return "inconsistent BitsAllocated/BitsStored/HighBit " + std::to_string(h.bitsAllocated) +
           "/" + std::to_string(h.bitsStored) + "/" + std::to_string(h.highBit);
  if (representation && *representation > 1)
    return "invalid PixelRepresentation " + std::to_string(*representation);
  h.signedPixels = representation && *representation == 1;
  return {};
}

enum class Outcome { Image, NotDicom, NotImage, Unreadable };

struct FileResult {
  Outcome outcome = Outcome::NotDicom;
  FileHeader header;
  std::string problem;
};

/// The frames of an image file: the frame count, and each frame's geometry from the image
/// attributes, the shared and the per-frame functional groups; returns the problem ("" when usable).
std::string readFrames(const gdcm::DataSet& ds, const fs::path& file, FileHeader& h) {
  h.frameCount = 1;
  if (auto n = number(ds, kFrames)) {
    if (!(*n >= 1 && *n <= kMaxFrames) || *n != std::floor(*n)) return "absurd NumberOfFrames " + num(*n, 0);
    h.frameCount = static_cast<int64_t>(*n);
  }

  Frame base;
  base.file = file;
  if (auto n = number(ds, kInstanceNumber); n && std::abs(*n) < 1e15)
    base.instanceNumber = static_cast<int64_t>(*n);
  applyImageAttributes(ds, base);
  if (auto shared = firstItem(ds, kSharedGroups)) applyFunctionalGroup(*shared, base);

  gdcm::SmartPointer<gdcm::SequenceOfItems> perFrame = sequence(ds, kPerFrameGroups);
  const int64_t perFrameItems = perFrame ? static_cast<int64_t>(perFrame->GetNumberOfItems()) : 0;
  if (perFrameItems > 0 && perFrameItems != h.frameCount)
    return "per-frame functional groups list " + std::to_string(perFrameItems) +
           " frames but NumberOfFrames is " + std::to_string(h.frameCount);
  h.frames.reserve(static_cast<size_t>(h.frameCount));
  for (int64_t f = 0; f < h.frameCount; ++f) {
    Frame fr = base;
    fr.frameIndex = f;
    if (perFrameItems > 0)
      applyFunctionalGroup(perFrame->GetItem(static_cast<gdcm::SequenceOfItems::SizeType>(f + 1))
                               .GetNestedDataSet(),
                           fr);
    h.frames.push_back(std::move(fr));
  }
  return {};
}

FileResult readHeader(const fs::path& file) {
  FileResult r;
  // GDCM may abort on damaged files: only structurally sound ones go to GDCM.
  const StructureCheck structure = checkStructure(file);
  if (!structure.ok) {
    r.outcome = structure.dicomLike ? Outcome::Unreadable : Outcome::NotDicom;
    r.problem = structure.problem;
    r.header.seriesUid = structure.seriesUid;
    return r;
  }
  const bool magic = structure.dicomLike;
  gdcm::Reader reader;
  reader.SetFileName(file.string().c_str());
  bool ok = false;
  try {
    ok = reader.ReadUpToTag(kPixelData);
  } catch (const std::exception& e) {
    r.problem = e.what();
  }
  if (!ok) {
    r.outcome = magic ? Outcome::Unreadable : Outcome::NotDicom;
    if (r.problem.empty()) r.problem = "DICOM header does not parse";
    return r;
  }
  const gdcm::DataSet& ds = reader.GetFile().GetDataSet();
  FileHeader& h = r.header;
  h.file = file;
  h.sopClassUid = stringValue(ds, kSopClass);
  if (h.sopClassUid.empty())  // media storage class in the meta header as a fallback
    h.sopClassUid = stringValue(reader.GetFile().GetHeader(), gdcm::Tag(0x0002, 0x0002));
  const auto rows = ushortValue(ds, kRows), cols = ushortValue(ds, kColumns);
  if (!magic && h.sopClassUid.empty() && !rows) {
    r.outcome = Outcome::NotDicom;  // parsed by accident: nothing DICOM-like inside
    return r;
  }
  h.seriesUid = stringValue(ds, kSeriesUid);
  if (!rows || !cols || *rows == 0 || *cols == 0) {
    // A DICOMDIR is an index; anything else without an image may be a damaged slice (a file
    // cut at an element boundary parses cleanly), so it is reported with its series.
    if (h.sopClassUid == "1.2.840.10008.1.3.10") {
      r.outcome = Outcome::NotImage;
    } else {
      r.outcome = Outcome::Unreadable;
      r.problem = "DICOM file holds no image (Rows/Columns missing)";
    }
    return r;
  }
  h.rows = *rows;
  h.columns = *cols;
  if (std::string why = readPixelModule(ds, h); !why.empty()) {
    r.outcome = Outcome::Unreadable;
    r.problem = why;
    return r;
  }
  h.modality = stringValue(ds, kModality);
  h.description = stringValue(ds, kSeriesDescription);
  h.sopInstanceUid = stringValue(ds, kSopInstance);
  if (std::string why = readFrames(ds, file, h); !why.empty()) {
    r.outcome = Outcome::Unreadable;
    r.problem = why;
    return r;
  }
  r.outcome = Outcome::Image;
  return r;
}

/// Regular files under `folder` (recursively), sorted; skips our own in-progress temporaries.
std::vector<fs::path> listFiles(const fs::path& folder) {
  std::vector<fs::path> files;
  std::error_code ec;
  fs::recursive_directory_iterator it(folder, fs::directory_options::skip_permission_denied, ec),
      end;
  if (ec) throw FileError(folder, "cannot list folder: " + ec.message());
  for (; it != end; it.increment(ec)) {
    if (ec) throw FileError(folder, "cannot list folder: " + ec.message());
    const std::string name = it->path().filename().string();
    if (name.rfind(".vellum-", 0) == 0) {  // a writer's temporary (see writeAtomically)
      if (it->is_directory(ec)) it.disable_recursion_pending();
      continue;
    }
    if (it->is_regular_file(ec)) files.push_back(it->path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace

std::string num(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

ScanResult scan(const fs::path& path, Progress* progress) {
  quietGdcm();
  std::error_code ec;
  const auto st = fs::status(path, ec);
  if (!fs::exists(st)) throw FileError(path, "no such file or folder");

  ScanResult result;
  if (!fs::is_directory(st)) {
    if (!fs::is_regular_file(st)) throw FileError(path, "not a regular file or folder");
    FileResult r = readHeader(path);
    switch (r.outcome) {
      case Outcome::NotDicom: throw FileError(path, "not a DICOM file");
      case Outcome::Unreadable: throw FileError(path, "unreadable DICOM file: " + r.problem);
      case Outcome::NotImage: throw FileError(path, "DICOM file holds no image (a DICOMDIR?)");
      case Outcome::Image: result.images.push_back(std::move(r.header)); break;
    }
    return result;
  }

  const std::vector<fs::path> files = listFiles(path);
  if (progress) progress->begin("scanning DICOM headers", files.size());
  std::vector<FileResult> results(files.size());
  parallelFor(static_cast<int64_t>(files.size()), [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      try {
        results[static_cast<size_t>(i)] = readHeader(files[static_cast<size_t>(i)]);
      } catch (const std::exception& ex) {  // never let one odd file end the scan
        results[static_cast<size_t>(i)].outcome = Outcome::Unreadable;
        results[static_cast<size_t>(i)].problem = ex.what();
      }
      if (progress) progress->advance();
    }
  });
  if (progress) progress->end();

  for (size_t i = 0; i < files.size(); ++i) {
    FileResult& r = results[i];
    switch (r.outcome) {
      case Outcome::NotDicom: ++result.skippedNonDicom; break;
      case Outcome::NotImage: ++result.skippedNonImage; break;
      case Outcome::Unreadable:
        result.unreadable.push_back({files[i], r.problem, r.header.seriesUid});
        break;
      case Outcome::Image: result.images.push_back(std::move(r.header)); break;
    }
  }
  return result;
}

std::vector<SeriesInfo> summarize(const ScanResult& scan) {
  std::map<std::string, SeriesInfo> bySeries;
  for (const FileHeader& h : scan.images) {
    SeriesInfo& s = bySeries[h.seriesUid];
    if (s.fileCount == 0) {
      s.uid = h.seriesUid;
      s.modality = h.modality;
      s.description = h.description;
      s.sopClassUid = h.sopClassUid;
      s.rows = h.rows;
      s.columns = h.columns;
    }
    ++s.fileCount;
    s.frames += h.frameCount;
  }
  std::vector<SeriesInfo> out;
  for (auto& [uid, s] : bySeries) out.push_back(std::move(s));
  std::stable_sort(out.begin(), out.end(),
                   [](const SeriesInfo& a, const SeriesInfo& b) { return a.frames > b.frames; });
  return out;
}

}  // namespace dicom

bool looksLikeDicom(const std::filesystem::path& file) {
  dicom::quietGdcm();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) return false;
  try {
    return dicom::readHeader(file).outcome != dicom::Outcome::NotDicom;
  } catch (...) {
    return false;
  }
}

}  // namespace vellum::io::detail

namespace vellum::io {

std::vector<SeriesInfo> listDicomSeries(const std::filesystem::path& path) {
  return detail::dicom::summarize(detail::dicom::scan(path, nullptr));
}

}  // namespace vellum::io
