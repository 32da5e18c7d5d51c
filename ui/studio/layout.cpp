#include "layout.hpp"

namespace vellum::studio {

std::vector<Pane> layoutPanes(Layout layout, const Rect& v) {
  constexpr float gap = 2;  // a visible seam between panes
  switch (layout) {
    case Layout::ThreeD:
      return {{std::nullopt, v}};
    case Layout::TwoByTwo: {
      const float w = (v.w - gap) / 2, h = (v.h - gap) / 2;
      return {{SliceAxis::Axial, {v.x, v.y, w, h}},
              {SliceAxis::Coronal, {v.x + w + gap, v.y, w, h}},
              {SliceAxis::Sagittal, {v.x, v.y + h + gap, w, h}},
              {std::nullopt, {v.x + w + gap, v.y + h + gap, w, h}}};
    }
    case Layout::OneByThree: {
      const float w = (v.w - 2 * gap) / 3;
      return {{SliceAxis::Axial, {v.x, v.y, w, v.h}},
              {SliceAxis::Coronal, {v.x + w + gap, v.y, w, v.h}},
              {SliceAxis::Sagittal, {v.x + 2 * (w + gap), v.y, w, v.h}}};
    }
  }
  return {};
}

}  // namespace vellum::studio
