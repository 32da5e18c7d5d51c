#pragma once
// `vellum labels` as a request: merge, reassign, drop, rename and recolour the ids of a label
// map — the pieces of one bone made one id before `--rigid-labels`, a bone split off into an id
// of its own, stray pieces dropped.
#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "vellum/core/progress.hpp"
#include "vellum/core/vec.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::app {

struct LabelEditRequest {
  std::filesystem::path input;   ///< label map (any format `vellum` reads)
  std::filesystem::path output;  ///< the edited map (.nrrd keeps the table)
  /// Each entry: these ids become that id (applied together, not in turn).
  std::vector<std::pair<std::vector<uint16_t>, uint16_t>> assign;
  std::vector<uint16_t> drop;  ///< these ids become background
  std::vector<uint16_t> keep;  ///< when set: every other id becomes background
  std::map<uint16_t, std::string> names;                  ///< table names after the moves
  std::map<uint16_t, std::array<uint8_t, 3>> colours;     ///< table colours after the moves
  std::filesystem::path report;  ///< JSON: ids, voxels and volumes before and after; empty: none
  bool force = false;            ///< a DICOM output may replace a Vellum folder of another kind
  io::LoadOptions load;          ///< region (crop, downsample), raw layout
  std::string commandLine;       ///< for the report (run_report.hpp)
};

struct LabelEditResult {
  struct Entry {
    uint16_t id = 0;
    std::string name;
    int64_t voxels = 0;
    double volumeMm3 = 0;
    Vec3 centreMm;           ///< the centroid of its voxels (which bone is where, for pose files)
    Vec3 boxMinMm, boxMaxMm;  ///< the physical bounds of its voxel centres
  };
  std::vector<Entry> before, after;  ///< the ids present, in id order
};

/// Loads, edits and writes the map under the output policy. Throws vellum::Error for an id that
/// is not in the map, an id moved twice, or a name/colour for an id the result does not hold.
LabelEditResult runLabelEdit(const LabelEditRequest& request, Progress& progress = Progress::none());

}  // namespace vellum::app
