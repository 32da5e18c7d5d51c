#include "studio_tools.hpp"

#include <imgui.h>

#include <algorithm>
#include <cstring>

#include "app.hpp"
#include "raw_dialog.hpp"
#include "vellum/core/error.hpp"

namespace vellum::studio {
namespace fs = std::filesystem;

void startFigureExport(StudioApp& app, const fs::path& out) {
  FigureExportState& f = app.studioTools().figure;
  if (f.job.busy()) throw Error("a figure is being exported: wait for it or cancel it");
  FigurePlan plan = planFigure(app.scene(), out, f.options);
  if (!plan.leftOut.empty()) {
    std::string what;
    for (const auto& w : plan.leftOut) what += (what.empty() ? "" : ", ") + w;
    app.notify("the figure leaves out " + what);
  }
  f.command = plan.command;
  f.lastError.clear();
  f.lastWritten.clear();
  f.job.start(std::move(plan));
}

std::string copyFigureCommand(StudioApp& app, const fs::path& out) {
  FigureExportState& f = app.studioTools().figure;
  f.command = planFigure(app.scene(), out, f.options).command;
  ImGui::SetClipboardText(f.command.c_str());  // glfwSetClipboardString through the GLFW backend
  return f.command;
}

void pollStudioTools(StudioApp& app) {
  FigureExportState& f = app.studioTools().figure;
  if (auto o = f.job.take()) {
    if (o->error.empty()) {
      f.lastWritten = o->path.string();
      char t[64];
      std::snprintf(t, sizeof t, " (%.1f s)", o->seconds);
      app.notify("figure written: " + f.lastWritten + t);
    } else {
      f.lastError = o->error;
      app.showError("Export figure: " + o->error);
    }
  }
}

namespace {

/// The 3D view's clipping box in mm along the volume's axes (RenderSettings::clipMin/Max, the
/// `--clip-min/--clip-max` fractions) and "this segment only" (`--only-label`); one undo step
/// per finished edit, like the View panel's widgets.
void clipSection(StudioApp& app) {
  Scene& s = app.scene();
  if (!s.hasVolume()) return;
  const ViewState before = s.viewState();
  const Geometry& g = s.ct.geometry();
  render::RenderSettings& r = s.render;
  bool started = false, finished = false;
  static const char* const kAxes[3] = {"Clip i (x)", "Clip j (y)", "Clip k (z)"};
  for (int a = 0; a < 3; ++a) {
    const size_t i = size_t(a);
    const float length = float(double(g.dims[a]) * g.spacing[a]);
    float lo = float(r.clipMin[i]) * length, hi = float(r.clipMax[i]) * length;
    if (ImGui::DragFloatRange2(kAxes[a], &lo, &hi, 0.5f, 0.f, length, "%.1f mm", "%.1f mm",
                               ImGuiSliderFlags_AlwaysClamp)) {
      const double voxel = 1.0 / double(g.dims[a]);  // the box keeps at least a voxel
      r.clipMin[i] = std::clamp(double(lo) / length, 0.0, 1.0 - voxel);
      r.clipMax[i] = std::clamp(double(hi) / length, r.clipMin[i] + voxel, 1.0);
    }
    started |= ImGui::IsItemActivated();
    finished |= ImGui::IsItemDeactivatedAfterEdit();
  }
  if (ImGui::SmallButton("Whole volume")) {
    app.beginViewEdit(before);
    r.clipMin = {0, 0, 0};
    r.clipMax = {1, 1, 1};
    app.endViewEdit("clip box");
  }
  // "Render this segment only": needs the label map (the label colours' texture).
  std::string current = r.onlyLabel == 0 ? "all" : std::to_string(r.onlyLabel);
  for (const Label& l : s.labels.table())
    if (l.id == r.onlyLabel) current = l.name;
  if (ImGui::BeginCombo("3D: only segment", current.c_str())) {
    int pick = -1;
    if (ImGui::Selectable("all", r.onlyLabel == 0)) pick = 0;
    for (const Label& l : s.labels.table())
      if (l.id != 0 && ImGui::Selectable((l.name + "##only" + std::to_string(l.id)).c_str(), l.id == r.onlyLabel)) pick = l.id;
    ImGui::EndCombo();
    if (pick >= 0 && pick != r.onlyLabel) {
      app.beginViewEdit(before);
      r.onlyLabel = pick;
      app.endViewEdit("only segment");
    }
  }
  if (started) app.beginViewEdit(before);
  if (finished) app.endViewEdit("clip box");
}

}  // namespace

void studioToolsSection(StudioApp& app) {
  clipSection(app);
  ImGui::TextUnformatted("Measure in the slices:");
  app.studioTools().measure.drawPanel();
  if (ImGui::Button("Export figure...") && app.scene().hasVolume()) app.studioTools().figure.dialogOpen = true;
  ImGui::SameLine();
  rawOpenButton(app);
}

void drawFigureDialog(StudioApp& app) {
  drawRawDialog(app);
  FigureExportState& f = app.studioTools().figure;
  if (!f.dialogOpen) return;
  ImGui::SetNextWindowSize({520, 0}, ImGuiCond_Appearing);
  if (!ImGui::Begin("Export figure", &f.dialogOpen, ImGuiWindowFlags_NoCollapse)) {
    ImGui::End();
    return;
  }
  ImGui::TextWrapped("Writes what the 3D view shows through the CLI's own renderer (vellum render, or vellum "
                     "illustrate for an illustration).");
  ImGui::InputText("Path", f.path, sizeof f.path);
  int size[2] = {f.options.width, f.options.height};
  if (ImGui::InputInt2("Size (px)", size)) {
    f.options.width = std::clamp(size[0], 1, 4096);
    f.options.height = std::clamp(size[1], 1, 4096);
  }
  ImGui::Checkbox("Scale bar", &f.options.scaleBar);
  ImGui::SameLine();
  ImGui::Checkbox("Orientation", &f.options.orientation);
  ImGui::SameLine();
  ImGui::Checkbox("Structure labels", &f.options.labels);
  if (f.job.busy()) {
    const auto [stage, fraction] = f.job.progress();
    ImGui::TextUnformatted(stage.c_str());
    ImGui::ProgressBar(static_cast<float>(fraction), {-70, 0});
    ImGui::SameLine();
    if (ImGui::Button("Cancel##figure")) f.job.cancel();
  } else if (ImGui::Button("Export")) {
    guarded(app, [&] { startFigureExport(app, f.path); });
  }
  ImGui::SameLine();
  if (ImGui::Button("Copy CLI command")) guarded(app, [&] { copyFigureCommand(app, f.path); });
  // The command, selectable for copying by hand too.
  std::vector<char> text(f.command.begin(), f.command.end());
  text.push_back('\0');
  ImGui::InputTextMultiline("##command", text.data(), text.size(), {-1, 60}, ImGuiInputTextFlags_ReadOnly);
  if (!f.lastWritten.empty()) ImGui::TextWrapped("written: %s", f.lastWritten.c_str());
  ImGui::End();
}

}  // namespace vellum::studio
