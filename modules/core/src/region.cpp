#include "vellum/core/region.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include "vellum/core/box_corners.hpp"
#include "vellum/core/cropped_geometry.hpp"
#include "vellum/core/downsample.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/memory_budget.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum {
Geometry croppedGeometry(const Geometry& g, const VoxelBox& box) {
  Geometry out = g;
  out.dims = box.dims();
  out.origin = g.indexToPhysical({double(box.lo[0]), double(box.lo[1]), double(box.lo[2])});
  return out;
}

namespace {

Geometry downsampledGeometry(const Geometry& g, int n) {
  Geometry out = g;
  out.dims = {(g.dims.x + n - 1) / n, (g.dims.y + n - 1) / n, (g.dims.z + n - 1) / n};
  out.spacing = g.spacing * double(n);
  // Voxel (0,0,0) of the result stands for block [0, n-1]^3: its centre is at
  // index (n-1)/2.
  const double c = 0.5 * (n - 1);
  out.origin = g.indexToPhysical({c, c, c});
  return out;
}

void checkFactor(int n) {
  if (n < 1 || n > 16) throw Error("downsample factor " + std::to_string(n) + " is outside 1..16");
}

}  // namespace

VoxelBox regionBox(const Geometry& g, const Region& region) {
  VoxelBox box{{0, 0, 0}, {g.dims.x - 1, g.dims.y - 1, g.dims.z - 1}};
  const std::array<int64_t, 3> dims{g.dims.x, g.dims.y, g.dims.z};
  if (region.cropVoxels && region.cropMm) throw Error("crop by voxels or by mm, not both");
  if (region.cropVoxels) {
    box = *region.cropVoxels;
    for (int a = 0; a < 3; ++a)
      if (box.lo[a] < 0 || box.hi[a] >= dims[a] || box.lo[a] > box.hi[a])
        throw Error("crop box " + std::to_string(box.lo[a]) + ".." + std::to_string(box.hi[a]) + " on axis " +
                    "ijk"[a] + " does not fit the volume's 0.." + std::to_string(dims[a] - 1));
  } else if (region.cropMm) {
    // The index-space bounding box of the physical box's eight corners, rounded
    // inwards.
    Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
    const auto& c = *region.cropMm;
    for (const Vec3& p : boxCorners(c[0], c[1])) {
      const Vec3 ijk = g.physicalToIndex(p);
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(lo[a], ijk[a]);
        hi[a] = std::max(hi[a], ijk[a]);
      }
    }
    for (int a = 0; a < 3; ++a) {
      box.lo[a] = std::max<int64_t>(0, int64_t(std::ceil(lo[a] - 1e-9)));
      box.hi[a] = std::min<int64_t>(dims[a] - 1, int64_t(std::floor(hi[a] + 1e-9)));
      if (box.lo[a] > box.hi[a])
        throw Error(std::string("crop box in mm holds no voxel centre along axis ") + "ijk"[a]);
    }
  }
  return box;
}

AnyVolume cropVolume(const AnyVolume& v, const VoxelBox& box) {
  return std::visit(
      [&](const auto& vol) -> AnyVolume {
        using T = typename std::decay_t<decltype(vol)>::value_type;
        const Geometry g = croppedGeometry(vol.geometry(), regionBox(vol.geometry(), Region{box, {}, 1}));
        checkMemoryBudget(g.dims, sizeof(T), "cropped volume");
        std::decay_t<decltype(vol)> out(g, T{}, vol.background());
        parallelFor(g.dims.z, [&](int64_t k0, int64_t k1) {
          for (int64_t k = k0; k < k1; ++k)
            for (int64_t j = 0; j < g.dims.y; ++j)
              std::copy_n(&vol(box.lo[0], box.lo[1] + j, box.lo[2] + k), g.dims.x, &out(0, j, k));
        });
        return out;
      },
      v);
}

namespace {
template <class T>
Volume<T> downsampleMeanOf(const Volume<T>& vol, int n) {
  const Dims d = vol.dims();
  const Geometry g = downsampledGeometry(vol.geometry(), n);
  Volume<T> out(g, T{}, vol.background());
  parallelFor(g.dims.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < g.dims.y; ++j)
        for (int64_t i = 0; i < g.dims.x; ++i) {
          double sum = 0;
          int64_t count = 0;
          for (int64_t z = k * n; z < std::min(d.z, (k + 1) * n); ++z)
            for (int64_t y = j * n; y < std::min(d.y, (j + 1) * n); ++y)
              for (int64_t x = i * n; x < std::min(d.x, (i + 1) * n); ++x, ++count) sum += vol(x, y, z);
          const double mean = sum / double(count);
          out(i, j, k) = std::is_integral_v<T> ? T(std::lround(mean)) : T(mean);
        }
  });
  return out;
}
}  // namespace

AnyVolume downsampleMean(const AnyVolume& v, int n) {
  checkFactor(n);
  if (n == 1) return v;
  return std::visit([&](const auto& vol) -> AnyVolume { return downsampleMeanOf(vol, n); }, v);
}

VolumeI16 downsampleMean(const VolumeI16& v, int n) {
  checkFactor(n);
  if (n == 1) return v;
  return downsampleMeanOf(v, n);
}

VolumeU16 downsampleMode(const VolumeU16& ids, int n) {
  checkFactor(n);
  if (n == 1) return ids;
  const Dims d = ids.dims();
  const Geometry g = downsampledGeometry(ids.geometry(), n);
  VolumeU16 out(g, 0, ids.background());
  parallelFor(g.dims.z, [&](int64_t k0, int64_t k1) {
    std::map<uint16_t, int> counts;
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < g.dims.y; ++j)
        for (int64_t i = 0; i < g.dims.x; ++i) {
          counts.clear();
          for (int64_t z = k * n; z < std::min(d.z, (k + 1) * n); ++z)
            for (int64_t y = j * n; y < std::min(d.y, (j + 1) * n); ++y)
              for (int64_t x = i * n; x < std::min(d.x, (i + 1) * n); ++x) ++counts[ids(x, y, z)];
          uint16_t best = 0;
          int bestCount = -1;
          for (const auto& [id, c] : counts)  // ascending ids: ties keep the smallest
            if (c > bestCount) best = id, bestCount = c;
          out(i, j, k) = best;
        }
  });
  return out;
}

AnyVolume applyRegion(const AnyVolume& v, const Region& region) {
  if (region.empty()) return v;
  const Geometry& g = geometryOf(v);
  const VoxelBox box = regionBox(g, region);
  const bool crops = box.dims().voxelCount() != g.dims.voxelCount();
  return downsampleMean(crops ? cropVolume(v, box) : v, region.downsample);
}

VolumeU16 applyRegionToLabels(const VolumeU16& ids, const Region& region) {
  if (region.empty()) return ids;
  const VoxelBox box = regionBox(ids.geometry(), region);
  const bool crops = box.dims().voxelCount() != ids.dims().voxelCount();
  return downsampleMode(crops ? std::get<VolumeU16>(cropVolume(ids, box)) : ids, region.downsample);
}

}  // namespace vellum
