#include "vellum/segmentation/morphology.hpp"

#include <cmath>

#include "vellum/core/edt_engine.hpp"

namespace vellum::segmentation {
namespace {

// A hair of tolerance so that voxels exactly at the radius (e.g. r = 2 spacings) count.
float radius2(double r) { return static_cast<float>(r * r * (1.0 + 1e-6) + 1e-9); }

}  // namespace

// Both operations threshold the distance inside the transform's last pass: no float volume
// is stored or read back, and erosion measures from the background directly (no inverted copy).
Mask dilate(const Mask& m, double radiusMm, Progress& progress) {
  if (!(radiusMm > 0)) return m;
  Mask out(m.geometry(), 0, 0.0);
  VolumeF32 work(m.geometry(), 0.0f, 0.0);
  uint8_t* o = out.data();
  const float r2 = radius2(radiusMm);
  progress.begin("dilate", 1);
  vellum::detail::squaredEdt(m.data(), true, m.geometry(), work.data(), [&](int64_t q, float d2) { o[q] = d2 <= r2; }, r2);
  progress.end();
  return out;
}

Mask erode(const Mask& m, double radiusMm, Progress& progress) {
  if (!(radiusMm > 0)) return m;
  // Distance to the nearest background voxel inside the grid (outside counts as foreground).
  Mask out(m.geometry(), 0, 0.0);
  VolumeF32 work(m.geometry(), 0.0f, 0.0);
  const uint8_t* src = m.data();
  uint8_t* o = out.data();
  const float r2 = radius2(radiusMm);
  progress.begin("erode", 1);
  vellum::detail::squaredEdt(src, false, m.geometry(), work.data(), [&](int64_t q, float d2) { o[q] = src[q] && d2 > r2; }, r2);
  progress.end();
  return out;
}

Mask open(const Mask& m, double radiusMm, Progress& progress) {
  return dilate(erode(m, radiusMm, progress), radiusMm, progress);
}

Mask close(const Mask& m, double radiusMm, Progress& progress) {
  return erode(dilate(m, radiusMm, progress), radiusMm, progress);
}

Mask removeThin(const Mask& m, double radiusMm, Progress& progress) {
  if (!(radiusMm > 0)) return m;
  // The reach one voxel diagonal past the radius keeps the voxel layer that open() shaves off
  // a thick object's rough surface and corners, so a bone keeps its volume.
  const Vec3 s = m.geometry().spacing;
  Mask keep = dilate(erode(m, radiusMm, progress), radiusMm + std::sqrt(s.x * s.x + s.y * s.y + s.z * s.z), progress);
  const uint8_t* src = m.data();
  uint8_t* k = keep.data();
  for (size_t n = 0; n < keep.size(); ++n) k[n] = k[n] && src[n];
  return keep;
}

}  // namespace vellum::segmentation
