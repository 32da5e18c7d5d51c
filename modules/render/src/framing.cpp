#include "vellum/render/framing.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "vellum/render/projection.hpp"

namespace vellum::render {

Camera fitCamera(const Geometry& volume, const RenderSettings& settings, const std::vector<Vec3>& pointsMm,
                 double margin, ImageInsets insets) {
  Camera cam = settings.camera;
  if (pointsMm.empty()) return cam;
  // At least half the image for the anatomy: wider insets shrink in proportion (the
  // annotations then overlap its edges rather than leave it a sliver).
  const auto limit = [](int& a, int& b, int size) {
    if (2 * (a + b) <= size) return;
    const double f = 0.5 * size / (a + b);
    a = int(a * f), b = int(b * f);
  };
  limit(insets.left, insets.right, settings.width);
  limit(insets.top, insets.bottom, settings.height);
  const double areaW = settings.width - insets.left - insets.right;
  const double areaH = settings.height - insets.top - insets.bottom;
  // The area's centre, in pixel-centre coordinates.
  const double cx = insets.left + 0.5 * areaW - 0.5, cy = insets.top + 0.5 * areaH - 0.5;
  Vec3 lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
          std::numeric_limits<double>::infinity()};
  Vec3 hi = -lo;
  for (const Vec3& p : pointsMm)
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
  RenderSettings s = settings;
  s.camera.zoom = 1;
  s.camera.panMm = (lo + hi) * 0.5 - volume.center();
  // Pans the camera until the points' projected extent is centred on pixel (tx, ty); returns
  // false when no point is in front of the eye. spanX/spanY: the extent between pixel centres.
  double spanX = 0, spanY = 0;
  const auto centreOn = [&](double tx, double ty) {
    for (int round = 0; round < 4; ++round) {
      const Projection p(volume, s);
      double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
      for (const Vec3& q : pointsMm) {
        const auto px = p.toPixel(q);
        if (!px) continue;
        x0 = std::min(x0, px->x), x1 = std::max(x1, px->x), y0 = std::min(y0, px->y), y1 = std::max(y1, px->y);
      }
      if (!(x1 >= x0)) return false;
      spanX = x1 - x0;
      spanY = y1 - y0;
      // The offset moved back to mm at the look-at depth (exact for orthographic views; in
      // perspective each point moves by its own depth, hence the rounds).
      const double dx = 0.5 * (x0 + x1) - tx, dy = 0.5 * (y0 + y1) - ty;
      if (std::abs(dx) < 0.1 && std::abs(dy) < 0.1) break;
      const double mmPerPixel = 1 / p.pixelsPerMm();
      s.camera.panMm = s.camera.panMm + p.screenRight() * (dx * mmPerPixel) - p.screenUp() * (dy * mmPerPixel);
    }
    return true;
  };
  // From the points' box centre: centred on the image at zoom 1 (zooming scales about the
  // image centre), zoomed so that the span plus one pixel (to the pixels' edges) fills
  // 1 - margin of the area, times the asked zoom, then moved to the area's centre.
  if (!centreOn(0.5 * (s.width - 1), 0.5 * (s.height - 1))) return cam;
  const double fit = std::min(std::max((1 - margin) * areaW - 1, 1.0) / std::max(spanX, 1e-9),
                              std::max((1 - margin) * areaH - 1, 1.0) / std::max(spanY, 1e-9));
  s.camera.zoom = settings.camera.zoom * fit;
  if (!centreOn(cx, cy)) return cam;
  cam.zoom = s.camera.zoom;
  cam.panMm = s.camera.panMm + settings.camera.panMm;
  return cam;
}

std::vector<Vec3> outlinePoints(const VolumeU16& ids, const std::vector<uint8_t>& wanted) {
  const Dims d = ids.dims();
  const Geometry& g = ids.geometry();
  const uint16_t* v = ids.data();
  const auto isWanted = [&](uint16_t id) { return id < wanted.size() && wanted[id] != 0; };
  // A vertex of the set's convex hull lies at an end of its row (it is no point between two
  // others): the first and last voxel of each x row hold every hull vertex, so the projected
  // extent of these is the extent of them all.
  std::vector<Vec3> out;
  for (int64_t k = 0; k < d.z; ++k)
    for (int64_t j = 0; j < d.y; ++j) {
      const uint16_t* row = v + (k * d.y + j) * d.x;
      int64_t first = -1, last = -1;
      for (int64_t i = 0; i < d.x; ++i)
        if (isWanted(row[i])) {
          if (first < 0) first = i;
          last = i;
        }
      if (first < 0) continue;
      for (const double x : {first - 0.5, last + 0.5})
        for (const double dy : {-0.5, 0.5})
          for (const double dz : {-0.5, 0.5}) out.push_back(g.indexToPhysical({x, j + dy, k + dz}));
    }
  return out;
}

}  // namespace vellum::render
