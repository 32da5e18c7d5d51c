// Format dispatch for volumes and label maps.
#include "vellum/io/volume_io.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "dicom.hpp"
#include "io_detail.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum::io {

namespace fs = std::filesystem;
using namespace detail;

namespace {

const char* kSupported =
    "supported: folder or .dcm (DICOM), .nrrd, .nhdr, .raw (+ .raw.json sidecar), .mhd, .mha, "
    ".nii, .nii.gz (read only), .vti";

std::string normalizedFormat(const fs::path& path, const std::string& name) {
  const std::string n = lower(name);
  if (n == "dicom" || n == "dcm") return "dicom";
  if (n == "nrrd" || n == "nhdr") return "nrrd";
  if (n == "raw") return "raw";
  if (n == "metaimage" || n == "mhd" || n == "mha") return "metaimage";
  if (n == "nifti" || n == "nii") return "nifti";
  if (n == "vti" || n == "vtk") return "vti";
  throw FileError(path, "unknown format '" + name + "' (" + kSupported + ")");
}

/// Label ids from any integer volume; FileError when values are not ids.
VolumeU16 toLabelIds(const fs::path& path, const AnyVolume& v) {
  if (std::holds_alternative<VolumeU16>(v)) return std::get<VolumeU16>(v);
  if (std::holds_alternative<VolumeU8>(v)) return convertVolume<uint16_t>(v);
  const auto [lo, hi] = std::visit([](const auto& vol) { return vol.valueRange(); }, v);
  if (lo < 0 || hi > std::numeric_limits<uint16_t>::max())
    throw FileError(path, "not a label map: values " + fmt(lo) + ".." + fmt(hi) + " are outside 0..65535");
  if (const auto* f = std::get_if<VolumeF32>(&v)) {
    for (float x : f->voxels())
      if (x != std::floor(x)) throw FileError(path, "not a label map: non-integer value " + fmt(x));
  }
  VolumeU16 ids = convertVolume<uint16_t>(v);
  ids.setBackground(0.0);
  return ids;
}

}  // namespace

std::string formatForPath(const fs::path& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) return "dicom";
  const std::string name = lower(path.filename().string());
  auto endsWith = [&](const std::string& s) {
    return name.size() > s.size() && name.compare(name.size() - s.size(), s.size(), s) == 0;
  };
  if (endsWith(".nii.gz")) return "nifti";
  const std::string ext = lower(path.extension().string());
  if (ext.empty()) return "dicom";  // a (new) folder receives a DICOM series
  if (ext == ".dcm") return "dicom";
  if (ext == ".nrrd" || ext == ".nhdr") return "nrrd";
  if (ext == ".raw") return "raw";
  if (ext == ".mhd" || ext == ".mha") return "metaimage";
  if (ext == ".nii") return "nifti";
  if (ext == ".vti") return "vti";
  throw FileError(path, "unknown file extension '" + ext + "' (" + kSupported + ")");
}

namespace {

LoadedVolume loadAsStored(const fs::path& path, const LoadOptions& options) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw FileError(path, "no such file");
  std::string format;
  if (fs::is_directory(path, ec)) {
    format = "dicom";
  } else if (path.extension().empty()) {
    // DICOM files often have no extension (I10, IM0001 ...).
    if (!detail::looksLikeDicom(path))
      throw FileError(path, std::string("no file extension and not DICOM (") + kSupported + ")");
    format = "dicom";
  } else {
    format = formatForPath(path);
  }
  if (format == "dicom") return detail::loadDicom(path, options);
  if (format == "nrrd") return loadNrrd(path, options, nullptr);
  if (format == "raw") return loadRaw(path, options);
  if (format == "metaimage") return loadMetaImage(path, options);
  if (format == "nifti") return loadNifti(path, options);
  return loadVti(path, options);
}

}  // namespace

/// stored * slope + intercept as CT (int16 HU, background -1000).
VolumeI16 rescaledToHu(const AnyVolume& stored, double slope, double intercept) {
  return std::visit(
      [&](const auto& v) {
        VolumeI16 out(v.geometry(), 0, -1000.0);
        for (size_t i = 0; i < v.size(); ++i)
          out.data()[i] = static_cast<int16_t>(std::clamp(std::round(v.data()[i] * slope + intercept), -32768.0, 32767.0));
        return out;
      },
      stored);
}

/// Unsigned CT numbers read as if they were HU make every preset a solid box: say so.
std::optional<std::string> notHuWarning(const LoadedVolume& lv) {
  if (lv.modality != "CT" && lv.format != "raw") return std::nullopt;
  // HU data shows a negative value (air) almost at once: only data without any gets the full
  // range pass, so loading ordinary CT costs no extra pass over the volume.
  const bool anyNegative = std::visit(
      [](const auto& v) { return std::any_of(v.data(), v.data() + v.size(), [](auto x) { return x < 0; }); }, lv.volume);
  if (anyNegative) return std::nullopt;
  const auto [lo, hi] = std::visit([](const auto& v) { return v.valueRange(); }, lv.volume);
  if (lo < 0 || hi < 1000) return std::nullopt;
  return "values " + std::to_string(int64_t(lo)) + ".." + std::to_string(int64_t(hi)) +
         " have no negatives although this looks like CT: if they are CT numbers rather than HU, "
         "load with --rescale 1 -1024 (slope, intercept)";
}

