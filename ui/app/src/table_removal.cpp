// CT table removal on load (see table_removal.hpp).
#include "vellum/app/table_removal.hpp"

#include <cstdio>

#include "vellum/core/error.hpp"

namespace vellum::app {

namespace {

const VolumeI16& requireCt(const AnyVolume& volume, const std::filesystem::path& path) {
  const auto* ct = std::get_if<VolumeI16>(&volume);
  if (!ct) throw FileError(path, "--remove-table needs a CT in HU (int16); use --rescale for CT numbers");
  return *ct;
}

std::string litres(double ml) {
  char buf[32];
  std::snprintf(buf, sizeof buf, ml >= 1000 ? "%.2f L" : "%.0f mL", ml >= 1000 ? ml / 1000 : ml);
  return buf;
}

}  // namespace

segmentation::Mask ctBodyMask(const AnyVolume& volume, const std::filesystem::path& path,
                              const segmentation::BodyMaskParams& params, Progress& progress,
                              segmentation::BodyMaskReport* report) {
  return segmentation::bodyMask(requireCt(volume, path), params, progress, report);
}

AnyVolume withoutCtTable(const AnyVolume& volume, const std::filesystem::path& path,
                         const segmentation::BodyMaskParams& params, Progress& progress,
                         segmentation::BodyMaskReport* report) {
  return segmentation::removeTable(requireCt(volume, path), params, progress, report);
}

nlohmann::json tableRemovalJson(const segmentation::BodyMaskReport& r) {
  return {{"kept_parts_ml", r.keptPartsMl},
          {"removed_ml", r.removedMl},
          {"removed_parts", r.removedParts},
          {"kept_largest_below_minimum", r.keptLargestBelowMinimum}};
}

std::string tableRemovalSummary(const segmentation::BodyMaskReport& r) {
  std::string kept;
  for (double ml : r.keptPartsMl) kept += (kept.empty() ? "" : ", ") + litres(ml);
  std::string line = "--remove-table: kept " + std::to_string(r.keptPartsMl.size()) + " body part" +
                     (r.keptPartsMl.size() == 1 ? "" : "s") + " (" + kept + "); removed " + litres(r.removedMl) +
                     " (table, pads, " + std::to_string(r.removedParts) + " separate piece" +
                     (r.removedParts == 1 ? "" : "s") + ")";
  if (r.keptLargestBelowMinimum) line += "; no part met --table-min-part-volume/-thickness: kept the largest";
  return line;
}

}  // namespace vellum::app
