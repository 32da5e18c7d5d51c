#pragma once
// Multi-planar reformatting: axial, coronal and sagittal planes through a point in physical
// (LPS, mm) space, resampled into RGBA images with window/level and a label overlay. One
// resampling for the studio's slice views and `vellum slice` (no GL, no ImGui).
// Display convention (radiological, as in 3D Slicer): patient left on screen right; axial
// seen from the feet, coronal from the front, sagittal with anterior on the left.
#include <array>
#include <optional>
#include <string>
#include <vector>
#include <set>
#include <utility>

#include "vellum/core/image.hpp"
#include "vellum/core/label_volume.hpp"
#include "vellum/core/volume.hpp"
#include "vellum/deformation/synthesis.hpp"
#include "vellum/segmentation/threshold.hpp"

namespace vellum::app {

enum class SliceAxis { Axial, Coronal, Sagittal };
const char* sliceAxisName(SliceAxis a);

/// A slice view's pixel grid in physical space: pixel (px, py) has its centre at
/// center + u * (px + 0.5 - width/2) * mmPerPixel + v * (py + 0.5 - height/2) * mmPerPixel.
struct SlicePlane {
  SliceAxis axis = SliceAxis::Axial;
  Vec3 center;        ///< mm: the volume's centre in-plane, the crosshair along the normal
  Vec3 u, v, normal;  ///< unit LPS directions of screen right, screen down, and u x v
  double mmPerPixel = 1;
  int width = 1, height = 1;

  Vec3 toMm(double px, double py) const;
  /// Pixel coordinates (not rounded) of the projection of p onto the plane.
  std::pair<double, double> toPixel(const Vec3& p) const;
};

/// The plane of `axis` through `crosshairMm`, fitting the whole volume into width x height.
SlicePlane makePlane(SliceAxis axis, const Geometry& g, const Vec3& crosshairMm, int width, int height);

/// A slice view's zoom and pan (not part of the scene: navigating is not an edit, as in
/// 3D Slicer). Zoom 1 and no pan is makePlane's fit of the whole volume.
struct SliceNavigation {
  double zoom = 1;        ///< > 1 magnifies
  double panU = 0, panV = 0;  ///< mm along the plane's u (screen right) and v (screen down)
  bool operator==(const SliceNavigation&) const = default;
};
/// The fitted plane zoomed and panned by `nav`.
SlicePlane navigated(SlicePlane plane, const SliceNavigation& nav);
/// `nav` zoomed by `factor` about pixel (px, py) of `fitted` (makePlane's plane): the position
/// under that pixel stays where it is. Zoom is kept within [0.25, 64].
SliceNavigation zoomedAbout(const SlicePlane& fitted, SliceNavigation nav, double factor, double px, double py);
/// `nav` panned so that the picture follows a pointer move of (dx, dy) pixels.
SliceNavigation pannedBy(const SlicePlane& fitted, SliceNavigation nav, double dx, double dy);
/// The orientation letters at the left, right, top and bottom edges of a plane's picture
/// (LPS: R/L, A/P, I/S; an oblique direction gets the letters of its two largest components).
std::array<std::string, 4> orientationLetters(const SlicePlane& plane);

/// Window/level in HU (centre, width).
struct WindowLevel {
  double center = 40;
  double width = 400;
  bool operator==(const WindowLevel&) const = default;
};

/// Slice window presets (centre, width in HU), as in 3D Slicer's window/level menu.
struct WindowPreset {
  const char* name;
  double center, width;
};
const std::vector<WindowPreset>& windowPresets();
/// The preset named `name` (case, spaces, '-' and '_' ignored: "soft-tissue" is "soft tissue");
/// nullptr when none is.
const WindowPreset* findWindowPreset(const std::string& name);

struct SliceStyle {
  WindowLevel window;
  const LabelVolume* labels = nullptr;
  float labelOpacity = 0.5f;              ///< fill; outlines are drawn opaque
  bool labelOutlines = true;              ///< opaque 1-pixel outlines where the id changes
  const std::set<uint16_t>* hidden = nullptr;
  std::optional<segmentation::HuInterval> thresholdPreview;  ///< drawn over the labels
  /// A running snake's inside (any grid over the volume, sampled nearest), drawn in yellow.
  const segmentation::Mask* snakePreview = nullptr;
  /// Deformed slices: nullptr, or the backward map (built for the CT's grid). Each pixel at
  /// output position v then shows the source at u = map(v): CT trilinear, labels, threshold and
  /// snake previews nearest; outside the deformed volume's voxel box, background and no label.
  const deformation::MapSampler* map = nullptr;
};

/// Trilinear CT with window/level, labels nearest-neighbour (fill + outline).
RgbaImage renderSlice(const VolumeI16& ct, const SlicePlane& plane, const SliceStyle& style);

}  // namespace vellum::app
