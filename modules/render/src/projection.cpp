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

}  // namespace vellum::render
