#pragma once
// `vellum convert` as a request: a volume or label map from any readable format to any
// writable one, optionally with another voxel type, under the output policy.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "vellum/core/progress.hpp"
#include "vellum/core/volume.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::app {

struct ConvertRequest {
  std::filesystem::path input;   ///< volume file or DICOM folder
  std::filesystem::path output;  ///< file (format from the extension) or folder (DICOM series)
  std::optional<VoxelType> type;  ///< convert the voxels (rounding, saturating); empty: keep
  bool labels = false;            ///< a label map: keeps the label table
  bool gzip = true;               ///< NRRD: gzip encoding, raw otherwise
  bool force = false;             ///< a DICOM output may replace a Vellum folder of another kind
  io::LoadOptions load;           ///< series, raw layout, region, rescale
  std::filesystem::path report;   ///< JSON with the shared report keys (run_report.hpp); empty: none
  std::string commandLine;        ///< for the report
};

struct ConvertResult {
  Dims dims;
  VoxelType type = VoxelType::Int16;  ///< of what was written
  size_t labelCount = 0;              ///< label maps: entries of the label table
  std::vector<std::string> warnings;  ///< the load's
};

/// Loads, converts and writes; throws vellum::Error / FileError, vellum::Cancelled.
ConvertResult runConvert(const ConvertRequest& request, Progress& progress = Progress::none());

}  // namespace vellum::app
