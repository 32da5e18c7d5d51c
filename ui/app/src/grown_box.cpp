// The grown output box (see grown_box.hpp).
#include "vellum/app/grown_box.hpp"

#include <cmath>
#include <string>

#include "vellum/core/box_corners.hpp"
#include "vellum/core/error.hpp"

namespace vellum::app {
using deformation::ControlPoints;

Geometry paddedGeometry(const Geometry& g, const Padding& pad) {
  Geometry out = g;
  out.origin = g.indexToPhysical({-double(pad.lo[0]), -double(pad.lo[1]), -double(pad.lo[2])});
  out.dims = {g.dims.x + pad.lo[0] + pad.hi[0], g.dims.y + pad.lo[1] + pad.hi[1], g.dims.z + pad.lo[2] + pad.hi[2]};
  return out;
}

AnyVolume padded(const AnyVolume& v, const Padding& pad) {
  return std::visit(
      [&](const auto& x) -> AnyVolume {
        using T = typename std::decay_t<decltype(x)>::value_type;
        return padded(x, pad, static_cast<T>(x.background()));
      },
      v);
}

LabelVolume padded(const LabelVolume& labels, const Padding& pad) {
  return LabelVolume(padded(labels.ids(), pad, uint16_t{0}), labels.table());
}

std::optional<Padding> placementIn(const Geometry& inner, const Geometry& outer) {
  const Vec3 at = outer.physicalToIndex(inner.origin);
  Padding pad;
  for (int a = 0; a < 3; ++a) {
    const size_t s = static_cast<size_t>(a);
    pad.lo[s] = std::llround(at[a]);
    pad.hi[s] = outer.dims[a] - inner.dims[a] - pad.lo[s];
    if (std::abs(at[a] - double(pad.lo[s])) >= 1e-3 || pad.lo[s] < 0 || pad.hi[s] < 0) return std::nullopt;
  }
  Geometry shifted = outer;
  shifted.dims = inner.dims;
  shifted.origin = inner.origin;
  if (!inner.approxEqual(shifted, 1e-3)) return std::nullopt;
  return pad;
}

LabelVolume labelsOnGrid(const LabelVolume& labels, const Geometry& grid) {
  const Geometry& lg = labels.geometry();
  if (lg.dims == grid.dims && lg.approxEqual(grid, 1e-3)) return labels;
  const std::optional<Padding> pad = placementIn(lg, grid);
  if (!pad) throw Error("label map grid " + lg.dims.str() + " differs from the volume's " + grid.dims.str());
  return padded(labels, *pad);
}

namespace {

/// Content samples: every `step`-th voxel above the background (CT: above -500 HU, tissue not air).
std::vector<Vec3> contentSamples(const AnyVolume& volume, int64_t step) {
  std::vector<Vec3> content;
  std::visit(
      [&](const auto& v) {
        const Geometry& g = v.geometry();
        const Dims d = g.dims;
        const double bg = v.background();
        const double above = bg <= -900 ? -500 : bg;  // CT: tissue, not air; else anything but the background
        for (int64_t k = 0; k < d.z; k += step)
          for (int64_t j = 0; j < d.y; j += step)
            for (int64_t i = 0; i < d.x; i += step)
              if (double(v(i, j, k)) > above) content.push_back(g.indexToPhysical({double(i), double(j), double(k)}));
      },
      volume);
  return content;
}

/// Each sample's nearest source point among `points` (index), in parallel.
std::vector<size_t> nearestSources(const std::vector<Vec3>& samples, const ControlPoints& points) {
  std::vector<size_t> nearest(samples.size(), 0);
  parallelFor(static_cast<int64_t>(samples.size()), [&](int64_t t0, int64_t t1) {
    for (int64_t t = t0; t < t1; ++t) {
      const Vec3& x = samples[static_cast<size_t>(t)];
      double best = std::numeric_limits<double>::infinity();
      for (size_t p = 0; p < points.size(); ++p)
        if (const double e = dot(points[p].source - x, points[p].source - x); e < best) best = e, nearest[size_t(t)] = p;
    }
  });
  return nearest;
}

bool sameSources(const ControlPoints& a, const ControlPoints& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (!(a[i].source == b[i].source)) return false;
  return true;
}

/// The box of the samples where they are and where each pose carries them (each moved by its
/// nearest point's displacement); `lo` / `hi` get how far (voxels) they pass each face of `g`.
/// The nearest points are found once for poses that share their sources (a pose's keyframes do).
BoxMm movedContent(const std::vector<Vec3>& samples, const std::vector<ControlPoints>& poses, const Geometry& g,
                   std::array<double, 3>& lo, std::array<double, 3>& hi) {
  BoxMm box;
  const auto reach = [&](const Vec3& m) {
    box.add(m);
    const Vec3 idx = g.physicalToIndex(m);
    for (int a = 0; a < 3; ++a) {
      lo[size_t(a)] = std::max(lo[size_t(a)], -idx[a]);
      hi[size_t(a)] = std::max(hi[size_t(a)], idx[a] - double(g.dims[a] - 1));
    }
  };
  for (const Vec3& x : samples) reach(x);
  const ControlPoints* last = nullptr;
  std::vector<size_t> nearest;
  for (const ControlPoints& points : poses) {
    if (points.empty()) continue;
    if (!last || !sameSources(*last, points)) nearest = nearestSources(samples, points);
    last = &points;
    for (size_t t = 0; t < samples.size(); ++t) {
      const deformation::ControlPoint& p = points[nearest[t]];
      reach(samples[t] + (p.target - p.source));
    }
  }
  return box;
}

}  // namespace

GrownBox grownBox(const AnyVolume& volume, double padMm, const std::vector<ControlPoints>& poses, int controlScale,
                  bool withContent) {
  const Geometry& g = geometryOf(volume);
  GrownBox out;
  std::array<double, 3> lo{0, 0, 0}, hi{0, 0, 0};  // voxels the content passes each face by
  const bool automatic = padMm < 0;
  // About 200 k samples whatever the size (a 512^2 x 350 volume: every 8th voxel).
  const int64_t step = std::max<int64_t>(1, std::llround(std::cbrt(double(g.dims.voxelCount()) / 2e5)));
  if (automatic || withContent) out.content = movedContent(contentSamples(volume, step), poses, g, lo, hi);
  if (automatic) {
    const double minSpacing = g.minSpacing();
    const double margin = 0.5 * double(step) + norm(g.spacing) * controlScale / minSpacing;  // voxels
    for (size_t a = 0; a < 3; ++a) {
      // Half a voxel past the face is still inside the last voxel.
      if (lo[a] > 0.5) out.pad.lo[a] = static_cast<int64_t>(std::ceil(lo[a] + margin));
      if (hi[a] > 0.5) out.pad.hi[a] = static_cast<int64_t>(std::ceil(hi[a] + margin));
    }
  } else {
    for (size_t a = 0; a < 3; ++a)
      out.pad.lo[a] = out.pad.hi[a] = static_cast<int64_t>(std::ceil(padMm / g.spacing[int(a)] - 1e-9));
  }
  out.grid = paddedGeometry(g, out.pad);
  if (!out.content.empty()) {  // what lies outside the grid is cut: not framed
    BoxMm gridBox;
    for (const Vec3& p : voxelBoxCorners(out.grid)) gridBox.add(p);
    for (int a = 0; a < 3; ++a) {
      out.content.lo[a] = std::clamp(out.content.lo[a], gridBox.lo[a], gridBox.hi[a]);
      out.content.hi[a] = std::clamp(out.content.hi[a], gridBox.lo[a], gridBox.hi[a]);
    }
  }
  return out;
}

render::Camera framedOnContent(const Geometry& grid, const BoxMm& content, const render::Camera& asked) {
  if (content.empty()) return asked;
  // The renderer frames a grid by its voxel box's bounding sphere about its centre
  // (render_common.cpp: makeFrame); the content's sphere takes its place.
  const Vec3 centre = grid.indexToPhysical({(grid.dims.x - 1) * 0.5, (grid.dims.y - 1) * 0.5, (grid.dims.z - 1) * 0.5});
  const double gridRadius = voxelBoxRadius(grid, centre);
  const double contentRadius = std::max(0.5 * norm(content.hi - content.lo), 1e-3);
  render::Camera c = asked;
  c.panMm = (content.lo + content.hi) * 0.5 - centre + asked.panMm;
  c.zoom = std::min(asked.zoom * gridRadius / contentRadius, 50.0);  // the zoom row's limit
  return c;
}

}  // namespace vellum::app
