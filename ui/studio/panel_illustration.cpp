#include "panel_illustration.hpp"

#include <imgui.h>

#include "app.hpp"
#include "param_widgets.hpp"

namespace vellum::studio {

namespace {

void shapesSection(StudioApp& app) {
  Scene& s = app.scene();
  ShapeJob& job = app.shapeJob();
  if (job.busy()) {
    const auto [stage, fraction] = job.progress();
    ImGui::TextUnformatted(stage.c_str());
    ImGui::ProgressBar(static_cast<float>(fraction), {-70, 0});
    ImGui::SameLine();
    if (ImGui::Button("Cancel##shapes")) job.cancel();
    return;
  }
  if (ImGui::Button("Make shapes from labels")) guarded(app, [&] { app.makeShapes(); });
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("vellum shape with one segment per label: denoised level sets, distance field, segmentation");
  static char folder[512] = "";
  ImGui::InputTextWithHint("##shapefolder", "vellum shape folder", folder, sizeof folder);
  ImGui::SameLine();
  if (ImGui::Button("Open##shapes") && folder[0]) guarded(app, [&] { app.makeShapes(folder); });
  if (s.shapes)
    ImGui::Text("%zu segments (%s)", s.shapes->segments.table().size(),
                s.shapesPath.empty() ? "from the labels" : s.shapesPath.filename().string().c_str());
  else
    ImGui::TextDisabled("no shapes yet");
}

void styleSection(StudioApp& app) {
  Scene& s = app.scene();
  illustration::Style& style = s.illustration.style;
  const ViewState before = s.viewState();
  if (ImGui::BeginCombo("Style preset", style.name.c_str())) {
    for (const auto& name : illustration::stylePresetNames())
      if (ImGui::Selectable(name.c_str(), name == style.name)) guarded(app, [&] { app.setStylePreset(name); });
    ImGui::EndCombo();
  }
  ParamEdit e;
  if (ImGui::TreeNode("Whole style")) {
    e |= editParams(illustration::styleTable(), style, {"name", "description", "texture_volume"});
    ImGui::TreePop();
  }
  // One node per segment of the shapes; opening one gives the segment its own row.
  std::vector<std::string> rows{"default", "unclassified"};
  if (s.shapes)
    for (const Label& l : s.shapes->segments.table()) rows.insert(rows.end() - 2, l.name);
  for (const std::string& name : rows) {
    if (!ImGui::TreeNode(name.c_str())) continue;
    ViewState beforeRow = s.viewState();
    illustration::SegmentStyle& row = ownStyleRow(style, name);
    if (!(s.viewState() == beforeRow)) {  // a new row: its own undo step
      app.beginViewEdit(beforeRow);
      app.endViewEdit("style row " + name);
    }
    e |= editParams(illustration::segmentStyleTable(), row, {"match"});
    ImGui::TreePop();
  }
  if (e.started) app.beginViewEdit(before);
  if (e.finished) app.endViewEdit("style");
}

/// "Meshes in 3D view": the view-settings table's meshes_3d field alone (one description for
/// the widget, the scene key and the script's `set`).
void meshesToggle(StudioApp& app) {
  Scene& s = app.scene();
  std::vector<std::string> others;
  for (const auto& f : viewSettingsTable())
    if (f.key != "meshes_3d") others.push_back(f.key);
  const ViewState before = s.viewState();
  ImGui::BeginDisabled(!s.shapeMeshes || s.shapeMeshes->empty());
  const ParamEdit e = editParams(viewSettingsTable(), s.view, others);
  ImGui::EndDisabled();
  if (s.shapeMeshes) ImGui::SameLine(), ImGui::TextDisabled("(%zu meshes)", s.shapeMeshes->size());
  if (e.started) app.beginViewEdit(before);
  if (e.finished) app.endViewEdit("meshes in 3D view");
}

/// Curve analogy by drawing: trace C0 over the 3D view (or load a drawing), pick the structure
/// (and what it carries), Apply: a new shape folder, one undo step.
void curveSection(StudioApp& app) {
  Scene& s = app.scene();
  CurveTool& c = app.curves().state();
  if (!ImGui::TreeNode("Curve analogy")) return;
  if (s.shapesPath.empty() || !s.shapeMeshes || s.shapeMeshes->empty()) {
    ImGui::TextDisabled("needs shapes opened from a vellum shape folder");
    ImGui::TreePop();
    return;
  }
  if (c.busy()) {
    ImGui::TextUnformatted("bending ... (vellum curve-analogy)");
    ImGui::TreePop();
    return;
  }
  if (ImGui::BeginCombo("Structure", c.segment.empty() ? "(pick)" : c.segment.c_str())) {
    for (const auto& m : *s.shapeMeshes)
      if (ImGui::Selectable(m.name.c_str(), m.name == c.segment)) c.segment = m.name;
    ImGui::EndCombo();
  }
  if (ImGui::TreeNode("Carried along")) {
    for (const auto& m : *s.shapeMeshes) {
      if (m.name == c.segment) continue;
      bool on = c.transfer.count(m.name) != 0;
      if (ImGui::Checkbox(m.name.c_str(), &on)) on ? (void)c.transfer.insert(m.name) : (void)c.transfer.erase(m.name);
    }
    ImGui::TreePop();
  }
  bool tracing = c.tracing;
  if (ImGui::Checkbox("Trace C0", &tracing)) app.curves().setTracing(tracing);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("left-drag in the 3D view draws the outline the structure should follow (plate view: orthographic)");
  static char drawing[512] = "";
  ImGui::InputTextWithHint("##drawing", "drawing (PNG)", drawing, sizeof drawing);
  ImGui::SameLine();
  if (ImGui::Button("Load##drawing") && drawing[0]) guarded(app, [&] { app.curves().loadDrawing(drawing); });
  ImGui::Text("C0: %zu points%s", c.c0.size(), c.drawing.empty() ? "" : " (drawing)");
  ImGui::SameLine();
  if (ImGui::SmallButton("Clear")) c.c0.clear(), c.drawing.clear();
  ImGui::BeginDisabled(c.c0.size() < 3 || c.segment.empty());
  if (ImGui::Button("Apply curve analogy")) guarded(app, [&] { app.curves().apply(); });
  ImGui::EndDisabled();
  ImGui::TreePop();
}

}  // namespace

void illustrationSection(StudioApp& app) {
  Scene& s = app.scene();
  shapesSection(app);
  bool on = s.illustration.enabled;
  ImGui::BeginDisabled(!s.shapes);
  if (ImGui::Checkbox("Illustrate the 3D view", &on)) app.setIllustration(on);
  ImGui::EndDisabled();
  meshesToggle(app);
  styleSection(app);
  curveSection(app);
}

}  // namespace vellum::studio
