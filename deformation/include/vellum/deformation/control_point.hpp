#pragma once
// Control points of an MLS deformation ([HVD 1.1, 1.2] in docs/references.md). Positions in mm (physical,
// LPS), as everywhere at Vellum's public APIs.
#include <array>
#include <vector>

#include "vellum/core/vec.hpp"

namespace vellum::deformation {

/// Non-spatial attributes a control point carries ([HVD 1.2] in docs/references.md). Interpolated over the
/// output volume with the same MLS weights; the renderer applies them.
struct PointAttributes {
  double lightness = 0;  ///< CIE L* offset (-100..100)
  double a = 0;          ///< CIE a* offset (green -> red)
  double b = 0;          ///< CIE b* offset (blue -> yellow)
  double density = 1;    ///< opacity / scalar scale, 1 = unchanged

  static constexpr int kCount = 4;
  std::array<double, kCount> values() const { return {lightness, a, b, density}; }
  bool isDefault() const { return lightness == 0 && a == 0 && b == 0 && density == 1; }
  bool operator==(const PointAttributes&) const = default;
};

struct ControlPoint {
  Vec3 source;  ///< x_i: position in the input volume (mm)
  Vec3 target;  ///< y_i: where the user dragged it (mm)
  PointAttributes attributes;
  bool operator==(const ControlPoint&) const = default;
};

using ControlPoints = std::vector<ControlPoint>;

/// True when any point carries non-default attributes.
bool hasAttributes(const ControlPoints& points);

}  // namespace vellum::deformation
