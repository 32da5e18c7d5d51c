#pragma once
// The gradient normals both renderers shade with, computed where they are sampled: central
// differences of the trilinear volume one voxel either side along each index axis (the
// trilinear interpolation of per-voxel central differences, exactly), turned into PHYSICAL
// space, as a unit normal and an encoded gradient magnitude. No stored normal volume: the GL
// shader's gradientNormal() computes the same from the volume texture (4 bytes a voxel less
// in the driver's memory; issue #22).
#include <algorithm>
#include <array>
#include <cmath>

#include "vellum/core/vec.hpp"
#include "vellum/core/volume.hpp"

namespace vellum::render::detail {

/// The magnitude channel is |grad| * minSpacing / (valueSpan * kGradScaleFraction), clamped
/// to 1: a step of 5% of the volume's value span per voxel (e.g. 200 HU on CT) saturates it.
constexpr double kGradScaleFraction = 0.05;

struct GradientNormals {
  /// Index-axis value differences (v(i+1) - v(i-1), ...) -> physical gradient (value / mm):
  /// D^-T diag(0.5 / spacing).
  Mat3 toPhysical;
  double magScale = 0;  ///< |physical gradient| -> the encoded magnitude (before the clamp)

  /// nx, ny, nz (unit, physical), magnitude in [0, 1] at continuous index coordinates u;
  /// zeros where the gradient vanishes. Outside the grid the volume is its background
  /// (Volume::sampleLinear), as the GL texture's border.
  template <class T>
  std::array<float, 4> sample(const Volume<T>& vol, const Vec3& u) const {
    const Vec3 diff{vol.sampleLinear({u.x + 1, u.y, u.z}) - vol.sampleLinear({u.x - 1, u.y, u.z}),
                    vol.sampleLinear({u.x, u.y + 1, u.z}) - vol.sampleLinear({u.x, u.y - 1, u.z}),
                    vol.sampleLinear({u.x, u.y, u.z + 1}) - vol.sampleLinear({u.x, u.y, u.z - 1})};
    const Vec3 g = toPhysical * diff;
    const double mag = norm(g);
    if (!(mag > 0)) return {0.f, 0.f, 0.f, 0.f};
    return {float(g.x / mag), float(g.y / mag), float(g.z / mag), float(std::min(mag * magScale, 1.0))};
  }
};

/// The constants for `volume` (its geometry and value span; one parallel pass for the range).
GradientNormals gradientNormals(const AnyVolume& volume);

}  // namespace vellum::render::detail
