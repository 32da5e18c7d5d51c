#pragma once
// The ruler and the angle tool of the slice views (as in 3D Slicer's markups): points clicked
// in a slice, kept in physical mm (LPS), so a length is in mm whatever the voxel spacing and
// an angle is measured in space, not in voxel units. Drawn over the slice with the view's
// annotations; each can be deleted. Not part of the scene (as navigation is not).
#include <optional>
#include <string>
#include <vector>

#include "mpr.hpp"
#include "vellum/core/vec.hpp"

namespace vellum::studio {

enum class MeasureMode { Off, Ruler, Angle };

struct Measurement {
  MeasureMode kind = MeasureMode::Ruler;  ///< Ruler: 2 points; Angle: 3, the vertex second
  SliceAxis axis = SliceAxis::Axial;      ///< the view it was drawn in
  std::vector<Vec3> mm;
  /// mm for a ruler, degrees for an angle (once complete).
  double value() const;
  /// "37.5 mm" or "110.0 deg".
  std::string text() const;
  bool complete() const { return mm.size() == (kind == MeasureMode::Angle ? 3u : 2u); }
};

/// The distance between two points, mm.
double rulerMm(const Vec3& a, const Vec3& b);
/// The angle at `vertex` between the rays to a and c, degrees (0 when a ray has no length).
double angleDeg(const Vec3& a, const Vec3& vertex, const Vec3& c);

class Measurements {
 public:
  MeasureMode mode = MeasureMode::Off;
  /// A click at `mm` in a view of `axis` with the tool on: adds a point (a measurement is
  /// finished by its last point). False when the tool is off (the click is not taken).
  bool click(SliceAxis axis, const Vec3& mm);
  /// Deletes measurement `index` (out of range: nothing).
  void remove(size_t index);
  void clear() {
    items_.clear();
    pending_.reset();
  }
  const std::vector<Measurement>& items() const { return items_; }
  const std::optional<Measurement>& pending() const { return pending_; }
  /// Draws the measurements of `axis` over a slice pane at window offset (x0, y0) through
  /// `plane` (ImGui's background list, after the slice). `cursorMm`: where the pointer is,
  /// for the unfinished one's rubber band.
  void draw(const SlicePlane& plane, float x0, float y0, float w, float h, const std::optional<Vec3>& cursorMm) const;
  /// The panel: tool choice and the list with a delete button each.
  void drawPanel();

 private:
  std::vector<Measurement> items_;
  std::optional<Measurement> pending_;
};

}  // namespace vellum::studio
