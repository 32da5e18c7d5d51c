#include "view_settings.hpp"

#include <cctype>
#include <cmath>

#include "vellum/core/error.hpp"

namespace vellum::studio {

const params::EnumTable<Layout>& layouts() {
  static const params::EnumTable<Layout> t{"layout", {"3d", "2x2", "1x3"}};
  return t;
}

const params::Table<ViewSettings>& viewSettingsTable() {
  using V = ViewSettings;
  static const params::Table<V> t{
      params::choice<V>("layout", &V::layout, layouts().names,
                        {"Layout", "3D view only, 2x2 (axial, coronal, sagittal, 3D) or 1x3 (the three slices)", ""}),
      params::real<V>("slice_window_center", params::nested(&V::sliceWindow, &WindowLevel::center),
                      {"Slice level", "centre of the slices' grey-value window", "HU", -4000, 4000}),
      params::real<V>("slice_window_width", params::nested(&V::sliceWindow, &WindowLevel::width),
                      {"Slice window", "width of the slices' grey-value window", "HU", 1, 10000}),
      params::real<V>("label_opacity", &V::labelOpacity,
                      {"Label opacity", "fill opacity of the label overlay in the slices (outlines stay opaque)", "", 0, 1}),
      params::flag<V>("meshes_3d", &V::meshesIn3d,
                      {"Meshes in 3D view", "draw the shape folder's segment meshes opaque in the 3D view (render presets); the volume in front of them is composited over them", ""}),
      params::choice<V>("deformed_upsampling", &V::deformedUpsampling,
                        upsamplings().names,
                        {"Map upsampling", "how the deformed view and the movie export interpolate the map between "
                                           "control nodes (vellum deform/animate --upsampling)", ""}),
      params::flag<V>("deformed_slices", &V::deformedSlices,
                      {"Deformed slices", "while a deformation is shown, the slice views show the CT and labels "
                                          "through it, as the 3D view does; off: the undeformed volume", ""}),
  };
  return t;
}

illustration::SegmentStyle& ownStyleRow(illustration::Style& style, const std::string& segment) {
  if (segment == "default") return style.fallback;
  if (segment == "unclassified") return style.unclassified;
  const auto lower = [](std::string t) {
    for (char& c : t) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return t;
  };
  for (auto& row : style.segments)
    if (lower(row.match) == lower(segment)) return row;
  const std::vector<Label> table{{1, segment, {}}};
  illustration::SegmentStyle row = illustration::resolveRows(style, table, 1)[1];
  row.match = segment;
  style.segments.push_back(row);
  return style.segments.back();
}

namespace {
bool sameCamera(const render::Camera& a, const render::Camera& b) {
  return a.azimuthDeg == b.azimuthDeg && a.elevationDeg == b.elevationDeg && a.zoom == b.zoom &&
         a.fieldOfViewDeg == b.fieldOfViewDeg && a.panMm == b.panMm;
}
}  // namespace

bool ViewState::operator==(const ViewState& o) const {
  // Equal when every table field and the pan agree (RenderSettings has no operator==).
  for (const auto& f : render::renderSettingsTable())
    if (params::format(f, render) != params::format(f, o.render)) return false;  // every kind, exactly
  if (!sameCamera(render.camera, o.render.camera) || view != o.view || illustration != o.illustration ||
      bookmarks.size() != o.bookmarks.size())
    return false;
  for (size_t i = 0; i < bookmarks.size(); ++i)
    if (bookmarks[i].name != o.bookmarks[i].name || !sameCamera(bookmarks[i].camera, o.bookmarks[i].camera)) return false;
  return true;
}

}  // namespace vellum::studio
