#include "measure_tools.hpp"

#include <imgui.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace vellum::studio {

double rulerMm(const Vec3& a, const Vec3& b) { return norm(b - a); }

double angleDeg(const Vec3& a, const Vec3& vertex, const Vec3& c) {
  const Vec3 u = a - vertex, v = c - vertex;
  const double nu = norm(u), nv = norm(v);
  if (nu <= 0 || nv <= 0) return 0;
  // atan2 of |u x v| and u.v: accurate near 0 and 180 degrees, where acos is not.
  return std::atan2(norm(cross(u, v)), dot(u, v)) * 180.0 / M_PI;
}

double Measurement::value() const {
  if (!complete()) return 0;
  return kind == MeasureMode::Angle ? angleDeg(mm[0], mm[1], mm[2]) : rulerMm(mm[0], mm[1]);
}

std::string Measurement::text() const {
  char t[48];
  std::snprintf(t, sizeof t, kind == MeasureMode::Angle ? "%.1f deg" : "%.1f mm", value());
  return t;
}

bool Measurements::click(SliceAxis axis, const Vec3& mm) {
  if (mode == MeasureMode::Off) return false;
  // A click in another view, or with the other tool, starts afresh.
  if (pending_ && (pending_->axis != axis || pending_->kind != mode)) pending_.reset();
  if (!pending_) pending_ = Measurement{mode, axis, {}};
  pending_->mm.push_back(mm);
  if (pending_->complete()) {
    items_.push_back(std::move(*pending_));
    pending_.reset();
  }
  return true;
}

void Measurements::remove(size_t index) {
  if (index < items_.size()) items_.erase(items_.begin() + static_cast<std::ptrdiff_t>(index));
}

void Measurements::draw(const SlicePlane& plane, float x0, float y0, float w, float h,
                        const std::optional<Vec3>& cursorMm) const {
  ImDrawList* dl = ImGui::GetBackgroundDrawList();
  dl->PushClipRect({x0, y0}, {x0 + w, y0 + h}, true);
  const auto at = [&](const Vec3& p) {
    const auto [x, y] = plane.toPixel(p);
    return ImVec2{x0 + float(x), y0 + float(y)};
  };
  const auto one = [&](const Measurement& m, std::vector<Vec3> pts, bool finished, int number) {
    // Off this slice (the crosshair moved): drawn faint, as Slicer does with markups.
    double off = 0;
    for (const Vec3& p : pts) off = std::max(off, std::abs(dot(p - plane.center, plane.normal)));
    const bool here = off <= 1.0;
    const ImU32 line = here ? IM_COL32(255, 230, 60, 255) : IM_COL32(255, 230, 60, 90);
    const ImU32 text = here ? IM_COL32(255, 255, 255, 255) : IM_COL32(255, 255, 255, 110);
    for (size_t i = 0; i + 1 < pts.size(); ++i) dl->AddLine(at(pts[i]), at(pts[i + 1]), line, 1.5f);
    for (const Vec3& p : pts) dl->AddCircleFilled(at(p), 3.f, line);
    if (m.kind == MeasureMode::Angle && pts.size() == 3) {  // an arc at the vertex
      const ImVec2 v = at(pts[1]), a = at(pts[0]), c = at(pts[2]);
      float a0 = std::atan2(a.y - v.y, a.x - v.x), a1 = std::atan2(c.y - v.y, c.x - v.x);
      if (a1 - a0 > float(M_PI)) a1 -= 2 * float(M_PI);
      if (a0 - a1 > float(M_PI)) a1 += 2 * float(M_PI);
      dl->PathArcTo(v, 18.f, a0, a1, 16);
      dl->PathStroke(line, 0, 1.2f);
    }
    if (!finished) return;
    char label[64];
    std::snprintf(label, sizeof label, "%d: %s", number, m.text().c_str());
    const ImVec2 p = m.kind == MeasureMode::Angle ? at(pts[1]) : at((pts[0] + pts[1]) * 0.5);
    dl->AddRectFilled({p.x + 6, p.y - 8}, {p.x + 10 + ImGui::CalcTextSize(label).x, p.y + 8}, IM_COL32(0, 0, 0, 150));
    dl->AddText({p.x + 8, p.y - 7}, text, label);
  };
  for (size_t i = 0; i < items_.size(); ++i)
    if (items_[i].axis == plane.axis) one(items_[i], items_[i].mm, true, int(i) + 1);
  if (pending_ && pending_->axis == plane.axis) {
    std::vector<Vec3> pts = pending_->mm;
    if (cursorMm) pts.push_back(*cursorMm);
    one(*pending_, pts, false, 0);
  }
  dl->PopClipRect();
}

void Measurements::drawPanel() {
  int m = static_cast<int>(mode);
  ImGui::RadioButton("Off##measure", &m, 0);
  ImGui::SameLine();
  ImGui::RadioButton("Ruler", &m, 1);
  ImGui::SameLine();
  ImGui::RadioButton("Angle", &m, 2);
  if (m != static_cast<int>(mode)) pending_.reset();
  mode = static_cast<MeasureMode>(m);
  if (mode != MeasureMode::Off)
    ImGui::TextDisabled(mode == MeasureMode::Ruler ? "click two points in a slice" : "click a point, the vertex, a point");
  for (size_t i = 0; i < items_.size(); ++i) {
    ImGui::PushID(static_cast<int>(i));
    ImGui::Text("%zu: %s  (%s)", i + 1, items_[i].text().c_str(), sliceAxisName(items_[i].axis));
    ImGui::SameLine();
    if (ImGui::SmallButton("x")) remove(i);
    ImGui::PopID();
  }
}

}  // namespace vellum::studio
