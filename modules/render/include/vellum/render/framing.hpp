#pragma once
// Figures framed on what they show: a camera that fits given points (the outline of the
// drawn structures) instead of the whole volume's bounding sphere, which leaves a leg or a
// pair of feet filling ~40 % of the width.
#include <cstdint>
#include <vector>

#include "vellum/core/volume.hpp"
#include "vellum/render/render_settings.hpp"

namespace vellum::render {

/// Pixels kept free at the image's edges (for annotations: render::annotationInsets).
struct ImageInsets {
  int left = 0, right = 0, top = 0, bottom = 0;
};

/// The camera of `settings` around `volume` (azimuth, elevation, field of view kept), panned
/// and zoomed so that every point of `pointsMm` lands inside the image less `insets`, with
/// `margin` (a fraction of that area's width/height) left free on the tighter side, centred in
/// it. Insets that would leave less than half the image shrink in proportion to leave half. `settings.camera.zoom`
/// and `panMm` act on top of that fit (the zoom multiplies, the pan adds): zoom 1 is the fit.
/// Returns the camera unchanged when `pointsMm` is empty.
Camera fitCamera(const Geometry& volume, const RenderSettings& settings, const std::vector<Vec3>& pointsMm,
                 double margin = 0.06, ImageInsets insets = {});

/// Points whose projected extent, in any view, is that of the voxels of `ids` with
/// `wanted[id]` non-zero (index 0 = label 0), voxels taken whole: the outer corners of the
/// first and last such voxel of each x row. Empty when no voxel is wanted.
std::vector<Vec3> outlinePoints(const VolumeU16& ids, const std::vector<uint8_t>& wanted);

}  // namespace vellum::render
