#pragma once
// `vellum shape` as a request: load the CT and its label map (the same region; without the CT
// table when asked), clean the segments' shapes (illustration::runShapePipeline: denoise, mesh,
// repair, per-segment and union distances, segmentation volume with shells and grown
// segments) and write the shape folder (with shape.json) atomically, and the report.
#include <nlohmann/json.hpp>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "vellum/core/progress.hpp"
#include "vellum/illustration/shape.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/segmentation/body_mask.hpp"

namespace vellum::app {

struct ShapeRequest {
  std::filesystem::path input;   ///< CT volume file or DICOM folder
  std::filesystem::path labels;  ///< label map on the CT's grid (NRRD keeps the label table)
  std::filesystem::path out;     ///< the shape folder (docs/shape.md)
  std::filesystem::path report;  ///< also shape.json (+ the shared keys) here; empty: none
  /// NAME=ID[,ID..] (illustration::parseSegmentSpec); enclosing structures first.
  std::vector<std::string> segments;
  std::vector<illustration::Shell> shells;
  std::vector<illustration::Grow> grows;
  illustration::ShapeOptions options;  ///< the shape table (`vellum params`)
  std::string meshFormat = "ply";      ///< ply | obj | stl
  io::LoadOptions load;                ///< series, raw layout, region (the labels get the same region)
  std::optional<segmentation::BodyMaskParams> removeTable;  ///< labels outside the body dropped
  bool force = false;       ///< `out` may replace a Vellum folder of another kind
  std::string commandLine;  ///< for the report's shared keys (run_report.hpp)
};

struct ShapeResult {
  illustration::ShapeResult shape;  ///< meshes, checks, volumes (on the CT's geometry)
  double pipelineMs = 0;            ///< the shape pipeline's wall time
  nlohmann::json report;            ///< shape.json as written
  std::vector<std::string> warnings;  ///< the load's
  std::string tableRemoval;  ///< --remove-table's one-line summary; empty without it
};

/// Runs the request under the output policy. Throws vellum::Error / FileError (one line,
/// naming the file or flag), vellum::Cancelled through `progress`.
ShapeResult runShape(const ShapeRequest& request, Progress& progress = Progress::none());

}  // namespace vellum::app
