#include "vellum/core/geometry.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "vellum/core/error.hpp"

namespace vellum {

std::string Dims::str() const {
  return std::to_string(x) + "x" + std::to_string(y) + "x" + std::to_string(z);
}

Vec3 Geometry::physicalToIndex(const Vec3& p) const { return physicalToIndexMap()(p); }

Geometry::ToIndex Geometry::physicalToIndexMap() const {
  Mat3 inv;
  if (!direction.inverse(inv)) inv = direction.transposed();
  return {origin, spacing, inv};
}

Vec3 Geometry::center() const {
  return indexToPhysical({(dims.x - 1) * 0.5, (dims.y - 1) * 0.5, (dims.z - 1) * 0.5});
}

Vec3 Geometry::extent() const {
  return {std::max<int64_t>(dims.x - 1, 0) * spacing.x, std::max<int64_t>(dims.y - 1, 0) * spacing.y,
          std::max<int64_t>(dims.z - 1, 0) * spacing.z};
}

double Geometry::minSpacing() const { return std::min({spacing.x, spacing.y, spacing.z}); }

void Geometry::validate(const std::string& what) const {
  auto fail = [&](const std::string& msg) { throw Error(what + ": " + msg); };
  if (dims.x <= 0 || dims.y <= 0 || dims.z <= 0) fail("invalid dimensions " + dims.str());
  constexpr int64_t kMaxDim = 1 << 16;
  if (dims.x > kMaxDim || dims.y > kMaxDim || dims.z > kMaxDim)
    fail("absurd dimensions " + dims.str() + " (each axis must be <= 65536)");
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(spacing[a]) || spacing[a] <= 0) {
      std::ostringstream s;
      s << "invalid spacing " << spacing.x << " " << spacing.y << " " << spacing.z
        << " (must be finite and > 0 mm)";
      fail(s.str());
    }
  }
  if (!isFinite(origin)) fail("origin is not finite");
  for (int c = 0; c < 3; ++c)
    if (!isFinite(direction.column(c))) fail("direction matrix is not finite");
  if (std::abs(direction.determinant()) < 1e-6) fail("direction matrix is singular");
}

bool Geometry::approxEqual(const Geometry& o, double tolMm) const {
  return dims == o.dims && norm(spacing - o.spacing) <= tolMm && norm(origin - o.origin) <= tolMm &&
         maxAbsDiff(direction, o.direction) <= 1e-5;
}

}  // namespace vellum
