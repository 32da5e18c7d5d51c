// PointController: the control-point metaphor. Source = grey dot, target = green dot, a grey line
// between them (green for the selected point), sized in screen pixels, over the 3D view
// (projected with render::Projection, the renderer's own camera) and the slice views. A press
// on a dot drags that end in the plane through it parallel to the screen (Shift: along the
// LPS axis closest to the pointer's motion); in a slice, within the slice plane.
#include "point_controller.hpp"

#include <GLFW/glfw3.h>
#include <imgui.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "app.hpp"
#include "deform_controller.hpp"
#include "deform_session.hpp"
#include "joint_tool.hpp"
#include "view3d.hpp"
#include "vellum/core/error.hpp"
#include "vellum/deformation/placement.hpp"
#include "vellum/render/projection.hpp"

namespace vellum::studio {
using deformation::ControlPoints;

namespace {
constexpr float kDotRadiusPx = 5.f;
constexpr double kPickRadiusPx = 9.0;
const ImU32 kGrey = IM_COL32(170, 170, 170, 255);
const ImU32 kGreen = IM_COL32(60, 220, 90, 255);
const ImU32 kSelectedRing = IM_COL32(255, 255, 255, 255);

Vec3 endOf(const deformation::ControlPoint& p, PointEnd e) { return e == PointEnd::Source ? p.source : p.target; }
}  // namespace

Scene& PointController::scene() const { return app_.scene(); }

void applyAttributeDrag(deformation::PointAttributes& out, const deformation::PointAttributes& start, PointTool tool,
                        double dx, double dy) {
  out = start;
  switch (tool) {
    case PointTool::Lightness:  // up = lighter: 0.5 L* per pixel
      out.lightness = std::clamp(start.lightness - 0.5 * dy, -100.0, 100.0);
      break;
    case PointTool::Hue:  // right = redder (a*), up = yellower (b*)
      out.a = std::clamp(start.a + 0.5 * dx, -128.0, 128.0);
      out.b = std::clamp(start.b - 0.5 * dy, -128.0, 128.0);
      break;
    case PointTool::Density:  // up = denser: x2 per 100 pixels
      out.density = std::clamp(start.density * std::exp2(-dy / 100.0), 0.0, 16.0);
      break;
    case PointTool::Move:
      break;
  }
}

std::optional<std::pair<double, double>> PointController::pointInPane(const Pane& pane, const Vec3& mm) const {
  if (pane.is3d()) {
    const render::Projection proj(scene().ct.geometry(), renderSettingsFor(scene(), int(pane.rect.w), int(pane.rect.h)));
    const auto px = proj.toPixel(mm);
    if (!px) return std::nullopt;
    // Projection puts pixel centres on integers; window coordinates put them at +0.5.
    return std::pair{pane.rect.x + px->x + 0.5, pane.rect.y + px->y + 0.5};
  }
  const SlicePlane plane = app_.planeOf(pane);
  const auto [x, y] = plane.toPixel(mm);
  return std::pair{pane.rect.x + x, pane.rect.y + y};
}

std::optional<PointHandle> PointController::pickPoint(const Pane& pane, double x, double y) const {
  if (scene().authoring.pose) return std::nullopt;  // not drawn (drawControlPoints)
  const ControlPoints pts = scene().authoring.currentPoints();
  // Dots that coincide on screen (points stacked along the view axis) are told apart by depth:
  // in 3D the one nearest the eye, in a slice the one nearest the slice plane.
  std::optional<render::Projection> proj;
  std::optional<SlicePlane> plane;
  if (pane.is3d()) proj.emplace(scene().ct.geometry(), renderSettingsFor(scene(), int(pane.rect.w), int(pane.rect.h)));
  else plane = app_.planeOf(pane);
  auto depthOf = [&](const Vec3& mm) {
    if (plane) return std::abs(dot(mm - scene().crosshairMm, plane->normal));
    const auto px = proj->toPixel(mm);
    return px ? px->z : 1e300;
  };
  constexpr double kSameDotPx = 1.0;
  std::optional<PointHandle> best;
  double bestD = kPickRadiusPx, bestDepth = 1e300;
  for (int i = 0; i < int(pts.size()); ++i)
    for (PointEnd e : {PointEnd::Target, PointEnd::Source}) {  // targets win ties: they are what one drags
      const Vec3 mm = endOf(pts[size_t(i)], e);
      const auto p = pointInPane(pane, mm);
      if (!p) continue;
      const double d = std::hypot(p->first - x, p->second - y), depth = depthOf(mm);
      const bool sameDot = best && std::abs(d - bestD) <= kSameDotPx;
      if (sameDot ? depth < bestDepth - 1e-9 : d < bestD) bestD = d, bestDepth = depth, best = PointHandle{i, e};
    }
  return best;
}

std::optional<std::pair<double, double>> PointController::pointOnScreen(int index, PointEnd end,
                                                                  const std::string& view) const {
  const ControlPoints pts = scene().authoring.currentPoints();
  if (index < 0 || index >= int(pts.size())) return std::nullopt;
  std::vector<const Pane*> order;
  for (const Pane& p : app_.panes()) {
    if (!view.empty() && view != (p.is3d() ? "3d" : sliceAxisName(*p.slice))) continue;
    if (p.is3d()) order.insert(order.begin(), &p);
    else order.push_back(&p);
  }
  for (const Pane* p : order)
    if (auto px = pointInPane(*p, endOf(pts[size_t(index)], end)); px && p->rect.contains(px->first, px->second))
      return px;
  return std::nullopt;
}

void PointController::draw(const Pane& pane) {
  if (scene().authoring.pose) return;  // the joint tool's generated points: its axes are the handles
  const ControlPoints pts = scene().authoring.currentPoints();
  if (pts.empty()) return;
  ImDrawList* dl = ImGui::GetBackgroundDrawList();
  dl->PushClipRect({pane.rect.x, pane.rect.y}, {pane.rect.x + pane.rect.w, pane.rect.y + pane.rect.h}, true);
  const int selected = scene().authoring.selected;
  // Selected last, so its line and dots lie on top.
  std::vector<int> order;
  for (int i = 0; i < int(pts.size()); ++i)
    if (i != selected) order.push_back(i);
  if (selected >= 0 && selected < int(pts.size())) order.push_back(selected);
  // In a slice, points away from the slice plane are dimmed (they are not in that section).
  std::optional<SlicePlane> plane;
  if (!pane.is3d())
    plane = app_.planeOf(pane);
  const Vec3& sp = scene().ct.geometry().spacing;
  const double nearMm = 1.5 * std::max({sp.x, sp.y, sp.z});
  // In the 3D view, dots behind the volume's first visible surface are dimmed (depth test
  // on the CPU along the eye ray, through the deformation the view draws).
  const deformation::MapSampler* map = app_.deform().session().sampler();
  auto hidden = [&](const Vec3& mm) {
    return plane ? std::abs(dot(mm - scene().crosshairMm, plane->normal)) > nearMm : occludedInView(scene(), map, mm);
  };
  if (!plane) {
    // The eye rays depend on the view and the map, not on the pane: cache them across frames.
    std::ostringstream key;
    key.precision(12);
    const auto& c = scene().render.camera;
    key << c.azimuthDeg << ' ' << c.elevationDeg << ' ' << c.fieldOfViewDeg << ' ' << c.panMm.x << ' ' << c.panMm.y
        << ' ' << c.panMm.z << ' ' << int(scene().render.preset) << ' ' << scene().render.windowCenter << ' '
        << scene().render.windowWidth << ' ' << app_.deform().session().mapRevision() << ' ' << scene().authoring.revision << ' '
        << scene().volumeGeneration;
    if (key.str() != occlusionKey_ || occlusion_.size() != pts.size()) {
      occlusion_.resize(pts.size());
      for (size_t i = 0; i < pts.size(); ++i) occlusion_[i] = {hidden(pts[i].source), hidden(pts[i].target)};
      occlusionKey_ = key.str();
    }
  }
  for (int i : order) {
    const auto& cp = pts[size_t(i)];
    const bool dimSource = plane ? hidden(cp.source) : occlusion_[size_t(i)][0];
    const bool dimTarget = plane ? hidden(cp.target) : occlusion_[size_t(i)][1];
    auto faded = [&](ImU32 c, const Vec3& mm) {
      const bool dim = &mm == &cp.source ? dimSource : dimTarget;
      return dim ? (c & 0x00FFFFFFu) | (IM_COL32_A_MASK & IM_COL32(0, 0, 0, 70)) : c;
    };
    const auto s = pointInPane(pane, cp.source), t = pointInPane(pane, cp.target);
    if (!s || !t) continue;
    const ImVec2 a{float(s->first), float(s->second)}, b{float(t->first), float(t->second)};
    const bool sel = i == selected;
    dl->AddLine(a, b, faded(sel ? kGreen : kGrey, cp.target), sel ? 2.5f : 1.5f);
    dl->AddCircleFilled(a, kDotRadiusPx, faded(kGrey, cp.source));
    dl->AddCircle(a, kDotRadiusPx, faded(IM_COL32(40, 40, 40, 255), cp.source));
    dl->AddCircleFilled(b, kDotRadiusPx, faded(kGreen, cp.target));
    dl->AddCircle(b, kDotRadiusPx, faded(sel ? kSelectedRing : IM_COL32(20, 60, 20, 255), cp.target), 0, sel ? 2.f : 1.f);
  }
  drawKeyframeConnector(pane);
  dl->PopClipRect();
}

void PointController::drawKeyframeConnector(const Pane& pane) {
  // The selected point's target in the previous / current / next keyframe, red / green / blue,
  // joined by a Y: three arms from their centroid.
  const Authoring& a = scene().authoring;
  const int n = int(a.track.keyframes.size());
  if (n < 2 || a.selected < 0 || a.timeS) return;
  std::vector<std::pair<ImVec2, ImU32>> ends;
  const int k = std::clamp(a.keyframe, 0, n - 1);
  const std::pair<int, ImU32> which[] = {{k - 1, IM_COL32(235, 70, 70, 255)}, {k, kGreen}, {k + 1, IM_COL32(80, 130, 255, 255)}};
  for (const auto& [kf, colour] : which) {
    const int i = a.track.loop ? (kf + n) % n : kf;
    if (i < 0 || i >= n) continue;
    const auto& pts = a.track.keyframes[size_t(i)].points;
    if (a.selected >= int(pts.size())) return;
    if (const auto p = pointInPane(pane, pts[size_t(a.selected)].target))
      ends.push_back({ImVec2{float(p->first), float(p->second)}, colour});
  }
  if (ends.size() < 2) return;
  ImVec2 c{0, 0};
  for (const auto& e : ends) c.x += e.first.x / float(ends.size()), c.y += e.first.y / float(ends.size());
  ImDrawList* dl = ImGui::GetBackgroundDrawList();
  for (const auto& [p, colour] : ends) {
    dl->AddLine(c, p, colour, 1.5f);
    dl->AddCircle(p, kDotRadiusPx + 3, colour, 0, 2.f);
  }
}

bool PointController::beginDrag(const Pane& pane, double x, double y, int mods) {
  if (scene().authoring.playing || !scene().authoring.active()) return false;
  const auto hit = pickPoint(pane, x, y);
  if (!hit) return false;
  Authoring& a = scene().authoring;
  if (a.timeS) {  // scrubbed between keyframes: edit the keyframe being shown
    a.timeS.reset();
    a.touch();
  }
  a.selected = hit->index;
  PointDrag d;
  d.handle = *hit;
  d.startMm = endOf(a.editablePoints()[size_t(hit->index)], hit->end);
  d.tool = tool_;
  d.startAttributes = a.editablePoints()[size_t(hit->index)].attributes;
  d.pressX = x;
  d.pressY = y;
  d.mods = mods;
  d.before = a.track;
  d.keyframeBefore = a.keyframe;
  drag_ = d;
  return true;
}

void PointController::moveDrag(const Pane& pane, double x, double y) {
  if (!drag_) return;
  const PointDrag& d = *drag_;
  const double dx = x - d.pressX, dy = y - d.pressY;
  if (d.tool != PointTool::Move) {
    applyAttributeDrag(scene().authoring.editablePoints()[size_t(d.handle.index)].attributes, d.startAttributes, d.tool,
                       dx, dy);
    scene().authoring.touch();
    return;
  }
  // Screen directions at the point's depth: the pixel motion of 1 mm along right, up (3D) or
  // the slice's u, v axes. In-plane, motion is linear in mm (constant depth).
  Vec3 right, down;
  double pxPerMm = 1;
  if (pane.is3d()) {
    const render::Projection proj(scene().ct.geometry(), renderSettingsFor(scene(), int(pane.rect.w), int(pane.rect.h)));
    const auto p0 = proj.toPixel(d.startMm), p1 = proj.toPixel(d.startMm + proj.screenRight());
    if (!p0 || !p1) return;
    pxPerMm = std::hypot(p1->x - p0->x, p1->y - p0->y);
    right = proj.screenRight();
    down = -proj.screenUp();
  } else {
    const SlicePlane plane = app_.planeOf(pane);
    pxPerMm = 1.0 / plane.mmPerPixel;
    right = plane.u;
    down = plane.v;
  }
  if (pxPerMm <= 0) return;
  Vec3 move = right * (dx / pxPerMm) + down * (dy / pxPerMm);
  if (d.mods & GLFW_MOD_SHIFT) {
    // Axis constraint: the LPS axis whose on-screen direction best matches the motion.
    int best = 0;
    double bestScore = -1;
    for (int axis = 0; axis < 3; ++axis) {
      Vec3 e;
      e[axis] = 1;
      const double sx = dot(e, right), sy = dot(e, down), len = std::hypot(sx, sy);
      if (len < 1e-6) continue;
      const double score = std::abs(dx * sx + dy * sy) / len;
      if (score > bestScore) bestScore = score, best = axis;
    }
    Vec3 e;
    e[best] = 1;
    const double sx = dot(e, right), sy = dot(e, down), len2 = sx * sx + sy * sy;
    move = len2 > 1e-12 ? e * ((dx * sx + dy * sy) / len2 / pxPerMm) : Vec3{};
  }
  auto& p = scene().authoring.editablePoints()[size_t(d.handle.index)];
  (d.handle.end == PointEnd::Source ? p.source : p.target) = d.startMm + move;
  scene().authoring.touch();
}

void PointController::endDrag() {
  if (!drag_) return;
  TrackEdit e;
  e.description = "drag point " + std::to_string(drag_->handle.index);
  e.before = std::move(drag_->before);
  e.keyframeBefore = drag_->keyframeBefore;
  e.after = scene().authoring.track;
  e.keyframeAfter = scene().authoring.keyframe;
  drag_.reset();
  if (!samePoints(e.before, e.after)) app_.undoStack().push(std::move(e));  // a click without motion only selects
}

void PointController::editTrack(const std::string& description, const std::function<void(Authoring&)>& fn) {
  // With joints the track is made from the pose: the edit goes to the pose (or is refused).
  if (scene().authoring.joints) return app_.deform().joints().editTrack(app_, description, fn);
  TrackEdit e;
  e.description = description;
  e.before = scene().authoring.track;
  e.keyframeBefore = scene().authoring.keyframe;
  e.engineBefore = scene().authoring.engine;
  fn(scene().authoring);
  e.after = scene().authoring.track;
  e.keyframeAfter = scene().authoring.keyframe;
  e.engineAfter = scene().authoring.engine;
  scene().authoring.touch();
  app_.undoStack().push(std::move(e));
}

void PointController::pushTrackEdit(const std::string& description, deformation::KeyframeTrack before, int keyframeBefore) {
  if (scene().authoring.joints) {  // a drag retimed the shown keyframes: the pose's take the durations
    std::vector<double> durations;
    for (const auto& k : scene().authoring.track.keyframes) durations.push_back(k.durationS);
    scene().authoring.track = std::move(before);
    return app_.deform().joints().editTrack(app_, description, [durations](Authoring& a) {
      for (size_t k = 0; k < durations.size() && k < a.track.keyframes.size(); ++k)
        a.track.keyframes[k].durationS = durations[k];
    });
  }
  TrackEdit e;
  e.description = description;
  e.before = std::move(before);
  e.keyframeBefore = keyframeBefore;
  e.after = scene().authoring.track;
  e.keyframeAfter = scene().authoring.keyframe;
  e.engineBefore = e.engineAfter = scene().authoring.engine;
  app_.undoStack().push(std::move(e));
}

void PointController::beginEngineEdit(const deformation::DeformParams& before) {
  if (!engineEditBefore_) engineEditBefore_ = before;
}

void PointController::endEngineEdit() {
  TrackEdit e;
  e.description = "engine parameters";
  e.before = e.after = scene().authoring.track;
  e.keyframeBefore = e.keyframeAfter = scene().authoring.keyframe;
  e.engineBefore = engineEditBefore_.value_or(scene().authoring.engine);
  e.engineAfter = scene().authoring.engine;
  engineEditBefore_.reset();
  scene().authoring.touch();
  app_.undoStack().push(std::move(e));
}

void PointController::placeControls(bool fromLabels) {
  if (scene().authoring.joints) throw Error(JointTool::generatedPointsNote());
  if (!scene().hasVolume()) throw Error("no volume is open");
  if (fromLabels && scene().labels.ids().empty()) throw Error("no label map is open");
  if (!fromLabels) {
    ControlPoints pts = deformation::boxControlPoints(scene().ct.geometry());
    editTrack("default points", [&](Authoring& a) { placePoints(a, std::move(pts)); });
    return;
  }
  // A pass over the whole label map: on the task queue's worker, after the queued label edits.
  app_.tasks().push("points from labels", [this](Progress&) {
    auto pts = std::make_shared<ControlPoints>(deformation::labelControlPoints(scene().labels));
    return TaskQueue::Apply([this, pts] {
      editTrack("points from labels", [&](Authoring& a) { placePoints(a, std::move(*pts)); });
    });
  });
}

}  // namespace vellum::studio

