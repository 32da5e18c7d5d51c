#include "vellum/app/mpr.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <vector>

#include "vellum/core/box_corners.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum::app {

const char* sliceAxisName(SliceAxis a) {
  switch (a) {
    case SliceAxis::Axial: return "axial";
    case SliceAxis::Coronal: return "coronal";
    case SliceAxis::Sagittal: return "sagittal";
  }
  return "?";
}

Vec3 SlicePlane::toMm(double px, double py) const {
  return center + u * ((px - width * 0.5) * mmPerPixel) + v * ((py - height * 0.5) * mmPerPixel);
}

std::pair<double, double> SlicePlane::toPixel(const Vec3& p) const {
  const Vec3 d = p - center;
  return {dot(d, u) / mmPerPixel + width * 0.5, dot(d, v) / mmPerPixel + height * 0.5};
}

SlicePlane makePlane(SliceAxis axis, const Geometry& g, const Vec3& crosshairMm, int width, int height) {
  SlicePlane p;
  p.axis = axis;
  p.width = std::max(1, width);
  p.height = std::max(1, height);
  switch (axis) {  // LPS: +x left, +y posterior, +z superior
    case SliceAxis::Axial: p.u = {1, 0, 0}; p.v = {0, 1, 0}; break;
    case SliceAxis::Coronal: p.u = {1, 0, 0}; p.v = {0, 0, -1}; break;
    case SliceAxis::Sagittal: p.u = {0, 1, 0}; p.v = {0, 0, -1}; break;
  }
  p.normal = cross(p.u, p.v);
  // Fit the oriented voxel box's projection onto (u, v).
  const Vec3 c = g.center();
  double halfU = 0, halfV = 0;
  for (const Vec3& corner : voxelBoxCorners(g)) {
    const Vec3 d = corner - c;
    halfU = std::max(halfU, std::abs(dot(d, p.u)));
    halfV = std::max(halfV, std::abs(dot(d, p.v)));
  }
  p.mmPerPixel = std::max(2 * halfU / p.width, 2 * halfV / p.height) * 1.04;  // small margin
  // In-plane centre = volume centre; along the normal = the crosshair.
  p.center = c + p.normal * dot(crosshairMm - c, p.normal);
  return p;
}

SlicePlane navigated(SlicePlane plane, const SliceNavigation& nav) {
  plane.mmPerPixel /= nav.zoom;
  plane.center += plane.u * nav.panU + plane.v * nav.panV;
  return plane;
}

SliceNavigation zoomedAbout(const SlicePlane& fitted, SliceNavigation nav, double factor, double px, double py) {
  const SlicePlane before = navigated(fitted, nav);
  const Vec3 at = before.toMm(px, py);
  nav.zoom = std::clamp(nav.zoom * factor, 0.25, 64.0);
  // The new centre puts `at` back under (px, py) at the new scale.
  const double m = fitted.mmPerPixel / nav.zoom;
  const Vec3 center = at - fitted.u * ((px - fitted.width * 0.5) * m) - fitted.v * ((py - fitted.height * 0.5) * m);
  nav.panU = dot(center - fitted.center, fitted.u);
  nav.panV = dot(center - fitted.center, fitted.v);
  return nav;
}

SliceNavigation pannedBy(const SlicePlane& fitted, SliceNavigation nav, double dx, double dy) {
  const double m = fitted.mmPerPixel / nav.zoom;
  nav.panU -= dx * m;  // the picture moves with the pointer: the centre moves against it
  nav.panV -= dy * m;
  return nav;
}

std::array<std::string, 4> orientationLetters(const SlicePlane& plane) {
  const auto letters = [](const Vec3& d) {
    // LPS: +x left, +y posterior, +z superior.
    const char* pos[3] = {"L", "P", "S"};
    const char* neg[3] = {"R", "A", "I"};
    int order[3] = {0, 1, 2};
    std::sort(order, order + 3, [&](int a, int b) { return std::abs(d[a]) > std::abs(d[b]); });
    std::string r = d[order[0]] >= 0 ? pos[order[0]] : neg[order[0]];
    if (std::abs(d[order[1]]) > 0.2) r += d[order[1]] >= 0 ? pos[order[1]] : neg[order[1]];
    return r;
  };
  return {letters(plane.u * -1.0), letters(plane.u), letters(plane.v * -1.0), letters(plane.v)};
}

