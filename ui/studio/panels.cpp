#include "panels.hpp"

#include <imgui.h>

#include <algorithm>
#include <cstring>
#include <functional>

#include "app.hpp"
#include "mpr.hpp"
#include "panel_deformation.hpp"
#include "joint_tool.hpp"
#include "panel_illustration.hpp"
#include "param_widgets.hpp"
#include "studio_tools.hpp"
#include "vellum/segmentation/threshold.hpp"

namespace vellum::studio {
namespace fs = std::filesystem;
namespace seg = vellum::segmentation;

namespace {

void fileSection(StudioApp& app) {
  Scene& s = app.scene();
  if (ImGui::Button("Open...")) {
    app.fileBrowser().open(FileBrowser::Mode::Open, "Open volume or scene",
                           [&app](const fs::path& p) { app.requestOpen(p); });
  }
  ImGui::SameLine();
  if (ImGui::Button("Save scene")) app.saveSceneOrAsk();
  ImGui::SameLine();
  if (ImGui::Button("Save as...") && s.hasVolume())
    app.fileBrowser().open(FileBrowser::Mode::Save, "Save scene as",
                           [&app](const fs::path& p) { guarded(app, [&] { app.saveScene(p); }); });
  ImGui::SameLine();
  if (ImGui::Button("Quit")) app.requestClose();  // asks about unsaved changes
  if (ImGui::Button("Save labels...") && s.hasVolume())
    app.fileBrowser().open(FileBrowser::Mode::Save, "Save label map as",
                           [&app](const fs::path& p) { guarded(app, [&] { app.saveLabels(p); }); });
  ImGui::SameLine();
  if (ImGui::Button("Open labels...") && s.hasVolume())
    app.fileBrowser().open(FileBrowser::Mode::Open, "Open label map", [&app](const fs::path& p) {
      app.requestOpen(app.scene().volumePath, p);
    });
  if (!app.recentFiles().empty() && ImGui::BeginCombo("Recent", "open a recent file")) {
    for (const fs::path& p : app.recentFiles())
      if (ImGui::Selectable(p.string().c_str())) app.requestOpen(p);
    ImGui::EndCombo();
  }
  if (s.series.size() > 1) {  // DICOM folder with several series: pick one to load
    auto describe = [](const io::SeriesInfo& i) {
      return i.modality + " " + std::to_string(i.frames) + " slices " + std::to_string(i.columns) + "x" +
             std::to_string(i.rows) + "  " + i.description;
    };
    std::string current = "?";
    for (const auto& i : s.series)
      if (i.uid == s.seriesUid) current = describe(i);
    if (ImGui::BeginCombo("Series", current.c_str())) {
      for (const auto& i : s.series)
        if (ImGui::Selectable((describe(i) + "##" + i.uid).c_str(), i.uid == s.seriesUid))
          app.requestOpen(s.volumePath, {}, i.uid);
      ImGui::EndCombo();
    }
  }
  if (app.loading()) {
    const auto [stage, fraction] = app.loader().progress();
    ImGui::TextUnformatted(stage.c_str());
    ImGui::ProgressBar(static_cast<float>(fraction), {-70, 0});
    ImGui::SameLine();
    if (ImGui::Button("Cancel")) app.loader().cancel();
  }
  if (s.hasVolume()) {
    ImGui::TextWrapped("Volume: %s", s.volumePath.filename().string().c_str());
    ImGui::Text("%s  %.2f x %.2f x %.2f mm", s.ct.geometry().dims.str().c_str(), s.ct.geometry().spacing.x,
                s.ct.geometry().spacing.y, s.ct.geometry().spacing.z);
  } else {
    ImGui::TextWrapped("No volume. Open a file, drop one on the window, or pass it on the command line.");
  }
}

void helpSection() {
  if (!ImGui::BeginTable("shortcuts", 2, ImGuiTableFlags_BordersInnerH | ImGuiTableFlags_SizingStretchProp)) return;
  for (const Shortcut& s : shortcuts()) {
    ImGui::TableNextRow();
    ImGui::TableNextColumn();
    ImGui::TextUnformatted(s.keys);
    ImGui::TableNextColumn();
    ImGui::TextWrapped("%s", s.what);
  }
  ImGui::EndTable();
}

void bookmarksSection(StudioApp& app) {
  Scene& s = app.scene();
  static char name[64] = "";
  ImGui::SetNextItemWidth(120);
  ImGui::InputTextWithHint("##bookmark", "name", name, sizeof name);
  ImGui::SameLine();
  if (ImGui::Button("Bookmark camera")) {
    app.addBookmark(name);
    name[0] = '\0';
  }
  for (size_t i = 0; i < s.bookmarks.size(); ++i) {
    ImGui::PushID(static_cast<int>(i));
    if (ImGui::Button(s.bookmarks[i].name.c_str())) app.goToBookmark(i);
    ImGui::SameLine();
    if (ImGui::SmallButton("x")) app.deleteBookmark(i);
    ImGui::PopID();
    if (i + 1 < s.bookmarks.size() && (i + 1) % 3 != 0) ImGui::SameLine();
  }
}

void viewSection(StudioApp& app) {
  Scene& s = app.scene();
  // Every widget here comes from the parameter tables the scene file and `vellum render`
  // use; one undo step per finished edit.
  const ViewState before = s.viewState();
  ImGui::PushItemWidth(ImGui::GetContentRegionAvail().x * 0.5f);  // room for "Field of view (degrees)"
  ParamEdit e = editParams(viewSettingsTable(), s.view, {"meshes_3d"});  // in the Illustration panel
  if (ImGui::TreeNodeEx("3D view (vellum render)", ImGuiTreeNodeFlags_DefaultOpen)) {
    e |= editParams(render::renderSettingsTable(), s.render, renderKeysNotInScene());
    ImGui::TreePop();
  }
  ImGui::PopItemWidth();
  if (e.started) app.beginViewEdit(before);
  if (e.finished) app.endViewEdit("view settings");
  ImGui::TextUnformatted("Slice window:");
  for (const WindowPreset& p : windowPresets()) {
    // On the same line while it fits the panel, else on the next.
    const float room = ImGui::GetWindowPos().x + ImGui::GetWindowContentRegionMax().x;
    if (ImGui::GetItemRectMax().x + ImGui::GetStyle().ItemSpacing.x + ImGui::CalcTextSize(p.name).x +
            2 * ImGui::GetStyle().FramePadding.x < room)
      ImGui::SameLine();
    if (ImGui::SmallButton(p.name)) guarded(app, [&] { app.setWindowPreset(p.name); });
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("centre %.0f HU, width %.0f HU", p.center, p.width);
  }
  bookmarksSection(app);
  if (ImGui::Button("Reset view (R)")) app.resetView();
  ImGui::SameLine();
  ImGui::Checkbox("HUD", &app.hudVisible);
  ImGui::SameLine();
  if (ImGui::Button("Copy CLI command") && s.hasVolume()) {
    // What `vellum render` needs to write the 3D view as a figure (same renderer, same pixels).
    ImGui::SetClipboardText(app.cliCommand("figure.png").c_str());
  }
  if (ImGui::IsItemHovered() && s.hasVolume()) ImGui::SetTooltip("%s", app.cliCommand("figure.png").c_str());
}

void segmentationSection(StudioApp& app) {
  ToolState& t = app.segmentation().tools();
  static int presetIndex = 0;
  const auto presets = seg::allPresets();
  if (ImGui::BeginCombo("HU preset", seg::presetName(presets[static_cast<size_t>(presetIndex)]))) {
    for (size_t n = 0; n < presets.size(); ++n)
      if (ImGui::Selectable(seg::presetName(presets[n]), int(n) == presetIndex)) {
        presetIndex = int(n);
        t.threshold = seg::presetInterval(presets[n]);
      }
    ImGui::EndCombo();
  }
  float range[2] = {float(t.threshold.lower), float(t.threshold.upper)};
  if (ImGui::DragFloat2("HU range", range, 5.f, -1024.f, 3071.f)) t.threshold = {range[0], range[1]};
  ImGui::Checkbox("Preview", &t.thresholdPreview);
  ImGui::SameLine();
  if (ImGui::Button("Otsu")) guarded(app, [&] { app.segmentation().otsuThreshold(); });
  ImGui::SameLine();
  if (ImGui::Button("Apply threshold")) guarded(app, [&] { app.segmentation().applyThreshold(); });
  if (ImGui::Button("Keep largest")) guarded(app, [&] { app.segmentation().keepLargestOfActive(); });
  ImGui::SameLine();
  if (ImGui::Button("Fill holes")) guarded(app, [&] { app.segmentation().fillHolesOfActive(); });
  if (ImGui::Button("Remove islands <")) guarded(app, [&] { app.segmentation().removeIslandsOfActive(); });
  ImGui::SameLine();
  ImGui::SetNextItemWidth(-40);
  ImGui::DragFloat("mm3", &t.minIslandMm3, 10.f, 0.f, 1e7f, "%.0f");
  for (Morphology op : {Morphology::Dilate, Morphology::Erode, Morphology::Open, Morphology::Close}) {
    if (op != Morphology::Dilate) ImGui::SameLine();
    if (ImGui::Button(morphologyName(op))) guarded(app, [&] { app.segmentation().morphologyOfActive(op); });
  }
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("ball of the brush radius, on the active label");
  int tool = static_cast<int>(t.tool);
  ImGui::RadioButton("Navigate", &tool, 0);
  ImGui::SameLine();
  ImGui::RadioButton("Paint", &tool, 1);
  ImGui::SameLine();
  ImGui::RadioButton("Erase", &tool, 2);
  ImGui::RadioButton("Grow", &tool, 3);
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("click a seed in a slice: region growing within the HU range");
  ImGui::SameLine();
  ImGui::RadioButton("Snake", &tool, 4);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("click a seed in a slice: 3D level-set snake from a bubble of the brush radius,\n"
                      "inside = the HU range (e.g. the soft-tissue preset); Escape cancels");
  if (ImGui::TreeNode("Snake settings (vellum segment)")) {
    // Generated from the request table `vellum segment --method snake` takes its flags from.
    editParams(app::segmentSettingsTable(), app.segmentation().tools().snake,
               {"method", "preset", "lower", "upper", "strong", "classes", "radius", "multiplier"});
    ImGui::TreePop();
  }
  if (app.segmentation().snake().busy()) {
    const auto [stage, fraction] = app.segmentation().snake().progress();
    ImGui::TextUnformatted(stage.c_str());
    ImGui::ProgressBar(static_cast<float>(fraction), {-70, 0});
    ImGui::SameLine();
    if (ImGui::Button("Cancel##snake")) app.segmentation().snake().cancel();
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("stops; after the coarse levels their contour is kept (Ctrl+Z drops it)");
    // ITK-SNAP's habit: pause to look, accept the contour as it is.
    const bool paused = app.segmentation().snake().pauseRequested();
    if (ImGui::Button(paused ? "Resume##snake" : "Pause##snake")) app.segmentation().snake().setPaused(!paused);
    ImGui::SameLine();
    if (ImGui::Button("Accept current##snake")) app.segmentation().snake().acceptCurrent();
  }
  t.tool = static_cast<Tool>(tool);
  ImGui::SliderFloat("Brush radius (mm)", &t.brushRadiusMm, 0.5f, 30.f, "%.1f");
  if (ImGui::Button("Undo (Ctrl+Z)")) app.undo();
  ImGui::SameLine();
  if (ImGui::Button("Redo (Ctrl+Shift+Z)")) app.redo();
}

void labelTable(StudioApp& app) {
  Scene& s = app.scene();
  ToolState& t = app.segmentation().tools();
  int active = t.activeLabel;
  if (ImGui::InputInt("Active label", &active)) t.activeLabel = static_cast<uint16_t>(std::clamp(active, 1, 65535));
  if (ImGui::Button("New label")) t.activeLabel = s.labels.nextFreeId();
  if (!ImGui::BeginTable("labels", 5, ImGuiTableFlags_Borders | ImGuiTableFlags_ScrollY, {0, 180})) return;
  ImGui::TableSetupColumn("id", ImGuiTableColumnFlags_WidthFixed, 28);
  ImGui::TableSetupColumn("show", ImGuiTableColumnFlags_WidthFixed, 28);
  ImGui::TableSetupColumn("lock", ImGuiTableColumnFlags_WidthFixed, 28);
  ImGui::TableSetupColumn("colour", ImGuiTableColumnFlags_WidthFixed, 28);
  ImGui::TableSetupColumn("name");
  // A worker reads the label map (and its table) while tasks run: names and colours wait.
  const bool frozen = app.labelsFrozen();
  for (Label l : s.labels.table()) {  // by value: edits go back through setLabel
    ImGui::TableNextRow();
    ImGui::PushID(l.id);
    ImGui::TableNextColumn();
    if (ImGui::Selectable(std::to_string(l.id).c_str(), l.id == t.activeLabel))
      t.activeLabel = l.id;
    ImGui::TableNextColumn();
    bool visible = !s.hiddenLabels.count(l.id);
    if (ImGui::Checkbox("##v", &visible)) visible ? (void)s.hiddenLabels.erase(l.id) : (void)s.hiddenLabels.insert(l.id);
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("visible");
    ImGui::TableNextColumn();
    bool locked = s.lockedLabels.count(l.id);
    if (ImGui::Checkbox("##l", &locked)) locked ? (void)s.lockedLabels.insert(l.id) : (void)s.lockedLabels.erase(l.id);
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("locked: no edit changes this segment");
    ImGui::TableNextColumn();
    float rgb[3] = {l.rgb[0] / 255.f, l.rgb[1] / 255.f, l.rgb[2] / 255.f};
    ImGui::BeginDisabled(frozen);
    bool changed = ImGui::ColorEdit3("##c", rgb, ImGuiColorEditFlags_NoInputs);
    ImGui::TableNextColumn();
    char name[128];
    std::strncpy(name, l.name.c_str(), sizeof name - 1);
    name[sizeof name - 1] = '\0';
    ImGui::SetNextItemWidth(-1);
    changed |= ImGui::InputText("##n", name, sizeof name);
    ImGui::EndDisabled();
    if (changed) {
      for (int c = 0; c < 3; ++c) l.rgb[static_cast<size_t>(c)] = static_cast<uint8_t>(std::lround(rgb[c] * 255));
      l.name = name;
      s.labels.setLabel(l);
      s.touchLabels();
    }
    ImGui::PopID();
  }
  ImGui::EndTable();
}

// The queued edits: the running one with its progress and Cancel, how many wait.
void runningSection(StudioApp& app) {
  TaskQueue& tasks = app.tasks();
  if (tasks.running().empty()) return;
  const auto [stage, fraction] = tasks.progress();
  ImGui::TextColored({0.6f, 0.85f, 1.f, 1.f}, "Running: %s%s", tasks.running().c_str(),
                     tasks.waiting() ? (" (" + std::to_string(tasks.waiting()) + " queued)").c_str() : "");
  ImGui::ProgressBar(static_cast<float>(fraction), {-70, 0});
  ImGui::SameLine();
  if (ImGui::Button("Cancel##task")) tasks.cancel();
  ImGui::Separator();
}

}  // namespace

const std::vector<Shortcut>& shortcuts() {
  static const std::vector<Shortcut> list = {
      {"Ctrl+O", "open a volume, DICOM folder or scene"},
      {"Ctrl+S", "save the scene (asks for a file the first time)"},
      {"Ctrl+Q", "quit (asks about unsaved changes)"},
      {"Ctrl+Z / Ctrl+Shift+Z, Ctrl+Y", "undo / redo (queued behind running edits)"},
      {"Escape", "cancel what runs (export, edit, snake, load); else the Navigate tool"},
      {"1 / 2 / 3", "layout: 3D / 2x2 / 1x3"},
      {"R", "reset the camera, the crosshair and every slice view"},
      {"F", "fit the slice view under the pointer"},
      {"wheel (slice)", "move through the slices"},
      {"Ctrl+wheel, Ctrl+right-drag (slice)", "zoom about the pointer"},
      {"middle-drag (slice)", "pan"},
      {"right-drag (slice)", "window/level"},
      {"left-drag (slice)", "move the crosshair (Navigate) or paint / erase"},
      {"left-drag (3D)", "orbit; Shift+left or middle: pan; wheel: zoom"},
      {"Ctrl+click (3D)", "crosshair, or a Grow / Snake seed, on the visible surface"},
      {"drag a dot", "move a control point (Shift: along one axis)"},
  };
  return list;
}

void drawToolPanel(StudioApp& app, float width, float height) {
  ImGui::SetNextWindowPos({0, 0}, ImGuiCond_Always);
  ImGui::SetNextWindowSize({width, height}, ImGuiCond_Always);
  ImGui::Begin("Vellum Studio", nullptr,
               ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse);
  ImGui::PushItemWidth(-130);
  runningSection(app);
  if (ImGui::CollapsingHeader("File", ImGuiTreeNodeFlags_DefaultOpen)) fileSection(app);
  if (ImGui::CollapsingHeader("View", ImGuiTreeNodeFlags_DefaultOpen)) viewSection(app);
  if (ImGui::CollapsingHeader("Illustration")) illustrationSection(app);
  if (ImGui::CollapsingHeader("Deformation", ImGuiTreeNodeFlags_DefaultOpen)) deformationSection(app);
  if (ImGui::CollapsingHeader("Joints", app.deform().joints().pose.joints.empty() ? 0 : ImGuiTreeNodeFlags_DefaultOpen))
    jointsSection(app);
  if (ImGui::CollapsingHeader("Segmentation", ImGuiTreeNodeFlags_DefaultOpen)) segmentationSection(app);
  if (ImGui::CollapsingHeader("Labels", ImGuiTreeNodeFlags_DefaultOpen)) labelTable(app);
  if (ImGui::CollapsingHeader("Measure and figures", ImGuiTreeNodeFlags_DefaultOpen)) studioToolsSection(app);
  if (ImGui::CollapsingHeader("Help: shortcuts")) helpSection();
  ImGui::PopItemWidth();
  ImGui::End();
}

}  // namespace vellum::studio
