#include "vellum/core/distance_transform.hpp"

#include <cmath>

#include "vellum/core/edt_engine.hpp"

namespace vellum {

VolumeF32 squaredDistanceMm(const VolumeU8& features, Progress& progress) {
  VolumeF32 out(features.geometry(), 0.0f, 0.0);
  progress.begin("distance transform", 1);
  float* o = out.data();
  // The last pass writes into the same buffer it reads: each block is gathered before it is
  // written back, and blocks do not overlap.
  detail::squaredEdt(features.data(), true, features.geometry(), o, [o](int64_t q, float d2) { o[q] = d2; });
  progress.end();
  return out;
}

VolumeF32 signedDistanceMm(const VolumeU8& mask, Progress& progress) {
  const Geometry& g = mask.geometry();
  VolumeF32 out(g, 0.0f, 0.0);
  VolumeF32 work(g, 0.0f, 0.0);
  const uint8_t* m = mask.data();
  float* o = out.data();
  progress.begin("signed distance transform", 2);
  // Outside voxels: distance to the nearest inside voxel.
  detail::squaredEdt(m, true, g, work.data(), [&](int64_t q, float d2) { o[q] = m[q] ? 0.0f : std::sqrt(d2); });
  progress.advance();
  // Inside voxels: minus the distance to the nearest outside voxel.
  detail::squaredEdt(m, false, g, work.data(), [&](int64_t q, float d2) {
    if (m[q]) o[q] = -std::sqrt(d2);
  });
  progress.end();
  return out;
}

}  // namespace vellum
