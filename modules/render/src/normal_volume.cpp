#include "normal_volume.hpp"

#include "vellum/core/error.hpp"

#include <algorithm>

namespace vellum::render::detail {

GradientNormals gradientNormals(const AnyVolume& volume) {
  return std::visit(
      [](const auto& vol) {
        const Geometry& g = vol.geometry();
        Mat3 dirInv;
        if (!g.direction.inverse(dirInv)) throw Error("render: singular direction matrix");
        // Gradients transform by the inverse transpose; 0.5 / spacing: the central difference.
        const Mat3 halfPerMm = Mat3::fromColumns({0.5 / g.spacing.x, 0, 0}, {0, 0.5 / g.spacing.y, 0},
                                                 {0, 0, 0.5 / g.spacing.z});
        const auto [vmin, vmax] = vol.valueRange();
        const double span = std::max({vmax, vol.background()}) - std::min({vmin, vol.background()});
        const double minSpacing = g.minSpacing();
        return GradientNormals{dirInv.transposed() * halfPerMm,
                               minSpacing / (std::max(span, 1e-6) * kGradScaleFraction)};
      },
      volume);
}

}  // namespace vellum::render::detail
