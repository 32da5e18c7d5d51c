#pragma once
// What the View panel edits and the scene file saves about how the scene is shown: the
// studio's own settings (layout, slice window, label opacity) and the 3D view's
// render::RenderSettings. Both are described once, by parameter tables (vellum/core/params.hpp):
// the panel's widgets, the scene file's keys, the undo entries and the CLI flags of
// `vellum render` all come from them. No GL, no ImGui.
#include <string>
#include <vector>

#include "vellum/app/mpr.hpp"
#include "vellum/core/enum_table.hpp"
#include "vellum/core/params.hpp"
#include "vellum/deformation/control_volume.hpp"
#include "vellum/illustration/style.hpp"
#include "vellum/render/render_settings.hpp"

namespace vellum::studio {

enum class Layout { ThreeD, TwoByTwo, OneByThree };
/// "3d", "2x2", "1x3".
const params::EnumTable<Layout>& layouts();
inline const char* layoutName(Layout l) { return layouts().name(l); }
inline Layout parseLayout(const std::string& name) { return layouts().parse(name); }

/// Window/level in HU (centre, width): the slice resampling's (vellum/app/mpr.hpp).
using app::WindowLevel;

/// The studio's own view settings.
struct ViewSettings {
  Layout layout = Layout::TwoByTwo;
  WindowLevel sliceWindow{40, 400};
  float labelOpacity = 0.4f;  ///< fill of the label overlay in the slices (outlines are opaque)
  /// The shape folder's meshes drawn opaque in the 3D view, the volume composited over them.
  bool meshesIn3d = false;
  /// How the live deformed view and the movie export interpolate the backward map between
  /// control nodes (`vellum deform/animate --upsampling`).
  deformation::Upsampling deformedUpsampling = deformation::Upsampling::Trilinear;
  /// While a deformation is shown, the slice views resample the CT and labels through its
  /// backward map, as the 3D view does; off: the undeformed volume (what label edits change).
  bool deformedSlices = true;
  bool operator==(const ViewSettings&) const = default;
};
/// Keys: layout, slice_window_center, slice_window_width, label_opacity, meshes_3d,
/// deformed_upsampling, deformed_slices.
const params::Table<ViewSettings>& viewSettingsTable();

/// Render-table keys that are not part of a scene (the 3D view's size is the window's).
inline const std::vector<std::string>& renderKeysNotInScene() {
  static const std::vector<std::string> keys{"width", "height"};
  return keys;
}

/// A named camera the user can return to (the View panel's bookmarks).
struct CameraBookmark {
  std::string name;
  render::Camera camera;
  bool operator==(const CameraBookmark&) const = default;
};

/// The 3D view as a shape-aware illustration (the illustration module's renderer and style,
/// what `vellum illustrate` draws) instead of the render presets.
struct IllustrationView {
  bool enabled = false;
  illustration::Style style = illustration::stylePreset("textbook");
  bool operator==(const IllustrationView&) const = default;
};

/// The style row that styles `segment` (a label name; "default" and "unclassified" are the
/// style's own rows) alone: its named row, or a new one, copied from the row that styles it
/// now, so editing it changes that segment only.
illustration::SegmentStyle& ownStyleRow(illustration::Style& style, const std::string& segment);

/// Everything a view edit can change: one undo step holds it before and after.
struct ViewState {
  ViewSettings view;
  render::RenderSettings render;  ///< width/height unused (the pane's size)
  std::vector<CameraBookmark> bookmarks;
  IllustrationView illustration;
  bool operator==(const ViewState& o) const;
};

}  // namespace vellum::studio
