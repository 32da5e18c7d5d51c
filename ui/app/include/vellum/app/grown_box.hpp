#pragma once
// The output box grown to hold what moves (issue 23 §4, `--pad-mm`): `vellum deform --out`,
// `vellum pose --out` and `--movie`, `vellum animate` and the studio's movie export pad their
// volume by one rule. 0: the input's box; > 0: that margin (mm) on every side; -1 (automatic):
// per side, as far as the content passes that face when each pose's control points carry it,
// over every pose given (a movie: all its keyframes, so one grid holds every frame).
#include <algorithm>
#include <array>
#include <limits>
#include <optional>
#include <vector>

#include "vellum/core/box_corners.hpp"
#include "vellum/core/label_volume.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/core/volume.hpp"
#include "vellum/deformation/control_point.hpp"
#include "vellum/render/render_settings.hpp"

namespace vellum::app {

/// Voxels added below (lo) and above (hi) the box along each axis (x, y, z).
struct Padding {
  std::array<int64_t, 3> lo{0, 0, 0}, hi{0, 0, 0};
  bool none() const {
    return std::all_of(lo.begin(), lo.end(), [](int64_t v) { return v == 0; }) &&
           std::all_of(hi.begin(), hi.end(), [](int64_t v) { return v == 0; });
  }
};

/// `g` grown by `pad`: the origin moves out along the axes, so every voxel keeps its world position.
Geometry paddedGeometry(const Geometry& g, const Padding& pad);

/// `v` inside its box grown by `pad` (paddedGeometry), `fill` around.
template <class T>
Volume<T> padded(const Volume<T>& v, const Padding& pad, T fill) {
  const Geometry g = paddedGeometry(v.geometry(), pad);
  const Dims d = v.dims();
  Volume<T> out(g, fill, v.background());
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        std::copy_n(v.data() + (k * d.y + j) * d.x, d.x,
                    out.data() + ((k + pad.lo[2]) * g.dims.y + j + pad.lo[1]) * g.dims.x + pad.lo[0]);
  });
  return out;
}
/// Any volume padded with its background (CT: air, -1000 HU or what the volume says).
AnyVolume padded(const AnyVolume& v, const Padding& pad);
/// A label map padded with 0 (no label), its table kept.
LabelVolume padded(const LabelVolume& labels, const Padding& pad);

/// The padding that places `inner` inside `outer` at whole voxels (same spacing and direction,
/// within 1e-3 of a voxel); nullopt when `inner` is not such a part of `outer`.
std::optional<Padding> placementIn(const Geometry& inner, const Geometry& outer);
/// `labels` on `grid`: the same map, or placed in `grid` (0 around) when `grid` is its grid grown
/// by whole voxels. FileError-free: Error naming both grids otherwise (callers add the file).
LabelVolume labelsOnGrid(const LabelVolume& labels, const Geometry& grid);

/// The grown box of --pad-mm for a volume moved by one or more poses.
struct GrownBox {
  Padding pad;
  Geometry grid;  ///< the input's grid grown by `pad` (the output's, or the movie's for every frame)
  /// The content (CT above -500 HU, else above the background), sampled on a coarse lattice,
  /// where it is and where every pose carries it, clipped to `grid`: what a movie frames.
  BoxMm content;
};

/// The box of `padMm` (0: the input's; > 0: that margin on every side; -1: automatic) for
/// `volume` whose content each of `poses` moves (the control points, source -> target).
/// Automatic, per axis and side: each content sample (about 200 k on a coarse lattice, whatever
/// the size) moves as its nearest control point does (local: what still points hold does not
/// move, where the MLS field's far reach moved the top of the feet's legs 22 mm up); a side
/// grows by how far any pose carries a sample past its face, plus half the lattice step and a
/// control cell's diagonal (controlScale voxels: what the lattice and the blend may add). Sides
/// nothing moves out of stay: a foot flexing down grows the floor only. `withContent`: also
/// fill GrownBox::content (the samples are taken for -1 anyway).
GrownBox grownBox(const AnyVolume& volume, double padMm, const std::vector<deformation::ControlPoints>& poses,
                  int controlScale, bool withContent = false);

/// The camera that frames `content` in a render of `grid` the way the default camera frames a
/// whole volume: looking at the content box's centre, zoom 1 fitting its bounding sphere into
/// the shorter image side (a grown movie box is mostly air: its own sphere left the feet
/// small); `asked`'s zoom multiplies, its pan adds, its angles stay. `asked` when content is empty.
render::Camera framedOnContent(const Geometry& grid, const BoxMm& content, const render::Camera& asked);

}  // namespace vellum::app
