#pragma once
// A grid's index -> mm linear part, direction * diag(spacing): an index offset as an mm offset
// (Geometry::indexToPhysical without the origin). The frames a backward map's samplers relate.
#include "vellum/core/geometry.hpp"

namespace vellum {

inline Mat3 indexToMm(const Geometry& g) {
  return g.direction * Mat3::fromColumns({g.spacing.x, 0, 0}, {0, g.spacing.y, 0}, {0, 0, g.spacing.z});
}

}  // namespace vellum
