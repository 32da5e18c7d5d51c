#pragma once
// CT table removal on load (--remove-table), for every command and pipeline that offers it.
#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>

#include "vellum/core/progress.hpp"
#include "vellum/core/volume.hpp"
#include "vellum/segmentation/body_mask.hpp"

namespace vellum::app {

/// The body of `volume` (segmentation::bodyMask): every body part above the minimum volume and
/// thickness. The volume must be a CT in HU (int16): otherwise FileError naming `path`.
segmentation::Mask ctBodyMask(const AnyVolume& volume, const std::filesystem::path& path,
                              const segmentation::BodyMaskParams& params, Progress& progress = Progress::none(),
                              segmentation::BodyMaskReport* report = nullptr);

/// `volume` without the CT table: every voxel outside ctBodyMask() set to air.
AnyVolume withoutCtTable(const AnyVolume& volume, const std::filesystem::path& path,
                         const segmentation::BodyMaskParams& params, Progress& progress = Progress::none(),
                         segmentation::BodyMaskReport* report = nullptr);

/// What was kept and removed, for a command's report:
/// {"kept_parts_ml": [...], "removed_ml": x, "removed_parts": n, "kept_largest_below_minimum": b}.
nlohmann::json tableRemovalJson(const segmentation::BodyMaskReport& report);
/// The same in one line for stderr, e.g. "--remove-table: kept 2 body parts (1.21 L, 1.18 L);
/// removed 0.83 L (table, pads, 3 pieces)".
std::string tableRemovalSummary(const segmentation::BodyMaskReport& report);

}  // namespace vellum::app
