#pragma once
// Where physical points land in a rendered image: the renderer's own camera model, for
// annotations (scale bars, labels, leader lines) and picking.
#include <array>
#include <optional>

#include "vellum/core/geometry.hpp"
#include "vellum/render/render_settings.hpp"

namespace vellum::render {

class Projection {
 public:
  /// The camera of `settings` around `volume` (the same frame the renderer builds). Deformed
  /// renders frame the backward map's node grid instead: pass it as `mapGrid`.
  Projection(const Geometry& volume, const RenderSettings& settings, const Geometry* mapGrid = nullptr);
  /// An orthographic view of a plane: pixel (x, y)'s centre at centreMm + right * (x + 0.5 -
  /// width/2) * mmPerPixel + down * (y + 0.5 - height/2) * mmPerPixel, looking along right x down
  /// (unit, orthogonal directions). A slice picture's frame, so that annotate() draws on it.
  static Projection plane(const Vec3& centreMm, const Vec3& right, const Vec3& down, double mmPerPixel, int width,
                          int height);

  /// Pixel coordinates (x right, y down; the centre of pixel (0,0) is at (0,0)) and the depth
  /// along the viewing direction (mm) of a physical point; nullopt behind a perspective eye.
  std::optional<Vec3> toPixel(const Vec3& mm) const;
  /// Pixels per mm: exact everywhere for orthographic views; for perspective views, at the
  /// depth of the look-at point (nearer things look bigger).
  double pixelsPerMm() const;
  bool perspective() const { return perspective_; }
  int width() const { return width_; }
  int height() const { return height_; }
  /// Unit physical (LPS) directions of screen right, screen up and the view.
  const Vec3& screenRight() const { return right_; }
  const Vec3& screenUp() const { return up_; }
  const Vec3& viewDirection() const { return forward_; }
  /// The eye (perspective) or the centre of the eye plane (orthographic), mm.
  const Vec3& eye() const { return eye_; }
  /// The same camera as a GL view-projection matrix (column-major, for glUniformMatrix4fv):
  /// after the divide by w, GL's viewport transform puts a point at toPixel()'s pixel (GL
  /// window x = pixel x + 0.5, window y = height - 0.5 - pixel y); z maps view depths
  /// [nearMm, farMm] to [-1, 1]. Used by MeshRenderer, so meshes land where rays go.
  std::array<double, 16> viewProjectionGl(double nearMm, double farMm) const;

 private:
  Projection() = default;
  int width_ = 0, height_ = 0;
  Vec3 eye_, right_, up_, forward_, lookAt_;
  double halfW_ = 1, halfH_ = 1;
  bool perspective_ = false;
};

}  // namespace vellum::render
