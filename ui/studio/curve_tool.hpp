#pragma once
// The Illustration panel's curve analogy by drawing: C0 traced with the mouse over the 3D
// view (or the outline of a loaded drawing), the structure to bend, and the job that runs
// app::runCurveAnalogy (what `vellum curve-analogy` runs) into a new shape folder.
#include <filesystem>
#include <future>
#include <set>
#include <string>

#include "vellum/app/curve_analogy_pipeline.hpp"
#include "vellum/illustration/curve.hpp"

namespace vellum::studio {

struct CurveTool {
  /// Left drags in the 3D view draw C0 instead of orbiting. Turning it on sets the plate view
  /// `vellum curve-analogy` uses: orthographic, zoom 1, centred (azimuth and elevation kept).
  bool tracing = false;
  bool stroke = false;         ///< a trace in progress (button down)
  illustration::Polyline2 c0;  ///< in pixels of a viewWidth x viewHeight image of the plate view
  int viewWidth = 0, viewHeight = 0;
  std::filesystem::path drawing;  ///< C0's drawing, if it came from one
  std::string segment;            ///< the structure to bend
  std::set<std::string> transfer;  ///< structures carried along

  std::future<app::CurveAnalogyResult> job;
  std::filesystem::path jobBefore, jobOut;  ///< the shape folders the job goes from and to
  std::string lastError;
  bool busy() const { return job.valid(); }
};

/// `<folder>-curve-N` beside `folder`, the first N that does not exist.
std::filesystem::path nextCurveFolder(const std::filesystem::path& folder);

}  // namespace vellum::studio
