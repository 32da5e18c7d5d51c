#pragma once
// Multi-planar reformatting: axial, coronal and sagittal planes through a point in physical
// (LPS, mm) space, resampled into RGBA images with window/level and a label overlay.
// Display convention (radiological, as in 3D Slicer): patient left on screen right; axial
// seen from the feet, coronal from the front, sagittal with anterior on the left.
#include <optional>
#include <set>
#include <utility>

#include "scene.hpp"
#include "vellum/core/image.hpp"
#include "vellum/deformation/synthesis.hpp"
#include "vellum/segmentation/threshold.hpp"

namespace vellum::studio {

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

struct SliceStyle {
  WindowLevel window;
  const LabelVolume* labels = nullptr;
  float labelOpacity = 0.5f;              ///< fill; outlines are drawn opaque
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

}  // namespace vellum::studio
