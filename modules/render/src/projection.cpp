#include "vellum/render/projection.hpp"

#include "render_common.hpp"

namespace vellum::render {

Projection::Projection(const Geometry& volume, const RenderSettings& settings, const Geometry* mapGrid) {
  const detail::Frame f = detail::makeFrame(volume, mapGrid, settings);
  width_ = f.width;
  height_ = f.height;
  eye_ = f.eye;
  right_ = f.right;
  up_ = f.up;
  forward_ = f.forward;
  halfW_ = f.halfW;
  halfH_ = f.halfH;
  perspective_ = f.perspective;
  lookAt_ = f.box.center() + settings.camera.panMm;  // the framed box: the volume or the map grid
}

Projection Projection::plane(const Vec3& centreMm, const Vec3& right, const Vec3& down, double mmPerPixel, int width,
                             int height) {
  Projection p;
  p.width_ = width;
  p.height_ = height;
  p.eye_ = p.lookAt_ = centreMm;
  p.right_ = right;
  p.up_ = -down;
  p.forward_ = cross(right, down);
  p.halfW_ = 0.5 * width * mmPerPixel;
  p.halfH_ = 0.5 * height * mmPerPixel;
  return p;
}

std::optional<Vec3> Projection::toPixel(const Vec3& mm) const {
  // The inverse of detail::pixelRay.
  const Vec3 q = mm - eye_;
  const double depth = dot(q, forward_);
  double sx = dot(q, right_), sy = dot(q, up_);
  if (perspective_) {
    if (depth <= 1e-9) return std::nullopt;
    sx /= depth;
    sy /= depth;
  }
  return Vec3{(sx / halfW_ + 1) * 0.5 * width_ - 0.5, (1 - sy / halfH_) * 0.5 * height_ - 0.5, depth};
}

double Projection::pixelsPerMm() const {
  const double extentMm = perspective_ ? 2 * halfW_ * dot(lookAt_ - eye_, forward_) : 2 * halfW_;
  return width_ / extentMm;
}

std::array<double, 16> Projection::viewProjectionGl(double nearMm, double farMm) const {
  // Rows act on (p, 1): x = right.(p - eye) / halfW, y = up.(p - eye) / halfH; perspective
  // divides both by w = forward.(p - eye), the depth toPixel() divides by.
  auto row = [&](const Vec3& axis, double scale) {
    return std::array<double, 4>{axis.x * scale, axis.y * scale, axis.z * scale, -dot(axis, eye_) * scale};
  };
  const std::array<double, 4> depth = row(forward_, 1.0);
  std::array<std::array<double, 4>, 4> m{row(right_, 1 / halfW_), row(up_, 1 / halfH_), {}, {}};
  const double span = farMm - nearMm;
  if (perspective_) {  // z_ndc = (a depth + b) / depth: -1 at near, +1 at far
    const double a = (farMm + nearMm) / span, b = -2 * farMm * nearMm / span;
    for (int c = 0; c < 4; ++c) m[2][c] = a * depth[c];
    m[2][3] += b;
    m[3] = depth;
  } else {  // z_ndc = (2 depth - far - near) / span
    for (int c = 0; c < 4; ++c) m[2][c] = 2 * depth[c] / span;
    m[2][3] -= (farMm + nearMm) / span;
    m[3] = {0, 0, 0, 1};
  }
  std::array<double, 16> columnMajor{};
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) columnMajor[size_t(c * 4 + r)] = m[size_t(r)][size_t(c)];
  return columnMajor;
}

}  // namespace vellum::render
