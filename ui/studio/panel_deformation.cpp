#include "panel_deformation.hpp"

#include <imgui.h>

#include <algorithm>
#include <cstdio>
#include <optional>
#include <string>

#include "app.hpp"
#include "param_widgets.hpp"
#include "vellum/app/animate_pipeline.hpp"
#include "vellum/deformation/deform_params.hpp"
#include "deform_controller.hpp"
#include "deform_session.hpp"
#include "joint_tool.hpp"

namespace vellum::studio {
using deformation::Interpolation;

namespace {

/// The labels kept rigid (bones) and the falloff of their blend, each change one undo step.
void rigidBones(StudioApp& app) {
  Authoring& a = app.scene().authoring;
  std::string rigid;
  // Appended piece by piece: `"," + std::to_string(id)` (operator+(const char*, string&&),
  // an insert at 0) draws a false -Wrestrict from GCC 12 at -O3.
  for (uint16_t id : a.rigidLabels) {
    if (!rigid.empty()) rigid += ',';
    rigid += std::to_string(id);
  }
  const bool open = ImGui::TreeNode("rigid", "Rigid labels: %s", rigid.empty() ? "none" : rigid.c_str());
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("labels kept rigid (bones); initially those whose names say bone");
  if (open) {
    if (a.joints) {  // every bone of the pose is rigid (DeformController::setRigid refuses others)
      ImGui::TextDisabled("the joints' bones (Joints panel)");
      ImGui::BeginDisabled();
    }
    for (const Label& l : app.scene().labels.table()) {
      bool on = std::find(a.rigidLabels.begin(), a.rigidLabels.end(), l.id) != a.rigidLabels.end();
      const std::string text = std::to_string(l.id) + " " + l.name;
      if (ImGui::Checkbox(text.c_str(), &on)) {
        std::vector<uint16_t> ids = a.rigidLabels;
        if (on) ids.push_back(l.id);
        else ids.erase(std::remove(ids.begin(), ids.end(), l.id), ids.end());
        app.deform().setRigid(std::move(ids), a.falloffMm, on ? "rigid label on" : "rigid label off");
      }
    }
    if (app.scene().labels.table().empty()) ImGui::TextDisabled("no label table");
    if (a.joints) ImGui::EndDisabled();
    ImGui::TreePop();
  }
  // The falloff re-solves live while dragged and is recorded once, when the drag ends.
  static std::optional<std::pair<std::vector<uint16_t>, double>> dragStart;
  float falloff = float(a.falloffMm);
  const bool changed = ImGui::SliderFloat("Rigid falloff mm", &falloff, 1.f, 40.f, "%.1f");
  if (ImGui::IsItemActivated()) dragStart = std::make_pair(a.rigidLabels, a.falloffMm);
  if (changed) {
    a.falloffMm = falloff;
    a.touch();
  }
  if (ImGui::IsItemDeactivatedAfterEdit() && dragStart) {
    app.deform().setRigid(a.rigidLabels, a.falloffMm, "rigid falloff", dragStart);
    dragStart.reset();
  }
}

void pointsRow(StudioApp& app) {
  Scene& s = app.scene();
  Authoring& a = s.authoring;
  // With joints the points are generated from the bones (the Joints panel): shown, not edited
  // here; the keyframe edits below change the pose's keyframes (JointTool::editTrack).
  const bool fromJoints = a.joints != nullptr;
  if (fromJoints) {
    ImGui::PushStyleColor(ImGuiCol_Text, ImVec4(1.f, 0.85f, 0.4f, 1.f));
    ImGui::TextWrapped("%s. Keyframe edits below change the pose's keyframes.", JointTool::generatedPointsNote());
    ImGui::PopStyleColor();
    ImGui::BeginDisabled();
  }
  if (ImGui::Button("16 default points")) guarded(app, [&] { app.points().placeControls(false); });
  ImGui::SameLine();
  if (ImGui::Button("Points from labels")) guarded(app, [&] { app.points().placeControls(true); });
  if (ImGui::Button("Add point")) {
    // At the crosshair: the point the slices show.
    guarded(app, [&] { app.points().editTrack("add point", [&](Authoring& x) { addPoint(x, s.crosshairMm); }); });
  }
  ImGui::SameLine();
  if (ImGui::Button("Delete point") && a.selected >= 0) {
    const int i = a.selected;
    guarded(app, [&] { app.points().editTrack("delete point", [i](Authoring& x) { deletePoint(x, i); }); });
  }
  int tool = static_cast<int>(app.points().tool());
  const char* names[] = {"move", "light", "hue", "density"};  // what dragging a dot does
  for (int t = 0; t < 4; ++t) {
    if (t) ImGui::SameLine();
    if (ImGui::RadioButton(names[t], &tool, t)) app.points().tool() = static_cast<PointTool>(t);
  }
  if (fromJoints) ImGui::EndDisabled();
  const int n = a.active() ? int(a.track.keyframes.front().points.size()) : 0;
  ImGui::Text("%d points", n);
  if (a.selected >= 0 && a.selected < n) {
    const auto p = a.currentPoints()[size_t(a.selected)];
    ImGui::Text("#%d target (%.1f, %.1f, %.1f) mm", a.selected, p.target.x, p.target.y, p.target.z);
    ImGui::Text("   L %+.0f a %+.0f b %+.0f density %.2f", p.attributes.lightness, p.attributes.a, p.attributes.b,
                p.attributes.density);
  }
  rigidBones(app);
  if (ImGui::TreeNode("Engine (vellum deform)")) {
    // Generated from the engine's parameter table (the flags of `vellum deform` / `animate`).
    const deformation::DeformParams before = a.engine;
    const ParamEdit e = editParams(deformation::deformParamsTable(), a.engine);
    if (e.changed) a.touch();  // re-solve with the new parameters
    if (e.started) app.points().beginEngineEdit(before);
    if (e.finished) app.points().endEngineEdit();
    ImGui::TreePop();
  }
  if (const auto* t = app.deform().session().timings(); t && app.deform().session().map()) {
    ImGui::Text("map update %.1f ms%s", app.deform().session().lastUpdateMs(), app.deform().session().preview() ? " (preview)" : "");
    ImGui::Text("  MLS %.1f, rho %.1f (%d fields), rigid %.1f", t->mapMs, t->rhoCacheMs, t->rhoFieldsRebuilt,
                app.deform().session().lastRigidityMs());
  }
}

// One block per keyframe, as wide as its duration: click to edit that keyframe, drag it onto
// another block to move its pose there, drag its right edge (the handle) to change its
// duration. Each drag is one undo step.
void keyframeBlocks(StudioApp& app) {
  Authoring& a = app.scene().authoring;
  const float width = ImGui::GetContentRegionAvail().x;
  const double total = std::max(1e-6, a.track.totalDurationS());
  const int n = int(a.track.keyframes.size());
  const float handle = StudioApp::kKeyframeHandlePx;
  static std::optional<deformation::KeyframeTrack> before;
  static int beforeKeyframe = 0;
  for (int k = 0; k < n; ++k) {
    if (k) ImGui::SameLine(0, 2);
    const float w = std::max(18.f, float(a.track.keyframes[size_t(k)].durationS / total) * (width - 2 * float(n)));
    const bool current = k == a.keyframe && !a.timeS;
    const ImVec2 at = ImGui::GetCursorScreenPos();
    app.keyframeBlocks().push_back({at.x, at.y, w, 24});
    ImGui::PushStyleColor(ImGuiCol_Button, current ? ImVec4(0.2f, 0.6f, 0.3f, 1) : ImVec4(0.3f, 0.3f, 0.35f, 1));
    const std::string number = std::to_string(k);  // not "K" + a temporary (as above)
    if (ImGui::Button(("K" + number + "##kf" + number).c_str(), {w - handle, 24})) {
      a.keyframe = k;
      a.timeS.reset();
      a.playing = false;
      a.touch();
    }
    ImGui::PopStyleColor();
    if (ImGui::BeginDragDropSource()) {
      ImGui::SetDragDropPayload("VELLUM_KEYFRAME", &k, sizeof k);
      ImGui::Text("move K%d", k);
      ImGui::EndDragDropSource();
    }
    if (ImGui::BeginDragDropTarget()) {
      if (const ImGuiPayload* p = ImGui::AcceptDragDropPayload("VELLUM_KEYFRAME")) {
        const int from = *static_cast<const int*>(p->Data);
        if (from != k)
          guarded(app, [&] { app.points().editTrack("move keyframe", [from, k](Authoring& x) { moveKeyframeTo(x, from, k); }); });
      }
      ImGui::EndDragDropTarget();
    }
    ImGui::SameLine(0, 0);
    ImGui::PushStyleColor(ImGuiCol_Button, ImVec4(0.55f, 0.55f, 0.6f, 1));
    ImGui::Button(("##dur" + std::to_string(k)).c_str(), {handle, 24});
    ImGui::PopStyleColor();
    if (ImGui::IsItemHovered() || ImGui::IsItemActive()) ImGui::SetMouseCursor(ImGuiMouseCursor_ResizeEW);
    if (ImGui::IsItemActivated()) before = a.track, beforeKeyframe = a.keyframe;
    if (ImGui::IsItemActive() && ImGui::IsMouseDragging(ImGuiMouseButton_Left, 0.f)) {
      const double secondsPerPx = total / std::max(1.f, width);
      double& d = a.track.keyframes[size_t(k)].durationS;
      d = std::clamp(d + ImGui::GetIO().MouseDelta.x * secondsPerPx, 0.05, 600.0);
      a.touch();
    }
    if (ImGui::IsItemDeactivated() && before) {
      if (before->keyframes.size() == a.track.keyframes.size() &&
          before->keyframes[size_t(k)].durationS != a.track.keyframes[size_t(k)].durationS)
        app.points().pushTrackEdit("keyframe duration", std::move(*before), beforeKeyframe);
      before.reset();
    }
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("drag to change K%d's duration", k);
  }
}

void timeline(StudioApp& app) {
  Authoring& a = app.scene().authoring;
  if (!a.active()) return;
  keyframeBlocks(app);
  const double total = std::max(1e-6, a.track.totalDurationS());
  float duration = float(a.track.keyframes[size_t(a.keyframe)].durationS);
  if (ImGui::DragFloat("Duration s", &duration, 0.05f, 0.05f, 60.f, "%.2f")) {
    const int k = a.keyframe;
    const double d = std::max(0.05f, duration);
    app.points().editTrack("keyframe duration", [k, d](Authoring& x) { x.track.keyframes[size_t(k)].durationS = d; });
  }
  if (ImGui::Button("Add keyframe")) guarded(app, [&] { app.points().editTrack("add keyframe", addKeyframe); });
  ImGui::SameLine();
  if (ImGui::Button("Delete keyframe") && a.track.keyframes.size() > 1) {
    const int k = a.keyframe;
    guarded(app, [&] { app.points().editTrack("delete keyframe", [k](Authoring& x) { deleteKeyframe(x, k); }); });
  }
  ImGui::SameLine();
  {
    const int k = a.keyframe, n = int(a.track.keyframes.size());
    ImGui::BeginDisabled(k <= 0);
    if (ImGui::ArrowButton("##earlier", ImGuiDir_Left))
      guarded(app, [&] { app.points().editTrack("move keyframe", [k](Authoring& x) { moveKeyframe(x, k, -1); }); });
    ImGui::EndDisabled();
    ImGui::SameLine();
    ImGui::BeginDisabled(k + 1 >= n);
    if (ImGui::ArrowButton("##later", ImGuiDir_Right))
      guarded(app, [&] { app.points().editTrack("move keyframe", [k](Authoring& x) { moveKeyframe(x, k, +1); }); });
    ImGui::EndDisabled();
    if (ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled)) ImGui::SetTooltip("move the keyframe earlier / later");
  }
  {  // Keyframed camera (turntables, fly-arounds): the view's camera stored in this keyframe.
    const int k = a.keyframe;
    if (ImGui::Button("Key camera"))
      guarded(app, [&] {
        const render::Camera c = app.scene().render.camera;
        app.points().editTrack("keyframe camera", [k, c](Authoring& x) {
          x.track.keyframes[size_t(k)].camera = keyframeCameraOf(c);
        });
      });
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("store the 3D view's camera in this keyframe (movies and playback follow it)");
    if (a.track.keyframes[size_t(k)].camera) {
      ImGui::SameLine();
      if (ImGui::Button("Clear camera"))
        guarded(app, [&] { app.points().editTrack("clear keyframe camera", [k](Authoring& x) { x.track.keyframes[size_t(k)].camera.reset(); }); });
      ImGui::SameLine();
      const deformation::KeyframeCamera& kc = *a.track.keyframes[size_t(k)].camera;
      ImGui::TextDisabled("az %.0f el %.0f zoom %.2f fov %.0f", kc.azimuthDeg, kc.elevationDeg, kc.zoom,
                          kc.fieldOfViewDeg.value_or(app.scene().render.camera.fieldOfViewDeg));
    }
  }
  int interp = static_cast<int>(a.track.interpolation);
  if (ImGui::Combo("Interpolation", &interp, "linear\0smooth\0eased\0")) {
    app.points().editTrack("interpolation", [interp](Authoring& x) { x.track.interpolation = static_cast<Interpolation>(interp); });
  }
  bool loop = a.track.loop;
  if (ImGui::Checkbox("Loop", &loop)) app.points().editTrack("loop", [loop](Authoring& x) { x.track.loop = loop; });
  ImGui::SameLine();
  if (ImGui::Button(a.playing ? "Pause" : "Play")) guarded(app, [&] { app.deform().play(!a.playing); });
  float t = float(a.timeS.value_or(keyframeStartS(a.track, a.keyframe)));
  if (ImGui::SliderFloat("Time s", &t, 0.f, float(total), "%.2f")) {
    a.playing = false;
    a.timeS = t;
    a.touch();
  }
}

void exportRow(StudioApp& app) {
  static char out[256] = "frames/";
  static int size[2] = {512, 512};
  static float fps = 30;
  static float orbit = 0;
  ImGui::InputText("Out (dir/ or .mp4)", out, sizeof out);
  ImGui::InputInt2("Size", size);
  ImGui::InputFloat("fps", &fps);
  ImGui::InputFloat("Orbit deg", &orbit);
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("turns the camera by this many degrees over the movie (turntable)");
  static double padMm = -1;  // --pad-mm (deform's row, described once): automatic
  const params::Info& pad = params::findField(app::animateRequestTable(), "pad_mm")->info;
  detail::numberWidget(detail::widgetLabel(pad, "export_pad"), padMm, pad, false);
  detail::tooltip(pad.help, "-1 = automatic; 0 = the volume's box");
  if (app.deform().exporting()) {
    const auto [done, count] = app.deform().exportProgress();
    char label[64];
    std::snprintf(label, sizeof label, "%d / %d frames", done, count);
    ImGui::ProgressBar(count ? float(done) / float(count) : 0.f, {-70, 0}, label);
    ImGui::SameLine();
    if (ImGui::Button("Cancel##export")) app.deform().cancelExport();
  } else if (ImGui::Button("Export movie")) {
    guarded(app, [&] { app.deform().startExport(out, fps, size[0], size[1], orbit, padMm); });
  }
}

}  // namespace

void deformationSection(StudioApp& app) {
  if (!app.scene().hasVolume()) return;
  pointsRow(app);
  ImGui::Separator();
  timeline(app);
  ImGui::Separator();
  if (app.scene().authoring.active()) exportRow(app);
}

}  // namespace vellum::studio
