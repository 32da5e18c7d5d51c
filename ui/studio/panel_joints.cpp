// The Joints panel: the joint tool's joints, the selected joint's angle slider (the view
// follows live), the pose's keyframes, a new joint (bones picked by clicks or typed as ids,
// the axis estimated or two clicked points), fixed labels, and the pose file.
#include <imgui.h>

#include <algorithm>
#include <cstdio>
#include <sstream>

#include "app.hpp"
#include "file_browser.hpp"
#include "joint_tool.hpp"
#include "param_widgets.hpp"
#include "vellum/core/error.hpp"

namespace vellum::studio {
namespace {

std::string idsText(const std::vector<uint16_t>& ids) {
  std::string s;
  for (size_t i = 0; i < ids.size(); ++i) {
    if (i) s += ',';
    s += std::to_string(ids[i]);
  }
  return s;
}

/// "4, 5 7" -> {4, 5, 7}; Error for anything else.
std::vector<uint16_t> parseIds(const std::string& text) {
  std::vector<uint16_t> ids;
  std::string t = text;
  for (char& c : t)
    if (c == ',') c = ' ';
  std::istringstream in(t);
  long v = 0;
  while (in >> v) {
    if (v < 1 || v > 65535) throw Error("label ids are 1..65535");
    ids.push_back(uint16_t(v));
  }
  if (!in.eof()) throw Error("label ids: numbers separated by commas");
  return ids;
}

/// A text field showing `ids`; Enter parses it back (true when it did).
bool idsField(StudioApp& app, const char* label, std::vector<uint16_t>& ids) {
  char buf[128];
  std::snprintf(buf, sizeof buf, "%s", idsText(ids).c_str());
  bool parsed = false;
  if (ImGui::InputText(label, buf, sizeof buf, ImGuiInputTextFlags_EnterReturnsTrue))
    guarded(app, [&] { ids = parseIds(buf), parsed = true; });
  return parsed;
}

}  // namespace

void jointsSection(StudioApp& app) {
  JointTool& jt = app.deform().joints();
  Scene& scene = app.scene();
  if (!scene.hasVolume() || scene.labels.ids().empty()) {
    ImGui::TextDisabled("open a label map to pose its bones");
    return;
  }
  if (jt.busy()) {
    ImGui::ProgressBar(float(jt.progress()), {-80, 0}, "joint axes and points");
    ImGui::SameLine();
    if (ImGui::Button("Cancel##joints")) jt.cancel();
  } else if (!jt.error().empty()) {
    ImGui::TextColored({1, 0.5f, 0.4f, 1}, "%s", jt.error().c_str());
  }
  deformation::Pose& pose = jt.pose;
  // The joints; the selected one's angle in the edited keyframe.
  for (int j = 0; j < int(pose.joints.size()); ++j) {
    const deformation::Joint& joint = pose.joints[size_t(j)];
    char row[160];
    std::snprintf(row, sizeof row, "%s: %s -> %s (%s)##joint%d", joint.name.c_str(), idsText(joint.parent).c_str(),
                  idsText(joint.child).c_str(),
                  joint.hasAxisHint ? "axis placed near the hint" : joint.estimateAxis ? "axis estimated" : "axis given", j);
    if (ImGui::RadioButton(row, jt.selected == j)) jt.selected = j;
    ImGui::SameLine();
    ImGui::PushID(j);
    if (ImGui::SmallButton("x")) guarded(app, [&] { jt.removeJoint(app, j); });
    ImGui::PopID();
  }
  if (!pose.joints.empty() && jt.ready()) {
    const int j = std::clamp(jt.selected, 0, int(pose.joints.size()) - 1);
    float deg = float(jt.angle(app, j));
    const bool changed = ImGui::SliderFloat("Angle deg", &deg, -90.f, 90.f, "%.1f");
    if (ImGui::IsItemActivated()) jt.beginAngleDrag(app);  // one drag = one undo step
    jt.dragging = ImGui::IsItemActive();  // the map is solved as during a point drag meanwhile
    if (changed) guarded(app, [&] { jt.setAngle(app, j, deg); });
    if (ImGui::IsItemDeactivated()) jt.endAngleDrag(app);
    const int n = int(pose.angles.keyframes.size());
    const int k = std::clamp(scene.authoring.keyframe, 0, n - 1);
    ImGui::Text("Pose keyframe %d / %d", k + 1, n);
    ImGui::SameLine();
    if (ImGui::SmallButton("<##posekf") && k > 0) guarded(app, [&] { jt.selectKeyframe(app, k - 1); });
    ImGui::SameLine();
    if (ImGui::SmallButton(">##posekf") && k + 1 < n) guarded(app, [&] { jt.selectKeyframe(app, k + 1); });
    ImGui::SameLine();
    if (ImGui::SmallButton("Add keyframe##pose")) guarded(app, [&] { jt.addKeyframe(app); });
    float dur = float(pose.angles.keyframes[size_t(k)].durationS);
    if (ImGui::InputFloat("Duration s##pose", &dur, 0.f, 0.f, "%.2f", ImGuiInputTextFlags_EnterReturnsTrue))
      guarded(app, [&] { jt.setDuration(app, dur); });
    if (ImGui::Button(scene.authoring.playing ? "Pause##pose" : "Play##pose"))
      guarded(app, [&] { app.deform().play(!scene.authoring.playing); });
  }
  ImGui::Separator();
  // A new joint: bones by clicks in a view (one id per click) or typed; axis two clicks or estimated.
  char name[64];
  std::snprintf(name, sizeof name, "%s", jt.draftName.c_str());
  if (ImGui::InputText("Name##joint", name, sizeof name)) jt.draftName = name;
  const auto pickButton = [&](const char* label, JointPick p, const char* tip) {
    const bool on = jt.pick == p;
    if (on) ImGui::PushStyleColor(ImGuiCol_Button, ImVec4(0.8f, 0.5f, 0.1f, 1));
    if (ImGui::Button(label)) jt.pick = on ? JointPick::None : p;
    if (on) ImGui::PopStyleColor();
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", tip);
  };
  pickButton("Pick parent", JointPick::Parent, "then click the parent bone in a slice or the 3D view");
  ImGui::SameLine();
  idsField(app, "##parentids", jt.draftParent);
  pickButton("Pick child", JointPick::Child, "then click the child bone (it turns; everything distal follows)");
  ImGui::SameLine();
  idsField(app, "##childids", jt.draftChild);
  pickButton("Axis 1", JointPick::AxisA, "click the first point of the hinge axis (else the axis is estimated)");
  ImGui::SameLine();
  pickButton("Axis 2", JointPick::AxisB, "click the second point: a positive angle turns right-handed about 1 -> 2");
  ImGui::SameLine();
  if (jt.draftAxisA || jt.draftAxisB) {
    if (ImGui::SmallButton("Estimate")) jt.draftAxisA.reset(), jt.draftAxisB.reset();
    ImGui::SameLine();
    ImGui::Checkbox("Place by motion", &jt.draftAxisIsHint);
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip("the two points are a rough axis: the axis within 30 mm (same direction) about which the "
                        "child slides along the parent with the least collision over the pose's angles");
  } else {
    ImGui::TextDisabled("estimated");
  }
  if (ImGui::Button("Add joint")) guarded(app, [&] { jt.addDraftJoint(app); });
  {  // the map: `vellum pose --map`'s row (its choices and help)
    app::PoseRequest r;
    r.map = jt.map;
    std::vector<std::string> others;
    for (const auto& f : app::poseRequestTable())
      if (f.key != "map") others.push_back(f.key);
    if (editParams(app::poseRequestTable(), r, others).changed) guarded(app, [&] { jt.setMap(app, r.map); });
  }
  deformation::FixedRegions fixed = pose.fixed;
  if (idsField(app, "Fixed labels", fixed.ids)) guarded(app, [&] { jt.setFixed(app, fixed); });
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("label ids that do not move at all (the other limb, the table)");
  if (ImGui::Button("Load pose...")) {
    app.fileBrowser().open(FileBrowser::Mode::Open, "Load pose file",
                           [&app](const std::filesystem::path& p) { guarded(app, [&] { app.deform().joints().load(app, p); }); });
  }
  ImGui::SameLine();
  if (!pose.joints.empty() && ImGui::Button("Save pose...")) {
    app.fileBrowser().open(FileBrowser::Mode::Save, "Save pose file (vellum pose --pose)", [&app](const std::filesystem::path& p) {
      guarded(app, [&] {
        std::filesystem::path cmd = p;
        cmd += ".command.txt";
        app.deform().joints().save(app, p, cmd, p.parent_path() / (p.stem().string() + "-posed.nrrd"));
        app.notify("saved " + p.string() + " and the vellum pose line beside it");
      });
    });
  }
}

}  // namespace vellum::studio
