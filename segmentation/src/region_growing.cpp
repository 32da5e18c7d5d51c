#include "vellum/segmentation/region_growing.hpp"

#include <cmath>

#include "neighbors.hpp"

namespace vellum::segmentation {
namespace {

std::vector<int64_t> linearSeeds(const VolumeI16& ct, const std::vector<Vec3>& seedsMm) {
  std::vector<int64_t> out;
  for (const Index3& s : seedsToVoxels(ct.geometry(), seedsMm))
    out.push_back(static_cast<int64_t>(ct.linearIndex(s.i, s.j, s.k)));
  return out;
}

}  // namespace

Mask connectedThreshold(const VolumeI16& ct, const std::vector<Vec3>& seedsMm,
                        const HuInterval& interval, Connectivity connectivity, Progress& progress) {
  const auto starts = linearSeeds(ct, seedsMm);
  Mask out(ct.geometry(), 0, 0.0);
  progress.begin("region growing", 1);
  const int16_t* src = ct.data();
  detail::floodFill(ct.dims(), starts, connectivity,
                    [&](int64_t q) { return interval.contains(src[q]); }, out.data());
  progress.end();
  return out;
}

ConfidenceResult confidenceConnected(const VolumeI16& ct, const std::vector<Vec3>& seedsMm,
                                     const ConfidenceParams& p, Progress& progress) {
  if (seedsMm.empty()) throw Error("confidence-connected growing needs at least one seed");
  if (!(p.multiplier > 0) || p.iterations < 1)
    throw Error("confidence-connected: multiplier must be > 0 and iterations >= 1");
  const Geometry& g = ct.geometry();
  const auto seedVoxels = seedsToVoxels(g, seedsMm);

  // First estimate: the voxels within seedRadiusMm of each seed (at least the seed itself).
  double sum = 0, sum2 = 0, n = 0;
  for (const Index3& s : seedVoxels) {
    const double r = std::max(p.seedRadiusMm, 0.0);
    const int64_t ri = static_cast<int64_t>(std::floor(r / g.spacing.x));
    const int64_t rj = static_cast<int64_t>(std::floor(r / g.spacing.y));
    const int64_t rk = static_cast<int64_t>(std::floor(r / g.spacing.z));
    for (int64_t k = s.k - rk; k <= s.k + rk; ++k)
      for (int64_t j = s.j - rj; j <= s.j + rj; ++j)
        for (int64_t i = s.i - ri; i <= s.i + ri; ++i) {
          if (!g.contains(i, j, k)) continue;
          const double dx = (i - s.i) * g.spacing.x, dy = (j - s.j) * g.spacing.y,
                       dz = (k - s.k) * g.spacing.z;
          if (dx * dx + dy * dy + dz * dz > r * r) continue;
          const double v = ct(i, j, k);
          sum += v; sum2 += v * v; n += 1;
        }
  }
  ConfidenceResult res;
  progress.begin("confidence-connected growing", static_cast<uint64_t>(p.iterations));
  int64_t lastCount = -1;
  for (int it = 0; it < p.iterations; ++it) {
    res.mean = sum / n;
    res.stddev = std::sqrt(std::max(0.0, sum2 / n - res.mean * res.mean));
    // A minimum half-width of 1 HU keeps a perfectly flat seed region growable.
    const double half = std::max(p.multiplier * res.stddev, 1.0);
    res.finalInterval = {res.mean - half, res.mean + half};
    res.mask = connectedThreshold(ct, seedsMm, res.finalInterval, p.connectivity);
    res.iterations = it + 1;
    progress.advance();
    // Statistics of the grown region for the next pass.
    sum = sum2 = n = 0;
    const int16_t* src = ct.data();
    const uint8_t* m = res.mask.data();
    for (size_t q = 0; q < ct.size(); ++q)
      if (m[q]) { const double v = src[q]; sum += v; sum2 += v * v; n += 1; }
    if (n == 0) break;  // seeds outside their own interval: nothing grows
    if (static_cast<int64_t>(n) == lastCount) break;
    lastCount = static_cast<int64_t>(n);
  }
  progress.end();
  return res;
}

}  // namespace vellum::segmentation
