#pragma once
// `vellum render` as a request: load a volume (without the CT table when asked), optionally
// with an attribute field of `vellum deform --attributes-out` and label colours, upload it
// ONCE and draw one figure per preset and view through the GL ray caster (annotated when
// asked), each written atomically under the output policy, or all of them as one plate.
#include <nlohmann/json.hpp>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "vellum/app/figures.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/render/annotations.hpp"
#include "vellum/render/render_settings.hpp"
#include "vellum/segmentation/body_mask.hpp"

namespace vellum::app {

struct RenderRequest {
  std::filesystem::path input;   ///< volume file or DICOM folder
  std::filesystem::path output;  ///< the figure (one preset, one view), the stem of several, or the plate
  std::filesystem::path report;  ///< report JSON; empty: none
  /// Label map on the volume's grid: names its structures (annotations.labels) and, without
  /// labelColours, gives the tint's colours.
  std::filesystem::path labelMap;
  std::filesystem::path labelColours;  ///< label map whose colours tint the volume (settings.labelBlend)
  std::filesystem::path attributes;    ///< attribute field of `vellum deform --attributes-out`
  std::vector<render::Preset> presets{render::RenderSettings{}.preset};  ///< one figure each
  std::vector<FigureView> views;  ///< one figure each; empty: settings.camera
  /// All figures as one contact sheet at `output`: a row per preset, a column per view (one
  /// row when there is one view).
  bool plate = false;
  render::RenderSettings settings;  ///< size, camera, transfer function, lighting, background
  render::AnnotationOptions annotations;  ///< labels need labelMap
  std::vector<uint16_t> labelIds;         ///< structures to name (empty: every id of the table)
  io::LoadOptions load;                   ///< series, raw layout, region (the label maps get the same region)
  std::optional<segmentation::BodyMaskParams> removeTable;
  std::string commandLine;  ///< for the report's shared keys (run_report.hpp)
};

struct RenderFigure {
  std::filesystem::path path;  ///< the file (the plate's path for a plate's tile)
  render::Preset preset = render::Preset::Bone;
  std::string view;            ///< "" without RenderRequest::views
  double drawMs = 0;
  int samples = 0;  ///< path-traced samples (quality cinematic); 0 when ray cast
};

struct RenderResult {
  std::vector<RenderFigure> figures;  ///< preset by preset, view by view
  nlohmann::json report;              ///< what `report` holds
  std::vector<std::string> warnings;  ///< the load's
  std::string tableRemoval;  ///< --remove-table's one-line summary; empty without it
};

/// The files the request writes, in the order of RenderResult::figures (one file: `output`;
/// several: "-PRESET" and/or "-VIEW" suffixes for the axes with more than one entry; a plate:
/// `output`).
std::vector<std::filesystem::path> renderOutputs(const RenderRequest& request);

/// Runs the request on a headless GL context. Throws vellum::Error / FileError (one line),
/// vellum::Cancelled through `progress` (between figures); nothing of a failed run is left.
RenderResult runRender(const RenderRequest& request, Progress& progress = Progress::none());

}  // namespace vellum::app