const std::vector<WindowPreset>& windowPresets() {
  static const std::vector<WindowPreset> presets = {
      {"soft tissue", 40, 400}, {"bone", 400, 1800}, {"lung", -600, 1500}, {"brain", 40, 80}, {"abdomen", 60, 350},
  };
  return presets;
}

const WindowPreset* findWindowPreset(const std::string& name) {
  const auto key = [](const std::string& text) {
    std::string k;
    for (char c : text)
      if (c != ' ' && c != '-' && c != '_') k += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return k;
  };
  for (const WindowPreset& p : windowPresets())
    if (key(p.name) == key(name)) return &p;
  return nullptr;
}

namespace {
/// Label fill at `opacity` with opaque 1-pixel outlines where the id changes.
void overlayLabels(RgbaImage& img, const std::vector<uint16_t>& ids,
                   const std::vector<std::array<uint8_t, 3>>& colours, float opacity, bool outlines);
}  // namespace

namespace {
/// Source index coordinates of the slice's pixels, a row at a time: the plane's own positions
/// (stepped: they are affine in the pixel), or (deformed slices) u = map(v) of each pixel's v.
class PixelSources {
 public:
  PixelSources(const Geometry& g, const SlicePlane& plane, const deformation::MapSampler* map)
      : plane_(plane), map_(map), toIndex_(g.physicalToIndexMap()) {
    origin_ = g.physicalToIndex(plane.toMm(0.5, 0.5));
    dx_ = g.physicalToIndex(plane.toMm(1.5, 0.5)) - origin_;
    dy_ = g.physicalToIndex(plane.toMm(0.5, 1.5)) - origin_;
    if (map && !(map->output().dims == g.dims && map->output().approxEqual(g)))
      throw Error("deformed slice: the map was not built for this volume's grid");
  }

  /// Row y into ijk[0 .. width); `u` and `inside` are the caller's scratch (one per thread).
  void row(int64_t y, Vec3* ijk, std::vector<float>& u, std::vector<uint8_t>& inside) const {
    const int w = plane_.width;
    if (!map_) {
      for (int x = 0; x < w; ++x) ijk[x] = origin_ + dx_ * double(x) + dy_ * double(y);
      return;
    }
    u.resize(3 * static_cast<size_t>(w));
    inside.resize(static_cast<size_t>(w));
    map_->sourceMmRow(plane_.toMm(0.5, double(y) + 0.5), plane_.u * plane_.mmPerPixel, w, u.data(), inside.data());
    const Vec3 outside{-1e6, -1e6, -1e6};  // where the deformed volume is background
    for (int x = 0; x < w; ++x) {
      const float* p = u.data() + 3 * x;
      ijk[x] = inside[static_cast<size_t>(x)] ? toIndex_(Vec3{p[0], p[1], p[2]}) : outside;
    }
  }

 private:
  const SlicePlane& plane_;
  const deformation::MapSampler* map_;
  Geometry::ToIndex toIndex_;  // the inverse direction found once, not per pixel
  Vec3 origin_, dx_, dy_;
};
}  // namespace

