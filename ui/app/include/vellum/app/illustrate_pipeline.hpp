#pragma once
// `vellum illustrate` as a request: read a shape folder and its CT (without the table when
// asked), upload them ONCE, and draw one figure per style and view (illustration::
// IllustrationRenderer: several presets and views share the upload), framed on what each style
// draws and labelled with the segments that show; each figure written atomically under the
// output policy, or all of them as one plate.
#include <nlohmann/json.hpp>

#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "vellum/app/figures.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/illustration/figure.hpp"
#include "vellum/illustration/illustration_renderer.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/render/annotations.hpp"
#include "vellum/segmentation/body_mask.hpp"

namespace vellum::app {

struct IllustrateRequest {
  std::filesystem::path input;   ///< the CT the shape folder was made from
  std::filesystem::path shape;   ///< shape folder of `vellum shape`
  std::filesystem::path output;  ///< the figure (one style, one view), the stem of several, or the plate
  std::filesystem::path report;     ///< report JSON; empty: none
  std::filesystem::path saveStyle;  ///< also the style used as JSON (one style only); empty: none
  std::vector<std::string> presets;  ///< built-in styles, one figure each ...
  std::filesystem::path style;       ///< ... or one style file
  std::vector<FigureView> views;     ///< one figure each; empty: settings.render.camera
  /// All figures as one contact sheet at `output`: a row per style, a column per view (one
  /// row when there is one view).
  bool plate = false;
  /// Size, camera (zoom and pan on top of the framing), step, interpolation.
  illustration::IllustrationSettings settings;
  /// The lighting layer (docs/lighting.md, "Illustrations"): settings.render.lighting on (shadows,
  /// occlusion or tone map) multiplies each figure's colour by how much the ray caster's light
  /// volume darkens (or brightens) the CT drawn with this preset under the same camera. Off
  /// (the default): the figures are exactly those without it.
  render::Preset lightPreset = render::Preset::Bone;
  std::optional<std::array<float, 4>> background;  ///< empty: each style's own
  bool transparent = false;                        ///< background alpha 0
  illustration::Framing framing = illustration::Framing::Drawn;
  render::AnnotationOptions annotations;  ///< labels: name the segments each figure draws
  std::vector<uint16_t> labelIds;         ///< candidates to name (empty: every segment)
  io::LoadOptions load;                   ///< series, raw layout, region
  std::optional<segmentation::BodyMaskParams> removeTable;
  std::string commandLine;  ///< for the report's shared keys (run_report.hpp)
};

struct IllustrateFigure {
  std::filesystem::path path;  ///< the file (the plate's path for a plate's tile)
  std::string style, view;     ///< view "" without IllustrateRequest::views
  double renderMs = 0;         ///< the draw (glFinish-bounded)
};

struct IllustrateResult {
  std::vector<IllustrateFigure> figures;  ///< in order: style by style, view by view
  double uploadMs = 0;                    ///< the one scene upload
  nlohmann::json report;                  ///< what `report` holds
  std::vector<std::string> warnings;      ///< the CT load's
  std::string tableRemoval;  ///< --remove-table's one-line summary; empty without it
};

/// The room the annotations of a figure of `style` will take (labels: the texts of the
/// candidates the style draws). For framing: illustration::frameFigure's insets.
render::ImageInsets annotationRoom(const render::AnnotationOptions& annotations, const std::vector<uint16_t>& labelIds,
                                   const LabelVolume& segments, const illustration::Style& style,
                                   const render::RenderSettings& settings);

/// The files the request writes (figures or plate), in the order of IllustrateResult::figures.
/// A call with one style and one view writes `output`; several get "-STYLE" and/or "-VIEW"
/// suffixes for the axes that have more than one entry (app::figurePath).
std::vector<std::filesystem::path> illustrateOutputs(const IllustrateRequest& request);

/// Runs the request on a headless GL context. Throws vellum::Error / FileError (one line,
/// naming the file or flag), vellum::Cancelled through `progress` (between figures: a GL draw
/// cannot be interrupted); nothing of a failed run is left behind.
IllustrateResult runIllustrate(const IllustrateRequest& request, Progress& progress = Progress::none());

}  // namespace vellum::app
