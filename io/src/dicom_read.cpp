// loadDicom: scan -> pick a series -> order slices in space -> decode pixels (parallel, one
// GDCM reader per file) -> drop exact duplicates -> resample when the stack is irregular.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <map>

#include "dicom.hpp"
#include "dicom_internal.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum::io::detail {

namespace {

using namespace dicom;

std::string skippedSummary(const ScanResult& s) {
  std::string out;
  auto add = [&](int64_t n, const std::string& what) {
    if (n == 0) return;
    if (!out.empty()) out += ", ";
    out += std::to_string(n) + " " + what;
  };
  add(s.skippedNonDicom, "not DICOM");
  add(s.skippedNonImage, "DICOMDIR");
  return out;
}

/// The series to load: options.seriesUid, else the largest CT series, else the largest one.
const SeriesInfo& chooseSeries(const fs::path& path, const std::vector<SeriesInfo>& series,
                               const std::string& wanted) {
  if (!wanted.empty()) {
    for (const SeriesInfo& s : series)
      if (s.uid == wanted) return s;
    std::string available;
    for (const SeriesInfo& s : series) {
      if (!available.empty()) available += ", ";
      available += s.uid;
    }
    throw FileError(path, "series " + wanted + " not found; available: " + available);
  }
  for (const SeriesInfo& s : series)  // sorted largest first
    if (s.modality == "CT") return s;
  return series.front();
}

/// Where each decoded frame goes: the stack slot of a kept slice, or a duplicate to compare.
struct Target {
  int64_t slot = -1;
  bool duplicate = false;
};
using FrameKey = std::pair<fs::path, int64_t>;

/// A volume after the memory budget check; a refusal names the DICOM path.
VolumeI16 allocate(const fs::path& path, const Geometry& g, double background) {
  try {
    return VolumeI16(g, 0, background);
  } catch (const FileError&) {
    throw;
  } catch (const Error& e) {
    throw FileError(path, e.what());
  }
}

/// The chosen series (with the loader's warnings about the others) and its files, which must
/// all share one image size. Refuses unreadable files that may belong to it.
std::vector<const FileHeader*> chooseSeriesFiles(const fs::path& path, const ScanResult& scanned,
                                                 const LoadOptions& options, LoadedVolume& result) {
  // A damaged DICOM file may be a slice of the series: refuse rather than leave a hole,
  // unless it is known to belong to another series.
  auto refuseUnreadable = [&](const std::string& loadingUid) {
    for (const Unreadable& u : scanned.unreadable)
      if (u.seriesUid.empty() || u.seriesUid == loadingUid)
        throw FileError(u.file, "unreadable DICOM file: " + u.problem);
  };
  if (scanned.images.empty()) {
    refuseUnreadable("");
    const std::string skipped = skippedSummary(scanned);
    throw FileError(path, "no DICOM images found" +
                              (skipped.empty() ? std::string(" (empty folder)")
                                               : " (skipped files: " + skipped + ")"));
  }
  result.format = "dicom";
  result.series = summarize(scanned);
  const SeriesInfo& chosen = chooseSeries(path, result.series, options.seriesUid);
  result.seriesUid = chosen.uid;
  refuseUnreadable(chosen.uid);
  if (!scanned.unreadable.empty())
    result.warnings.push_back("skipped " + std::to_string(scanned.unreadable.size()) +
                              " DICOM file(s) of other series without a readable image (first: " +
                              scanned.unreadable.front().file.string() + ": " +
                              scanned.unreadable.front().problem + ")");
  result.modality = chosen.modality;
  if (const std::string skipped = skippedSummary(scanned); !skipped.empty())
    result.warnings.push_back("skipped files: " + skipped);
  if (result.series.size() > 1)
    result.warnings.push_back("found " + std::to_string(result.series.size()) +
                              " series; loaded " + chosen.uid + " (" +
                              std::to_string(chosen.frames) + " images)");

  std::vector<const FileHeader*> files;
  for (const FileHeader& h : scanned.images)
    if (h.seriesUid == chosen.uid) files.push_back(&h);
  const int64_t rows = files.front()->rows, columns = files.front()->columns;
  for (const FileHeader* h : files)
    if (h->rows != rows || h->columns != columns)
      throw FileError(h->file, "mixed image sizes in one series: " + std::to_string(h->columns) +
                                   "x" + std::to_string(h->rows) + " but " +
                                   files.front()->file.filename().string() + " is " +
                                   std::to_string(columns) + "x" + std::to_string(rows));
  return files;
}

/// Every frame's destination slot, decided before anything is decoded; `duplicates` counts
/// the frames that only have to match a kept slice.
std::map<FrameKey, Target> frameTargets(const SlicePlan& plan, int64_t& duplicates) {
  std::map<FrameKey, Target> targets;
  duplicates = 0;
  for (size_t k = 0; k < plan.slices.size(); ++k) {
    targets[{plan.slices[k].file, plan.slices[k].frameIndex}] = {static_cast<int64_t>(k), false};
    for (const Frame& d : plan.duplicates[k]) {
      targets[{d.file, d.frameIndex}] = {static_cast<int64_t>(k), true};
      ++duplicates;
    }
  }
  return targets;
}

/// Headers can claim far more pixels than their files hold (a 1.3 KB file promising
/// gigabytes, found by the DICOM fuzzer): refuse before allocating. Even run-length or
/// lossless-JPEG compression of empty slices stays well under 1000:1.
void checkPixelsFitFiles(const fs::path& path, const std::vector<const FileHeader*>& files, const Geometry& stack) {
  uint64_t fileBytes = 0;
  for (const FileHeader* h : files) {
    std::error_code ec;
    const auto n = fs::file_size(h->file, ec);
    if (!ec) fileBytes += n;
  }
  const double pixelBytes = double(stack.dims.voxelCount()) * 2.0;
  if (pixelBytes > 1000.0 * double(fileBytes) + double(1u << 20))
    throw FileError(path, "the headers describe " + std::to_string(uint64_t(pixelBytes)) + " bytes of pixels but the files hold only " +
                              std::to_string(fileBytes) + " bytes (corrupt rows, columns or frame counts)");
}

/// Decodes the files into `stack` (files in parallel): pass 0 the files holding kept slices,
/// pass 1 those holding duplicates, compared against the kept slice (which pass 0 has filled).
/// Returns how many values were clamped to int16.
int64_t decodeIntoStack(const std::vector<const FileHeader*>& files, const std::map<FrameKey, Target>& targets,
                        const SlicePlan& plan, VolumeI16& stack, Progress* progress, bool storedValues) {
  const int64_t plane = stack.geometry().dims.x * stack.geometry().dims.y;
  std::atomic<int64_t> saturated{0};
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<const FileHeader*> todo;
    for (const FileHeader* h : files)
      for (const Frame& f : h->frames) {
        auto it = targets.find({h->file, f.frameIndex});
        if (it != targets.end() && it->second.duplicate == (pass == 1)) {
          todo.push_back(h);
          break;
        }
      }
    parallelFor(static_cast<int64_t>(todo.size()), [&](int64_t b, int64_t e) {
      for (int64_t t = b; t < e; ++t) {
        const FileHeader& h = *todo[static_cast<size_t>(t)];
        saturated += decodeFile(h, [&](int64_t frame, const int16_t* values) {
          auto it = targets.find({h.file, frame});
          if (it == targets.end() || it->second.duplicate != (pass == 1)) return;
          int16_t* slot = stack.data() + it->second.slot * plane;
          if (pass == 0) {
            std::memcpy(slot, values, static_cast<size_t>(plane) * sizeof(int16_t));
          } else if (std::memcmp(slot, values, static_cast<size_t>(plane) * sizeof(int16_t)) != 0) {
            const Frame& kept = plan.slices[static_cast<size_t>(it->second.slot)];
            throw FileError(h.file, "conflicting slices: same position as " + kept.file.filename().string() +
                                        " but different pixel data");
          }
          if (progress) progress->advance();
        }, storedValues);
      }
    });
  }
  return saturated.load();
}

}  // namespace

