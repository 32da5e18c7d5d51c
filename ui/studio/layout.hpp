#pragma once
// Splits the viewport (the window minus the tool panel) into panes per layout.
#include <optional>
#include <vector>

#include "mpr.hpp"
#include "scene.hpp"

namespace vellum::studio {

struct Rect {
  float x = 0, y = 0, w = 0, h = 0;  ///< window pixels, y down
  bool contains(double px, double py) const { return px >= x && py >= y && px < x + w && py < y + h; }
};

struct Pane {
  std::optional<SliceAxis> slice;  ///< nullopt: the 3D view
  Rect rect;
  bool is3d() const { return !slice; }
};

/// Width of the tool panel on the left; the viewport is the rest of the window.
inline constexpr float kToolPanelWidth = 330;

/// 3d: one 3D pane. 2x2: axial | coronal over sagittal | 3D. 1x3: axial | coronal | sagittal.
std::vector<Pane> layoutPanes(Layout layout, const Rect& viewport);

}  // namespace vellum::studio
