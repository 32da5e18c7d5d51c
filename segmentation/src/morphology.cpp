#include "vellum/segmentation/morphology.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <vector>

#include "vellum/core/distance_transform.hpp"
#include "vellum/core/edt_engine.hpp"
#include "vellum/core/parallel.hpp"

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
  const Geometry& g = m.geometry();
  const Dims d = g.dims;
  const Vec3 s = g.spacing;
  const double diagonal = std::sqrt(s.x * s.x + s.y * s.y + s.z * s.z);
  // The reach one voxel diagonal past the radius keeps the voxel layer that open() shaves off
  // a thick object's rough surface and corners, so a bone keeps its volume.
  // One distance to the core serves both reaches (the opening's and the kept one).
  const VolumeF32 toCore2 = squaredDistanceMm(erode(m, radiusMm, progress), progress);
  const float opened2 = radius2(radiusMm), kept2 = radius2(radiusMm + diagonal);
  Mask keep(g, 0, 0.0);
  const uint8_t* src = m.data();
  const float* dc = toCore2.data();
  uint8_t* k = keep.data();
  std::vector<int64_t> thin;
  Mask isThin(g, 0, 0.0);  // what open() removes: the thin parts with their stubs and a thick object's edges
  for (size_t n = 0; n < keep.size(); ++n) {
    k[n] = src[n] && dc[n] <= kept2;
    if (src[n] && !k[n]) thin.push_back(static_cast<int64_t>(n));
    isThin.data()[n] = src[n] && dc[n] > opened2;
  }
  // Of the thin parts only tubes go: a wire or a cord runs along one direction, while a bone's
  // thin cortical wall over a dark inside is a sheet. Around each thin voxel, the voxels that
  // open() would remove within reach (so a short bridge is seen with its stubs) must spread
  // along their first principal axis only (second variance under a fifth of the first: a
  // strip narrower than about 0.9 * reach counts as a tube).
  const double reach = 2 * radiusMm + diagonal;
  const int64_t hx = static_cast<int64_t>(std::ceil(reach / s.x)), hy = static_cast<int64_t>(std::ceil(reach / s.y)),
                hz = static_cast<int64_t>(std::ceil(reach / s.z));
  std::vector<uint8_t> sheet(thin.size(), 0);
  parallelFor(static_cast<int64_t>(thin.size()), [&](int64_t t0, int64_t t1) {
    for (int64_t t = t0; t < t1; ++t) {
      const int64_t n = thin[size_t(t)];
      const int64_t i = n % d.x, j = (n / d.x) % d.y, kk = n / (d.x * d.y);
      double sum[3] = {0, 0, 0}, sq[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
      int64_t count = 0;
      for (int64_t c = std::max<int64_t>(0, kk - hz); c <= std::min<int64_t>(d.z - 1, kk + hz); ++c)
        for (int64_t b = std::max<int64_t>(0, j - hy); b <= std::min<int64_t>(d.y - 1, j + hy); ++b)
          for (int64_t a = std::max<int64_t>(0, i - hx); a <= std::min<int64_t>(d.x - 1, i + hx); ++a) {
            if (!isThin(a, b, c)) continue;
            const double o[3] = {(a - i) * s.x, (b - j) * s.y, (c - kk) * s.z};
            if (o[0] * o[0] + o[1] * o[1] + o[2] * o[2] > reach * reach) continue;
            ++count;
            for (int p = 0; p < 3; ++p) {
              sum[p] += o[p];
              for (int q = 0; q < 3; ++q) sq[p][q] += o[p] * o[q];
            }
          }
      if (count < 4) { sheet[size_t(t)] = 1; continue; }  // a speck, not a tube: kept
      Eigen::Matrix3d cov;
      for (int p = 0; p < 3; ++p)
        for (int q = 0; q < 3; ++q) cov(p, q) = sq[p][q] / double(count) - sum[p] * sum[q] / (double(count) * count);
      const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov, Eigen::EigenvaluesOnly).eigenvalues();
      sheet[size_t(t)] = ev(1) >= 0.2 * ev(2);  // ascending: ev(2) the largest
    }
  });
  for (size_t t = 0; t < thin.size(); ++t)
    if (sheet[t]) k[thin[t]] = 1;
  return keep;
}

}  // namespace vellum::segmentation