LoadedVolume loadDicom(const std::filesystem::path& path, const LoadOptions& options) {
  Progress* progress = options.progress;
  const ScanResult scanned = scan(path, progress);
  LoadedVolume result;
  const std::vector<const FileHeader*> files = chooseSeriesFiles(path, scanned, options, result);

  std::vector<Frame> frames;
  for (const FileHeader* h : files) frames.insert(frames.end(), h->frames.begin(), h->frames.end());
  SlicePlan plan = planSlices(std::move(frames), files.front()->rows, files.front()->columns);
  result.warnings.insert(result.warnings.end(), plan.warnings.begin(), plan.warnings.end());

  const bool ct = result.modality == "CT";
  const double background = ct ? kCtAirHu : 0.0;
  int64_t duplicateCount = 0;
  const std::map<FrameKey, Target> targets = frameTargets(plan, duplicateCount);
  bool fractionalSlope = false, oneRescale = true;
  const Frame& first = files.front()->frames.front();
  for (const FileHeader* h : files)
    for (const Frame& f : h->frames) {
      if (f.slope != std::round(f.slope) || f.intercept != std::round(f.intercept)) fractionalSlope = true;
      oneRescale = oneRescale && f.slope == first.slope && f.intercept == first.intercept;
    }
  // Non-CT data with one fractional rescale (a float volume Vellum wrote, a PET or dose map):
  // decode the stored int16 values and return stored * slope + intercept as float32, instead
  // of rounding the real values to integers.
  bool asFloat = fractionalSlope && !ct && oneRescale;
  for (const FileHeader* h : files) asFloat = asFloat && h->bitsAllocated == 16 && h->signedPixels;

  Geometry stackGeometry = plan.geometry;
  stackGeometry.dims.z = static_cast<int64_t>(plan.slices.size());
  checkPixelsFitFiles(path, files, stackGeometry);
  VolumeI16 stack = allocate(path, stackGeometry, background);
  if (progress) progress->begin("decoding DICOM slices", plan.slices.size() + duplicateCount);
  const int64_t saturated = decodeIntoStack(files, targets, plan, stack, progress, asFloat);
  if (progress) progress->end();

  // Single mis-registered slices, before resampling (which would spread one into two).
  if (options.repairSlices)
    repairMisregisteredSlices(plan, stack.data(), stackGeometry.dims.x, stackGeometry.dims.y, result.warnings);

  if (duplicateCount > 0)
    result.warnings.push_back("dropped " + std::to_string(duplicateCount) +
                              " duplicate slice" + (duplicateCount > 1 ? "s" : "") +
                              " (same position and identical pixels)");
  if (saturated > 0)
    result.warnings.push_back(std::to_string(saturated) + " values outside the int16 range were clamped");
  if (fractionalSlope && !ct && !asFloat)
    result.warnings.push_back("non-integral rescale slope/intercept: values rounded to integers");

  if (plan.resample) {
    VolumeI16 out = allocate(path, plan.geometry, background);
    resampleStack(plan, stack.voxels(), out, background, progress);
    result.volume = std::move(out);
  } else {
    result.volume = std::move(stack);
  }
  if (asFloat) {
    VolumeF32 real = convertVolume<float>(result.volume);
    for (float& x : real.voxels()) x = static_cast<float>(x * first.slope + first.intercept);
    real.setBackground(0.0);
    result.volume = std::move(real);
  }
  try {
    geometryOf(result.volume).validate(path.string());
  } catch (const FileError&) {
    throw;
  } catch (const Error& e) {
    throw FileError(path, e.what());
  }
  return result;
}

}  // namespace vellum::io::detail
