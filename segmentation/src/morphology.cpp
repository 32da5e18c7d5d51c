#include "vellum/segmentation/morphology.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "vellum/segmentation/distance_transform.hpp"

namespace vellum::segmentation {
namespace {

// A hair of tolerance so that voxels exactly at the radius (e.g. r = 2 spacings) count.
double radius2(double r) { return r * r * (1.0 + 1e-9) + 1e-12; }

}  // namespace

Mask dilate(const Mask& m, double radiusMm, Progress& progress) {
  if (!(radiusMm > 0)) return m;
  const VolumeF32 d2 = squaredDistanceMm(m, progress);
  Mask out(m.geometry(), 0, 0.0);
  const float* d = d2.data();
  uint8_t* o = out.data();
  const double r2 = radius2(radiusMm);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, m.size(), 1 << 16),
                    [&](const tbb::blocked_range<size_t>& r) {
                      for (size_t i = r.begin(); i < r.end(); ++i) o[i] = d[i] <= r2;
                    });
  return out;
}

Mask erode(const Mask& m, double radiusMm, Progress& progress) {
  if (!(radiusMm > 0)) return m;
  // Distance to the nearest background voxel inside the grid (outside counts as foreground).
  const VolumeF32 d2 = squaredDistanceMm(maskNot(m), progress);
  Mask out(m.geometry(), 0, 0.0);
  const float* d = d2.data();
  const uint8_t* src = m.data();
  uint8_t* o = out.data();
  const double r2 = radius2(radiusMm);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, m.size(), 1 << 16),
                    [&](const tbb::blocked_range<size_t>& r) {
                      for (size_t i = r.begin(); i < r.end(); ++i) o[i] = src[i] && d[i] > r2;
                    });
  return out;
}

Mask open(const Mask& m, double radiusMm, Progress& progress) {
  return dilate(erode(m, radiusMm, progress), radiusMm, progress);
}

Mask close(const Mask& m, double radiusMm, Progress& progress) {
  return erode(dilate(m, radiusMm, progress), radiusMm, progress);
}

}  // namespace vellum::segmentation
