#pragma once
// The gradient-normal volume both renderers shade with: per voxel the unit gradient in
// PHYSICAL space and an encoded gradient magnitude, 4 x int8 (GL_RGBA8_SNORM), computed
// once per volume on the CPU in parallel.
#include <array>
#include <cstdint>
#include <vector>

#include "vellum/core/volume.hpp"

namespace vellum::render::detail {

/// The magnitude channel is |grad| * minSpacing / (valueSpan * kGradScaleFraction), clamped
/// to 1: a step of 5% of the volume's value span per voxel (e.g. 200 HU on CT) saturates it.
constexpr double kGradScaleFraction = 0.05;

struct NormalVolume {
  Dims dims;
  std::vector<int8_t> texels;  ///< 4 per voxel, x fastest: nx, ny, nz (x127), magnitude (x127)

  /// Trilinear sample at continuous index coordinates with zero outside (the GL texture's
  /// border), decoded as SNORM (c / 127). Mirrors the GL sampler for the CPU reference.
  std::array<float, 4> sample(double x, double y, double z) const;
};

/// Central differences in mm (background outside), rotated into physical space.
NormalVolume computeNormalVolume(const AnyVolume& volume);

}  // namespace vellum::render::detail
