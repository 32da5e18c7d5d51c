#pragma once
// The curve-tracing controller: owns the Illustration panel's curve analogy by drawing (the
// CurveTool state: C0, the structure, the job) and its commands. StudioApp hands it the left
// drags in the 3D view while tracing, polls it every frame and lets it draw C0 over the 3D
// pane; the panel and the script's "curve_analogy" call it through StudioApp::curves().
#include <filesystem>

#include "curve_tool.hpp"
#include "layout.hpp"
#include "vellum/render/render_settings.hpp"

namespace vellum::studio {

class StudioApp;

class CurveController {
 public:
  explicit CurveController(StudioApp& app) : app_(app) {}

  /// The tool's state (C0, the structure and what it carries, the job), for the panel.
  CurveTool& state() { return curve_; }
  const CurveTool& state() const { return curve_; }
  bool busy() const { return curve_.busy(); }

  /// Tracing on/off (on sets the plate view), a drawing's outline as C0, and Apply:
  /// app::runCurveAnalogy on a worker into `<shapes>-curve-N`, loaded as the scene's shapes
  /// when done, one undo step.
  void setTracing(bool on);
  void loadDrawing(const std::filesystem::path& path);
  void apply();
  /// Adopts a finished job (every frame).
  void poll();
  /// C0 over the 3D pane.
  void draw(const Pane& pane) const;

  // Input (window pixels): a left press in the 3D view while tracing starts a new C0 (true:
  // the press was the trace's); the pointer extends it while the button is down (true: it did);
  // the release ends it.
  bool beginStroke(const Pane& pane, double x, double y);
  bool extendStroke(const Pane& pane, double x, double y);
  void endStroke() { curve_.stroke = false; }

 private:
  /// The plate view at w x h: the scene's azimuth and elevation, orthographic, zoom 1, no pan.
  render::RenderSettings plateView(int w, int h) const;

  StudioApp& app_;
  CurveTool curve_;
};

}  // namespace vellum::studio
