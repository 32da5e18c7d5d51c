// CurveController: curve analogy by drawing ([SAVI 2.3] in docs/references.md). C0 is traced
// with the mouse over the 3D view in the plate view `vellum curve-analogy` uses, or taken from
// a drawing's outline; Apply runs the command's pipeline (app::runCurveAnalogy) on a worker
// into a new shape folder beside the current one, which then becomes the scene's shapes.
#include "curve_controller.hpp"

#include <imgui.h>

#include <chrono>
#include <cmath>
#include <iostream>

#include "app.hpp"
#include "curve_tool.hpp"
#include "vellum/core/error.hpp"
#include "vellum/illustration/curve_analogy.hpp"

namespace vellum::studio {
namespace fs = std::filesystem;

fs::path nextCurveFolder(const fs::path& folder) {
  const fs::path base = folder.has_filename() ? folder : folder.parent_path();
  for (int n = 1;; ++n) {
    fs::path candidate = base.parent_path() / (base.filename().string() + "-curve-" + std::to_string(n));
    if (!fs::exists(candidate)) return candidate;
  }
}

render::RenderSettings CurveController::plateView(int w, int h) const {
  render::RenderSettings s = app_.scene().render;
  s.width = w;
  s.height = h;
  s.camera.fieldOfViewDeg = 0;  // an illustration plate has no perspective
  s.camera.zoom = 1.0;
  s.camera.panMm = {0, 0, 0};
  return s;
}

void CurveController::setTracing(bool on) {
  curve_.tracing = on;
  curve_.stroke = false;
  if (!on) return;
  render::Camera& c = app_.scene().render.camera;  // show what C0 will be matched against
  c.fieldOfViewDeg = 0;
  c.zoom = 1.0;
  c.panMm = {0, 0, 0};
  app_.invalidate3d();
}

void CurveController::loadDrawing(const fs::path& path) {
  int w = 0, h = 0;
  illustration::Polyline2 c0 = illustration::loadDrawingOutline(path, w, h);
  curve_.c0 = std::move(c0);
  curve_.viewWidth = w;
  curve_.viewHeight = h;
  curve_.drawing = path;
  setTracing(false);
  render::Camera& c = app_.scene().render.camera;  // the drawing is a plate view at its own size
  c.fieldOfViewDeg = 0;
  c.zoom = 1.0;
  c.panMm = {0, 0, 0};
  app_.invalidate3d();
}

void CurveController::apply() {
  const Scene& scene = app_.scene();
  if (curve_.busy()) throw Error("a curve analogy is already running");
  if (scene.shapesPath.empty())
    throw Error("curve analogy needs shapes from a `vellum shape` folder (File > shapes, or make them and save)");
  if (curve_.segment.empty()) throw Error("pick the structure to bend");
  app::CurveAnalogyRequest r;
  r.dir = scene.shapesPath;
  r.out = nextCurveFolder(scene.shapesPath);
  r.segment = curve_.segment;
  r.transfer.assign(curve_.transfer.begin(), curve_.transfer.end());
  r.curve = curve_.c0;
  r.curveSource = curve_.drawing.empty() ? std::string("studio trace") : curve_.drawing.string();
  r.view = plateView(curve_.viewWidth, curve_.viewHeight);
  if (r.curve.size() < 3) throw Error("trace C0 over the 3D view, or load a drawing, first");
  curve_.jobBefore = r.dir;
  curve_.jobOut = r.out;
  curve_.lastError.clear();
  curve_.job = std::async(std::launch::async, [r] { return app::runCurveAnalogy(r); });
}

void CurveController::poll() {
  if (!curve_.busy() || curve_.job.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return;
  try {
    curve_.job.get();
  } catch (const std::exception& e) {
    curve_.job = {};
    curve_.lastError = e.what();
    std::cerr << "vellum-studio: " << curve_.lastError << "\n";
    app_.showError(curve_.lastError);
    return;
  }
  curve_.job = {};
  app_.undoStack().push(ShapesEdit{"curve analogy", curve_.jobBefore, curve_.jobOut});
  curve_.c0.clear();
  curve_.drawing.clear();
  app_.makeShapes(curve_.jobOut);
}

void CurveController::draw(const Pane& pane) const {
  if (curve_.c0.size() < 2 || curve_.viewWidth <= 0 || curve_.viewHeight <= 0) return;
  // C0's image (viewWidth x viewHeight) fitted into the pane by height, centred: the plate
  // view frames the volume by the image height.
  const double s = pane.rect.h / curve_.viewHeight;
  const double ox = pane.rect.x + (pane.rect.w - curve_.viewWidth * s) / 2, oy = pane.rect.y;
  ImDrawList* dl = ImGui::GetBackgroundDrawList();
  std::vector<ImVec2> pts;
  pts.reserve(curve_.c0.size());
  for (const auto& p : curve_.c0) pts.push_back({float(ox + p.x * s), float(oy + p.y * s)});
  dl->AddPolyline(pts.data(), int(pts.size()), IM_COL32(255, 140, 0, 255), curve_.stroke ? 0 : ImDrawFlags_Closed, 2.0f);
}

bool CurveController::beginStroke(const Pane& pane, double x, double y) {
  if (!curve_.tracing || !pane.is3d()) return false;
  curve_.stroke = true;
  curve_.drawing.clear();
  curve_.c0 = {{x - pane.rect.x, y - pane.rect.y}};
  curve_.viewWidth = int(pane.rect.w);
  curve_.viewHeight = int(pane.rect.h);
  return true;
}

bool CurveController::extendStroke(const Pane& pane, double x, double y) {
  if (!curve_.stroke) return false;
  // Tracing C0 in the 3D view's pixels.
  const illustration::Point2 q{x - pane.rect.x, y - pane.rect.y};
  if (curve_.c0.empty() || std::hypot(q.x - curve_.c0.back().x, q.y - curve_.c0.back().y) >= 1.0) curve_.c0.push_back(q);
  return true;
}

}  // namespace vellum::studio