RgbaImage renderSlice(const VolumeI16& ct, const SlicePlane& plane, const SliceStyle& style) {
  RgbaImage img(plane.width, plane.height);
  const Geometry& g = ct.geometry();
  const PixelSources sources(g, plane, style.map);
  const double lo = style.window.center - style.window.width / 2;
  const double scale = 255.0 / std::max(1e-6, style.window.width);
  const bool labelsOn = style.labels && !style.labels->ids().empty();
  std::vector<uint16_t> ids(labelsOn ? static_cast<size_t>(plane.width) * plane.height : 0);
  std::vector<uint8_t> preview(style.thresholdPreview ? static_cast<size_t>(plane.width) * plane.height : 0);
  std::vector<uint8_t> snake(style.snakePreview ? static_cast<size_t>(plane.width) * plane.height : 0);
  std::vector<std::array<uint8_t, 3>> colours(65536, {0, 0, 0});
  if (labelsOn) {
    for (uint16_t id = 1; id < 256; ++id) colours[id] = defaultLabelColor(id);
    for (const Label& l : style.labels->table()) colours[l.id] = l.rgb;
  }
  parallelFor(plane.height, [&](int64_t y0, int64_t y1) {
    std::vector<Vec3> row(static_cast<size_t>(plane.width));
    std::vector<float> scratch;
    std::vector<uint8_t> inside;
    for (int64_t y = y0; y < y1; ++y) {
      sources.row(y, row.data(), scratch, inside);
      for (int x = 0; x < plane.width; ++x) {
        const Vec3& ijk = row[static_cast<size_t>(x)];
        const double hu = ct.sampleLinear(ijk);
        const auto grey = static_cast<uint8_t>(std::clamp((hu - lo) * scale, 0.0, 255.0));
        uint8_t* px = img.at(x, static_cast<int>(y));
        px[0] = px[1] = px[2] = grey;
        px[3] = 255;
        if (labelsOn) {
          auto id = static_cast<uint16_t>(style.labels->ids().sampleNearest(ijk));
          if (id && style.hidden && style.hidden->count(id)) id = 0;
          ids[static_cast<size_t>(y) * plane.width + x] = id;
        }
        if (style.thresholdPreview) {
          const double v = ct.sampleNearest(ijk);
          preview[static_cast<size_t>(y) * plane.width + x] = style.thresholdPreview->contains(v);
        }
        if (style.snakePreview) {  // its own grid: the coarse levels come first
          const Geometry& sg = style.snakePreview->geometry();
          snake[static_cast<size_t>(y) * plane.width + x] =
              style.snakePreview->sampleNearest(sg.physicalToIndex(g.indexToPhysical(ijk))) != 0;
        }
      }
    }
  });
  if (labelsOn) overlayLabels(img, ids, colours, style.labelOpacity, style.labelOutlines);
  if (!snake.empty()) {  // yellow, half-blended: the snake's inside as it evolves
    for (size_t n = 0; n < snake.size(); ++n) {
      if (!snake[n]) continue;
      uint8_t* px = img.pixels.data() + n * 4;
      px[0] = static_cast<uint8_t>((px[0] + 255) / 2);
      px[1] = static_cast<uint8_t>((px[1] + 230) / 2);
      px[2] = static_cast<uint8_t>(px[2] / 4);
    }
  }
  if (!preview.empty()) {
    // Drawn last, in magenta (no default label uses it), half-blended so the anatomy shows.
    for (size_t n = 0; n < preview.size(); ++n) {
      if (!preview[n]) continue;
      uint8_t* px = img.pixels.data() + n * 4;
      px[0] = static_cast<uint8_t>((px[0] + 255) / 2);
      px[1] = static_cast<uint8_t>(px[1] / 4);
      px[2] = static_cast<uint8_t>((px[2] + 255) / 2);
    }
  }
  return img;
}

namespace {
void overlayLabels(RgbaImage& img, const std::vector<uint16_t>& ids,
                   const std::vector<std::array<uint8_t, 3>>& colours, float opacity, bool outlines) {
  const int width = img.width, height = img.height;
  const float a = std::clamp(opacity, 0.f, 1.f);
  parallelFor(height, [&](int64_t y0, int64_t y1) {
    for (int64_t y = y0; y < y1; ++y) {
      for (int x = 0; x < width; ++x) {
        const uint16_t id = ids[static_cast<size_t>(y) * width + x];
        if (!id) continue;
        // Outline: a pixel whose 4-neighbour carries another id (or lies outside the image).
        auto other = [&](int nx, int ny) {
          if (nx < 0 || ny < 0 || nx >= width || ny >= height) return true;
          return ids[static_cast<size_t>(ny) * width + nx] != id;
        };
        const int yi = static_cast<int>(y);
        const bool edge = outlines && (other(x - 1, yi) || other(x + 1, yi) || other(x, yi - 1) || other(x, yi + 1));
        const float w = edge ? 1.f : a;
        uint8_t* px = img.at(x, yi);
        for (int c = 0; c < 3; ++c)
          px[c] = static_cast<uint8_t>(std::lround(px[c] * (1 - w) + colours[id][c] * w));
      }
    }
  });
}
}  // namespace

}  // namespace vellum::app
