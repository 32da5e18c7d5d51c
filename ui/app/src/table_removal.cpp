// CT table removal on load (see table_removal.hpp).
#include "vellum/app/table_removal.hpp"

#include "vellum/core/error.hpp"

namespace vellum::app {

AnyVolume withoutCtTable(const AnyVolume& volume, const std::filesystem::path& path,
                         const segmentation::BodyMaskParams& params, Progress& progress) {
  const auto* ct = std::get_if<VolumeI16>(&volume);
  if (!ct) throw FileError(path, "--remove-table needs a CT in HU (int16); use --rescale for CT numbers");
  return segmentation::removeTable(*ct, params, progress);
}

}  // namespace vellum::app
