#pragma once
// ImGui widgets generated from a parameter table (vellum/core/params.hpp): one widget per
// field, labelled with the field's label and unit, its help and range as the tooltip, its
// range as the widget's limits. The panels write no widget by hand for a table's parameter,
// so a panel, the scene file and the CLI flag cannot disagree.
#include <imgui.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "vellum/core/params.hpp"

namespace vellum::studio {

/// What happened to the widgets this frame.
struct ParamEdit {
  bool started = false;   ///< an edit began this frame (the state before it is the frame's start)
  bool changed = false;   ///< a value changed (apply it: live preview)
  bool finished = false;  ///< an edit ended (mouse released, Enter, a click): one undo step
  ParamEdit& operator|=(const ParamEdit& o) {
    started |= o.started;
    changed |= o.changed;
    finished |= o.finished;
    return *this;
  }
};

namespace detail {
inline std::string widgetLabel(const params::Info& info, const std::string& key) {
  return info.unit.empty() ? info.label + "##" + key : info.label + " (" + info.unit + ")##" + key;
}
inline void tooltip(const std::string& help, const std::string& range) {
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s\n%s", help.c_str(), range.c_str());
}
/// A slider where the range is finite and not too wide, else a drag box clamped to the range.
inline bool numberWidget(const std::string& label, double& v, const params::Info& info, bool integer) {
  const bool finite = std::isfinite(info.min) && std::isfinite(info.max);
  const double lo = finite ? info.min : (std::isfinite(info.min) ? info.min : -1e9);
  const double hi = finite ? info.max : (std::isfinite(info.max) ? info.max : 1e9);
  const char* format = integer ? "%.0f" : (std::abs(v) < 10 ? "%.3g" : "%.1f");
  bool changed;
  if (finite && hi - lo <= 1000 && !integer) {
    changed = ImGui::SliderScalar(label.c_str(), ImGuiDataType_Double, &v, &lo, &hi, format, ImGuiSliderFlags_AlwaysClamp);
  } else {
    const float speed = static_cast<float>(integer ? 0.2 : std::max(0.01, 0.005 * std::max(std::abs(v), 1.0)));
    changed = ImGui::DragScalar(label.c_str(), ImGuiDataType_Double, &v, speed, &lo, &hi, format, ImGuiSliderFlags_AlwaysClamp);
  }
  if (integer) v = std::round(v);
  return changed;
}
}  // namespace detail

/// Widgets for the fields of `table` in `s`, except the keys in `skip`.
template <class S>
ParamEdit editParams(const params::Table<S>& table, S& s, const std::vector<std::string>& skip = {}) {
  ParamEdit edit;
  for (const auto& f : table) {
    if (std::find(skip.begin(), skip.end(), f.key) != skip.end()) continue;
    const std::string label = detail::widgetLabel(f.info, f.key);
    const std::string range = params::rangeText(f.kind, f.info, f.choices);
    bool changed = false;
    if (f.kind == params::Kind::Text && !f.choices.empty()) {
      const std::string text = f.getText(s);
      if (ImGui::BeginCombo(label.c_str(), text.c_str())) {
        for (const auto& c : f.choices)
          if (ImGui::Selectable(c.c_str(), c == text)) f.setText(s, c), changed = true;
        ImGui::EndCombo();
      }
    } else if (f.kind == params::Kind::Text) {
      char buffer[512];
      const std::string text = f.getText(s);
      std::snprintf(buffer, sizeof buffer, "%s", text.c_str());
      if (ImGui::InputText(label.c_str(), buffer, sizeof buffer)) f.setText(s, buffer), changed = true;
    } else if (f.kind == params::Kind::Vector) {
      const auto v = f.getVector(s);
      if (f.info.min == 0 && f.info.max == 1 && f.info.unit != "fraction") {  // a colour
        float rgb[3] = {float(v[0]), float(v[1]), float(v[2])};
        if (ImGui::ColorEdit3(label.c_str(), rgb, ImGuiColorEditFlags_Float)) f.setVector(s, {rgb[0], rgb[1], rgb[2]}), changed = true;
      } else {
        double xyz[3] = {v[0], v[1], v[2]};
        const double lo = std::isfinite(f.info.min) ? f.info.min : -1e9, hi = std::isfinite(f.info.max) ? f.info.max : 1e9;
        if (ImGui::DragScalarN(label.c_str(), ImGuiDataType_Double, xyz, 3, 0.01f, &lo, &hi, "%.2f", ImGuiSliderFlags_AlwaysClamp))
          f.setVector(s, {xyz[0], xyz[1], xyz[2]}), changed = true;
      }
    } else {
      const std::optional<double> current = f.get(s);
      if (f.optional) {  // "unset" is a state of its own: a checkbox in front of the value
        bool set = current.has_value();
        if (ImGui::Checkbox(("##set" + f.key).c_str(), &set)) {
          f.set(s, set ? std::optional<double>(std::isfinite(f.info.min) ? f.info.min : 0.0) : std::nullopt);
          changed = true;
        }
        detail::tooltip("on: set the value; off: " + f.info.help, range);
        ImGui::SameLine();
      }
      double v = current.value_or(std::isfinite(f.info.min) ? f.info.min : 0.0);
      ImGui::BeginDisabled(f.optional && !current);
      switch (f.kind) {
        case params::Kind::Flag: {
          bool on = v != 0;
          if (ImGui::Checkbox(label.c_str(), &on)) v = on ? 1 : 0, changed = true;
          break;
        }
        case params::Kind::Choice: {
          int index = static_cast<int>(v);
          const char* preview = index >= 0 && index < int(f.choices.size()) ? f.choices[index].c_str() : "?";
          if (ImGui::BeginCombo(label.c_str(), preview)) {
            for (int i = 0; i < int(f.choices.size()); ++i)
              if (ImGui::Selectable(f.choices[i].c_str(), i == index)) v = i, changed = true;
            ImGui::EndCombo();
          }
          break;
        }
        default: changed = detail::numberWidget(label, v, f.info, f.kind == params::Kind::Integer);
      }
      ImGui::EndDisabled();
      if (changed && (!f.optional || current)) f.set(s, v);
    }
    detail::tooltip(f.info.help, range);
    edit.changed |= changed;
    // Sliders and drags begin on press and end on release; combos, checkboxes and optional
    // toggles begin and end with one click.
    const bool oneClick = changed && (f.kind == params::Kind::Choice || f.kind == params::Kind::Flag || f.optional ||
                                      (f.kind == params::Kind::Text && !f.choices.empty()));
    edit.started |= ImGui::IsItemActivated() || oneClick;
    edit.finished |= ImGui::IsItemDeactivatedAfterEdit() || oneClick;
  }
  return edit;
}

}  // namespace vellum::studio
