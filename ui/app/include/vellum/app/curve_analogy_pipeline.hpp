#pragma once
// The curve analogy as one request and one run ([SAVI 2.3] in docs/references.md): a shape
// folder's segment bent toward an illustrator's outline C0, other segments carried along,
// the distance and segmentation volumes rebuilt, optionally the CT backward map. Run by
// `vellum curve-analogy` and by the studio's Illustration panel.
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "vellum/core/progress.hpp"
#include "vellum/illustration/curve.hpp"
#include "vellum/render/render_settings.hpp"

namespace vellum::app {

struct CurveAnalogyRequest {
  std::filesystem::path dir;  ///< input shape folder (`vellum shape`; PLY meshes)
  std::filesystem::path out;  ///< output shape folder (+ curve_analogy/); never the input
  std::filesystem::path mapOut;  ///< CT backward map NRRD; empty: none
  std::filesystem::path report;  ///< also the report JSON here; empty: none
  std::string commandLine;       ///< for the report's shared keys (run_report.hpp)
  std::string segment;           ///< the segment whose outline follows C0
  std::vector<std::string> transfer;  ///< segments carried by the cage (comma lists allowed)
  illustration::Polyline2 curve;      ///< C0 in pixels of `view` (x right, y down)
  std::string curveSource;            ///< what the report names as C0 (a file, "studio trace")
  render::RenderSettings view;        ///< camera and image size that C0's pixels refer to
  int samples = 200, anchors = 4, mapStep = 4;
  double lambda = 10.0;
  int64_t proxyFaces = 2000;
  bool force = false;  ///< `out` may replace a Vellum folder of another kind
};

struct CurveAnalogyResult {
  nlohmann::json shape;   ///< the output's shape.json (segments with their mesh checks)
  nlohmann::json report;  ///< its "curve_analogy" entry (Hausdorff before/after, timings ...)
};

/// Runs the request; throws vellum::Error (one line, naming the file or field) for a missing
/// folder, an unknown segment, C0 with fewer than 3 points, or an output that is the input;
/// vellum::Cancelled through `progress` between its stages (load, bend, volumes, map, write).
CurveAnalogyResult runCurveAnalogy(const CurveAnalogyRequest& request, Progress& progress = Progress::none());

}  // namespace vellum::app