/// NaN and infinite voxels (float data) would poison every sum, threshold and render: they
/// become the background, and the load says how many there were.
std::optional<std::string> replaceNonFinite(AnyVolume& volume) {
  auto* f = std::get_if<VolumeF32>(&volume);
  if (!f) return std::nullopt;
  const float background = static_cast<float>(f->background());
  int64_t count = 0;
  for (float& x : f->voxels())
    if (!std::isfinite(x)) {
      x = background;
      ++count;
    }
  if (count == 0) return std::nullopt;
  return std::to_string(count) + " voxel" + (count > 1 ? "s are" : " is") + " NaN or infinite: set to the background " +
         fmt(background);
}

LoadedVolume loadVolume(const fs::path& path, const LoadOptions& options) {
  if (options.rescale && (!std::isfinite(options.rescale->first) || !std::isfinite(options.rescale->second) ||
                          options.rescale->first == 0))
    throw FileError(path, "rescale slope " + fmt(options.rescale->first) + " and intercept " +
                              fmt(options.rescale->second) + ": both must be finite and the slope non-zero");
  LoadedVolume lv = loadAsStored(path, options);
  if (auto w = replaceNonFinite(lv.volume)) lv.warnings.push_back(*w);
  if (options.rescale) {
    lv.volume = rescaledToHu(lv.volume, options.rescale->first, options.rescale->second);
    lv.modality = "CT";
  } else if (auto w = notHuWarning(lv)) {
    lv.warnings.push_back(*w);
  }
  if (options.region.empty()) return lv;  // applyRegion would copy the whole volume
  try {
    lv.volume = applyRegion(lv.volume, options.region);
  } catch (const FileError&) {
    throw;
  } catch (const Error& e) {
    throw FileError(path, e.what());
  }
  return lv;
}

void saveVolume(const AnyVolume& volume, const fs::path& path, const SaveOptions& options) {
  const std::string format = options.format.empty() ? formatForPath(path) : normalizedFormat(path, options.format);
  const std::string modality = modalityToStore(volume, options.modality);
  if (format == "dicom") return detail::saveDicomSeries(volume, path, options);
  if (format == "nrrd") return saveNrrd(volume, path, options.gzip, modality, nullptr, options.progress);
  if (format == "raw") return saveRaw(volume, path, modality, options.progress);
  if (format == "metaimage") return saveMetaImage(volume, path, modality, options.progress);
  if (format == "vti") return saveVti(volume, path, modality, options.progress);
  throw FileError(path, "writing " + format + " is not supported (" + kSupported + ")");
}

namespace {

/// Label ids never averaged: the region's downsampling takes each block's most frequent id.
VolumeU16 labelIdsInRegion(const fs::path& path, const AnyVolume& stored, const Region& region) {
  try {
    VolumeU16 ids = toLabelIds(path, stored);
    if (region.empty()) return ids;  // applyRegionToLabels would copy it
    return applyRegionToLabels(ids, region);
  } catch (const FileError&) {
    throw;
  } catch (const Error& e) {
    throw FileError(path, e.what());
  }
}

}  // namespace

LabelVolume loadLabels(const fs::path& path, const LoadOptions& options) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw FileError(path, "no such file");
  if (!fs::is_directory(path, ec) && !path.extension().empty() && formatForPath(path) == "nrrd") {
    ExtraFields extra;
    LoadedVolume lv = loadNrrd(path, options, &extra);
    return LabelVolume(labelIdsInRegion(path, lv.volume, options.region), extra.labels);
  }
  LoadedVolume lv = loadAsStored(path, options);
  return LabelVolume(labelIdsInRegion(path, lv.volume, options.region));
}

void saveLabels(const LabelVolume& labels, const fs::path& path, const SaveOptions& options) {
  const std::string format = options.format.empty() ? formatForPath(path) : normalizedFormat(path, options.format);
  uint16_t maxId = labels.ids().empty() ? 0 : labels.maxId();
  for (const Label& l : labels.table()) maxId = std::max(maxId, l.id);
  // Narrowed straight from the ids (through an AnyVolume copy it would cost a second
  // volume-sized allocation), in parallel; every id is < 256 here.
  AnyVolume ids;
  if (maxId < 256) {
    VolumeU8 narrow(labels.ids().geometry(), 0);
    const uint16_t* src = labels.ids().data();
    uint8_t* dst = narrow.data();
    parallelFor(static_cast<int64_t>(narrow.size()), [&](int64_t b, int64_t e) {
      for (int64_t v = b; v < e; ++v) dst[v] = static_cast<uint8_t>(src[v]);
    }, 1 << 16);
    ids = std::move(narrow);
  } else {
    ids = labels.ids();
  }
  std::visit([](auto& v) { v.setBackground(0.0); }, ids);
  if (format == "nrrd") return saveNrrd(ids, path, options.gzip, "", &labels.table(), options.progress);
  SaveOptions plain = options;
  plain.format = format;
  plain.modality = "";
  saveVolume(ids, path, plain);
}

}  // namespace vellum::io
