#pragma once
// CT table removal on load (--remove-table), for every command and pipeline that offers it.
#include <filesystem>

#include "vellum/core/progress.hpp"
#include "vellum/core/volume.hpp"
#include "vellum/segmentation/body_mask.hpp"

namespace vellum::app {

/// `volume` without the CT table (segmentation::removeTable). The volume must be a CT in HU
/// (int16): otherwise FileError naming `path`.
AnyVolume withoutCtTable(const AnyVolume& volume, const std::filesystem::path& path,
                         const segmentation::BodyMaskParams& params, Progress& progress = Progress::none());

}  // namespace vellum::app
